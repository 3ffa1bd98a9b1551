//! The augmented modes' yaw: the rudder stick's yaw-rate command flown as a heading lock, as
//! a heading-hold gyro flies it and as ArduPilot's attitude controller takes a pilot's yaw
//! rate. The command, shaped to a largest yaw acceleration, moves a heading reference; the
//! rate flown is the shaped command plus a correction toward the reference. A disturbance
//! that turns the helicopter (the fin's and the tail rotor's weathervane moment as it turns
//! through a crosswind) is held off by the heading loop instead of by the tail integrator
//! alone, which follows only slowly. The reference leads the heading by at most
//! [`HEADING_LEASH_RAD`], so a saturated tail does not store up a turn to fly later.

use heli_nav::navigator::wrap_pi;

use crate::sanitize_dt;

/// Largest lead of the reference over the heading (rad): 20 deg.
pub const HEADING_LEASH_RAD: f64 = 0.35;

/// Largest yaw acceleration of the shaped command (rad/s²): 270 deg/s², ArduPilot's
/// `ATC_ACCEL_Y_MAX` default. A stick snapped to centre stops the reference over about
/// 0.1 s instead of at once, so the tail does not bounce back to where the stick let go.
pub const YAW_ACCEL_MAX_RPS2: f64 = 4.7;

/// Heading reference and shaped rate command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HeadingLock {
    reference_rad: Option<f64>,
    rate_rps: f64,
}

impl HeadingLock {
    /// The yaw rate to fly (rad/s) for the pilot's command `r_cmd_rps` at heading `yaw_rad`,
    /// with `gain` (1/s) from heading error to rate. On the ground (`airborne` false) the
    /// reference stays on the heading: the skids turn the fuselage, not the loop.
    pub fn rate(
        &mut self,
        yaw_rad: f64,
        r_cmd_rps: f64,
        gain: f64,
        dt_s: f64,
        airborne: bool,
    ) -> f64 {
        let dt = sanitize_dt(dt_s);
        let step = YAW_ACCEL_MAX_RPS2 * dt;
        let shaped = self.rate_rps + (r_cmd_rps - self.rate_rps).clamp(-step, step);
        self.rate_rps = if shaped.is_finite() { shaped } else { 0.0 };
        let reference = match self.reference_rad {
            Some(r) if airborne && r.is_finite() => r + self.rate_rps * dt,
            _ => yaw_rad,
        };
        let lead = wrap_pi(reference - yaw_rad).clamp(-HEADING_LEASH_RAD, HEADING_LEASH_RAD);
        self.reference_rad = Some(wrap_pi(yaw_rad + lead));
        self.rate_rps + gain * lead
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.02;

    #[test]
    fn a_helicopter_held_back_is_asked_to_catch_up_up_to_the_leash() {
        let mut lock = HeadingLock::default();
        let mut flown = 0.0;
        // The pilot asks for 0.5 rad/s for 2 s; the helicopter does not turn at all.
        for _ in 0..100 {
            flown = lock.rate(0.0, 0.5, 6.0, DT, true);
        }
        assert!(
            (flown - (0.5 + 6.0 * HEADING_LEASH_RAD)).abs() < 1e-9,
            "{flown}"
        );
    }

    #[test]
    fn a_helicopter_that_follows_is_asked_for_the_command_alone() {
        let mut lock = HeadingLock::default();
        let mut yaw = 0.0;
        let mut flown = 0.0;
        for _ in 0..200 {
            flown = lock.rate(yaw, 0.5, 6.0, DT, true);
            yaw = wrap_pi(yaw + flown * DT);
        }
        assert!((flown - 0.5).abs() < 1e-6, "{flown}");
    }

    #[test]
    fn the_command_is_shaped_to_the_largest_yaw_acceleration() {
        let mut lock = HeadingLock::default();
        let first = lock.rate(0.0, 2.0, 0.0, DT, true);
        assert!((first - YAW_ACCEL_MAX_RPS2 * DT).abs() < 1e-12, "{first}");
    }

    #[test]
    fn a_turn_pushed_by_the_wind_is_held_back_to_the_reference() {
        let mut lock = HeadingLock::default();
        lock.rate(0.0, 0.0, 6.0, DT, true);
        // Blown 0.1 rad to the right with the stick centred: the lock asks to turn back.
        let flown = lock.rate(0.1, 0.0, 6.0, DT, true);
        assert!((flown + 0.6).abs() < 1e-9, "{flown}");
    }

    #[test]
    fn on_the_ground_the_reference_follows_the_heading() {
        let mut lock = HeadingLock::default();
        for i in 0..50 {
            let flown = lock.rate(f64::from(i) * 0.1, 0.0, 6.0, DT, false);
            assert_eq!(flown, 0.0);
        }
    }

    #[test]
    fn a_nan_command_or_heading_leaves_a_finite_rate() {
        let mut lock = HeadingLock::default();
        lock.rate(0.0, f64::NAN, 6.0, DT, true);
        let flown = lock.rate(0.0, 0.3, 6.0, DT, true);
        assert!(flown.is_finite(), "{flown}");
    }
}
