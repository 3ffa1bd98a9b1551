//! A degraded estimate in flight: with no GPS fix fused for [`GPS_LOSS_LAND_AFTER_S`] the
//! position estimate coasts on the IMU and drifts without bound, so an autonomous hold, path
//! or climb is given up and the helicopter lands where it is, slowly, on the height the
//! altimeter and the IMU still keep (as ArduPilot's EKF failsafe lands and PX4 descends when
//! the position estimate is lost). The pilot takes it back with the auto switch. The filter's
//! health (test ratios, time since each aid was fused, `heli_nav::FilterHealth`) is what is
//! judged.

use heli_control::Target;
use heli_nav::NavState;
use nalgebra::Vector3;

use crate::phase::Phase;

/// Longest an autonomous flight goes on with no GPS fix fused before it lands (s): twice
/// the longest outage the filter is tested to coast through (10 s within 5 m).
pub const GPS_LOSS_LAND_AFTER_S: f64 = 20.0;

/// Down where it is: a slow vertical landing, heading kept.
pub fn land_where_it_is(est: &NavState) -> Phase {
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

/// Whether an autonomous flight (in the air once, holding, flying a path or climbing) must
/// land for want of GPS: the seconds since the last fix was fused (asked of the filter only
/// then), when more than [`GPS_LOSS_LAND_AFTER_S`].
pub fn landing_due(
    airborne_once: bool,
    phase: &Phase,
    since_gps_s: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    if !airborne_once
        || !matches!(
            phase,
            Phase::Holding { .. } | Phase::Flying { .. } | Phase::TakingOff { .. }
        )
    {
        return None;
    }
    match since_gps_s() {
        Some(s) if s <= GPS_LOSS_LAND_AFTER_S => None,
        other => other,
    }
}
