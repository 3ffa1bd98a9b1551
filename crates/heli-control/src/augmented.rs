//! Augmented flight: the pilot flies, the computer changes what the sticks mean (thesis §2.2,
//! §3.4: "high bandwidth rate and velocity-tracking feedback controllers" an expert pilot used
//! for aggressive maneuvers). Built from the same stages as the hover controller.

use heli_nav::NavState;
use heli_proto::scb::Controls;
use heli_types::AugmentedMode;
use nalgebra::Vector3;

use crate::hover::HoverController;
use crate::sanitize_dt;
use crate::{GOVERNED_THROTTLE, limit};

/// Full-stick values of the augmented modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StickScales {
    /// Roll and pitch rate at full stick (rad/s).
    pub rate_rps: f64,
    /// Roll and pitch angle at full stick (rad).
    pub angle_rad: f64,
    /// Horizontal speed at full stick (m/s).
    pub speed_mps: f64,
    /// Climb rate at full collective stick (m/s).
    pub climb_mps: f64,
    /// Yaw rate at full rudder (rad/s).
    pub yaw_rate_rps: f64,
}

impl Default for StickScales {
    fn default() -> Self {
        Self {
            rate_rps: 2.0,
            angle_rad: 0.5,
            speed_mps: 5.0,
            climb_mps: 2.0,
            yaw_rate_rps: 2.0,
        }
    }
}

/// The velocity (m/s, forward, right, down) the sticks command in velocity mode.
pub fn commanded_velocity(sticks: &Controls, scales: &StickScales) -> Vector3<f64> {
    Vector3::new(
        -limit(sticks.elevator, 1.0) * scales.speed_mps,
        limit(sticks.aileron, 1.0) * scales.speed_mps,
        -limit(sticks.collective, 1.0) * scales.climb_mps,
    )
}

/// One step of augmented control. Pilot stick conventions are those of the servos: aileron
/// right, elevator back (nose up), rudder right, collective up.
pub fn augmented_controls(
    mode: AugmentedMode,
    sticks: &Controls,
    est: &NavState,
    scales: &StickScales,
    inner: &mut HoverController,
    dt_s: f64,
    airborne: bool,
) -> Controls {
    let dt = sanitize_dt(dt_s);
    let r_cmd = limit(sticks.rudder, 1.0) * scales.yaw_rate_rps;
    let (aileron, elevator, collective) = match mode {
        AugmentedMode::Rate => {
            let p = limit(sticks.aileron, 1.0) * scales.rate_rps;
            let q = limit(sticks.elevator, 1.0) * scales.rate_rps;
            let (a, e) = inner.rates_to_cyclic(est, p, q);
            (a, e, sticks.collective)
        }
        AugmentedMode::Attitude => {
            let roll = limit(sticks.aileron, 1.0) * scales.angle_rad;
            let pitch = limit(sticks.elevator, 1.0) * scales.angle_rad;
            let (a, e) = inner.attitude_to_cyclic(est, roll, pitch);
            (a, e, sticks.collective)
        }
        AugmentedMode::Velocity => {
            let v_body = commanded_velocity(sticks, scales);
            let (_, _, yaw) = est.euler_rad();
            let (s, c) = yaw.sin_cos();
            let v_ned = Vector3::new(
                c * v_body.x - s * v_body.y,
                s * v_body.x + c * v_body.y,
                0.0,
            );
            let (roll, pitch) = inner.velocity_to_attitude(est, &v_ned, dt, airborne);
            let (a, e) = inner.attitude_to_cyclic(est, roll, pitch);
            (a, e, inner.climb_to_collective(est, v_body.z, dt))
        }
    };
    let (_, _, yaw) = est.euler_rad();
    let gain = inner.gains.heading_lock_to_rate;
    let r_flown = inner.heading_lock.rate(yaw, r_cmd, gain, dt, airborne);
    let rudder = inner.yaw_rate_to_tail(est, r_flown, collective, dt, airborne);
    let throttle = match mode {
        AugmentedMode::Velocity => GOVERNED_THROTTLE,
        AugmentedMode::Rate | AugmentedMode::Attitude => sticks.throttle,
    };
    Controls {
        aileron,
        elevator,
        rudder,
        collective: limit(collective, 1.0),
        throttle,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::HoverGains;
    use nalgebra::UnitQuaternion;

    fn level() -> NavState {
        NavState {
            t_us: 0,
            att: UnitQuaternion::identity(),
            vel_ned_mps: Vector3::zeros(),
            pos_ned_m: Vector3::zeros(),
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: Vector3::new(0.0, 0.0, -9.81),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        }
    }

    #[test]
    fn each_mode_reads_the_sticks_its_own_way() {
        let scales = StickScales::default();
        let right = Controls {
            aileron: 0.5,
            collective: 0.3,
            throttle: 0.8,
            ..Controls::default()
        };
        for mode in [
            AugmentedMode::Rate,
            AugmentedMode::Attitude,
            AugmentedMode::Velocity,
        ] {
            let mut inner = HoverController::new(HoverGains::default());
            let u = augmented_controls(mode, &right, &level(), &scales, &mut inner, 0.02, true);
            assert!(u.aileron > 0.0, "{mode:?} {u:?}");
            match mode {
                AugmentedMode::Velocity => assert_eq!(u.throttle, GOVERNED_THROTTLE),
                _ => assert_eq!(u.collective, 0.3, "collective passes through"),
            }
        }
    }

    #[test]
    fn velocity_mode_sticks_centred_is_hover() {
        let v = commanded_velocity(&Controls::default(), &StickScales::default());
        assert_eq!(v, Vector3::zeros());
        let forward = Controls {
            elevator: -1.0,
            ..Controls::default()
        };
        assert_eq!(commanded_velocity(&forward, &StickScales::default()).x, 5.0);
    }
}
