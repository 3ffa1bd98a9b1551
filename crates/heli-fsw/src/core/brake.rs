//! Stopping from forward flight: a hold begun in motion (the end of a path or a roll
//! sequence, transmitter loss, the auto switch) decelerates along the way it was going at a
//! set rate, then holds where it stopped — rather than holding a point it has already
//! passed and crawling back, or chasing a stopping point that rides along with it.

use heli_control::Target;
use heli_nav::{NavState, seconds_between};
use nalgebra::Vector3;

/// Deceleration of a stop (m/s²): under the hover controller's acceleration limit, so that
/// the profile can be flown with room to correct.
pub const BRAKE_DECEL_MPS2: f64 = 2.0;

/// Below this ground speed (m/s) a hold needs no stop: it holds where it is.
pub const BRAKE_ABOVE_MPS: f64 = 1.0;

/// A stop is over once the helicopter is slower than this (m/s); until then, a helicopter
/// that ran past the profile's end is held where it is along the way.
pub const BRAKE_SETTLED_MPS: f64 = 0.3;

/// A stop under way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brake {
    start_us: u64,
    from_ned_m: Vector3<f64>,
    /// Horizontal velocity when the stop began (m/s, NED).
    vel0_ned_mps: Vector3<f64>,
}

impl Brake {
    /// A stop from the estimate's position and horizontal velocity, if it is moving.
    pub fn begin(now_us: u64, est: &NavState) -> Option<Self> {
        let vel0 = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        (vel0.norm() > BRAKE_ABOVE_MPS).then_some(Self {
            start_us: now_us,
            from_ned_m: est.pos_ned_m,
            vel0_ned_mps: vel0,
        })
    }

    fn stop_time_s(&self) -> f64 {
        self.vel0_ned_mps.norm() / BRAKE_DECEL_MPS2
    }

    /// Where the stop ends for a helicopter at `pos_ned_m`: the profile's end, or further
    /// along the way if it ran past it (it is held where it stopped, never flown back).
    pub fn stop_for(&self, pos_ned_m: &Vector3<f64>) -> Vector3<f64> {
        let dir = self.vel0_ned_mps / self.vel0_ned_mps.norm().max(1e-9);
        let end = self.stopping_point();
        let beyond = (pos_ned_m - end).dot(&dir).max(0.0);
        end + dir * beyond
    }

    /// Where the stop's profile ends (horizontal; m, NED).
    pub fn stopping_point(&self) -> Vector3<f64> {
        // v0 · t_stop / 2 along the way: v0² / 2a.
        self.from_ned_m + self.vel0_ned_mps * (0.5 * self.stop_time_s())
    }

    /// The target at `now_us`: along the deceleration profile, at the height and heading
    /// of `hold`; `None` once the profile has reached its stop.
    pub fn target(&self, now_us: u64, hold: &Target) -> Option<Target> {
        let t = seconds_between(self.start_us, now_us);
        let t_stop = self.stop_time_s();
        if t >= t_stop {
            return None;
        }
        let dir = self.vel0_ned_mps / self.vel0_ned_mps.norm().max(1e-9);
        let v0 = self.vel0_ned_mps.norm();
        let along = v0 * t - 0.5 * BRAKE_DECEL_MPS2 * t * t;
        let mut pos = self.from_ned_m + dir * along;
        pos.z = hold.pos_ned_m.z;
        Some(Target {
            pos_ned_m: pos,
            vel_ned_mps: dir * (v0 - BRAKE_DECEL_MPS2 * t),
            yaw_rad: hold.yaw_rad,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moving(vel_ned_mps: Vector3<f64>) -> NavState {
        NavState {
            t_us: 0,
            att: nalgebra::UnitQuaternion::identity(),
            vel_ned_mps,
            pos_ned_m: Vector3::new(10.0, 0.0, -20.0),
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: Vector3::zeros(),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        }
    }

    #[test]
    fn a_stop_decelerates_at_its_rate_and_ends_where_v_squared_over_2a_says() {
        assert_eq!(Brake::begin(0, &moving(Vector3::new(0.5, 0.0, 0.0))), None);
        let brake = Brake::begin(1_000_000, &moving(Vector3::new(8.0, 0.0, 1.0)))
            .unwrap_or_else(|| panic!("moving at 8 m/s"));
        // 8 m/s at 2 m/s²: 4 s and 16 m.
        assert!((brake.stopping_point() - Vector3::new(26.0, 0.0, -20.0)).norm() < 1e-9);
        let hold = Target::hold(Vector3::new(0.0, 0.0, -25.0), 0.3);
        let at = |t_s: f64| brake.target(1_000_000 + (t_s * 1e6) as u64, &hold);
        let start = at(0.0).unwrap_or_else(|| panic!("under way"));
        assert!((start.vel_ned_mps.x - 8.0).abs() < 1e-9 && start.vel_ned_mps.z == 0.0);
        let half = at(2.0).unwrap_or_else(|| panic!("under way"));
        assert!((half.vel_ned_mps.x - 4.0).abs() < 1e-9);
        assert!((half.pos_ned_m.x - (10.0 + 12.0)).abs() < 1e-9, "8·2 − 2²");
        assert_eq!(half.pos_ned_m.z, -25.0, "at the hold's height");
        assert_eq!(half.yaw_rad, 0.3);
        assert_eq!(at(4.0), None, "stopped");
    }

    #[test]
    fn a_helicopter_that_ran_past_the_stop_is_held_where_it_stopped() {
        let brake = Brake::begin(0, &moving(Vector3::new(0.0, 6.0, 0.0)))
            .unwrap_or_else(|| panic!("moving at 6 m/s"));
        // 6 m/s east at 2 m/s²: 9 m east of (10, 0).
        let end = Vector3::new(10.0, 9.0, -20.0);
        assert!((brake.stopping_point() - end).norm() < 1e-9);
        // Short of the end, or off to the side: the end.
        assert!((brake.stop_for(&Vector3::new(10.0, 5.0, -20.0)) - end).norm() < 1e-9);
        assert!((brake.stop_for(&Vector3::new(13.0, 9.0, -20.0)) - end).norm() < 1e-9);
        // 3 m past it along the way: there.
        let past = brake.stop_for(&Vector3::new(10.0, 12.0, -20.0));
        assert!(
            (past - Vector3::new(10.0, 12.0, -20.0)).norm() < 1e-9,
            "{past:?}"
        );
        // Just above the braking speed it brakes; at it, it does not.
        assert!(Brake::begin(0, &moving(Vector3::new(0.0, BRAKE_ABOVE_MPS, 0.0))).is_none());
        assert!(Brake::begin(0, &moving(Vector3::new(0.0, BRAKE_ABOVE_MPS + 0.01, 0.0))).is_some());
    }

    #[test]
    fn at_the_end_of_the_stop_the_hold_moves_to_where_it_stopped_and_stays_once_still() {
        let mut core =
            super::super::sequencer::Sequencer::new(super::super::FlightParams::default());
        let est = moving(Vector3::new(0.0, 6.0, 0.0));
        core.braking = Brake::begin(0, &est);
        let hold = Target::hold(Vector3::new(0.0, 0.0, -25.0), 0.3);
        // Under way: on the profile.
        let on_the_way = core.braking_target(hold, 1_000_000, &est);
        assert!((on_the_way.pos_ned_m.y - (6.0 - 1.0)).abs() < 1e-9);
        // Over (3 s): at the stop, at the hold's height; still moving, so still braking.
        let mut moving_on = est;
        moving_on.pos_ned_m = Vector3::new(10.0, 12.0, -20.0);
        moving_on.vel_ned_mps = Vector3::new(0.0, 0.5, 0.0);
        let t = core.braking_target(hold, 3_000_000, &moving_on);
        assert_eq!(t, Target::hold(Vector3::new(10.0, 12.0, -25.0), 0.3));
        assert!(core.braking.is_some());
        // Stopped (under 0.3 m/s): the stop is over.
        let mut still = moving_on;
        still.vel_ned_mps = Vector3::new(0.0, 0.29, 0.0);
        core.braking_target(hold, 3_100_000, &still);
        assert!(core.braking.is_none());
        assert_eq!(core.braking_target(hold, 3_200_000, &still), hold);
    }
}
