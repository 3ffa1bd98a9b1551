//! A degraded estimate in flight: with no GPS fix fused for [`GPS_LOSS_LAND_AFTER_S`] the
//! position estimate coasts on the IMU and drifts without bound, so an autonomous hold, path
//! or climb is given up and the helicopter lands where it is, slowly, on the height the
//! altimeter and the IMU still keep (as ArduPilot's EKF failsafe lands and PX4 descends when
//! the position estimate is lost). The pilot takes it back with the auto switch. The filter's
//! health (test ratios, time since each aid was fused, `heli_nav::FilterHealth`) is what is
//! judged.

use super::*;

/// Longest an autonomous flight goes on with no GPS fix fused before it lands (s): twice
/// the longest outage the filter is tested to coast through (10 s within 5 m).
pub const GPS_LOSS_LAND_AFTER_S: f64 = 20.0;

impl FlightCore {
    /// The landing a degraded estimate calls for, once, if the phase is an autonomous one
    /// in the air.
    pub(super) fn land_if_degraded(
        &mut self,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Option<Phase> {
        if !self.airborne_once
            || !matches!(
                self.phase,
                Phase::Holding { .. } | Phase::Flying { .. } | Phase::TakingOff { .. }
            )
        {
            return None;
        }
        let since_gps_s = self.nav.health(now_us).since_gps_s?;
        if since_gps_s <= GPS_LOSS_LAND_AFTER_S {
            return None;
        }
        self.plan_abandoned = true;
        self.braking = None;
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::EstimateDegraded { since_gps_s },
        )));
        Some(land_where_it_is(est))
    }
}

/// A slow landing (0.5 m/s) where the helicopter is, on its heading.
pub(super) fn land_where_it_is(est: &NavState) -> Phase {
    let (_, _, yaw) = est.euler_rad();
    Phase::Landing {
        settled_since_us: None,
        target: Target {
            pos_ned_m: est.pos_ned_m,
            vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
            yaw_rad: yaw,
        },
    }
}
