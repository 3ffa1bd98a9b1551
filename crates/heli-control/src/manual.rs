//! Manual flight: the pilot's commands pass through to the servos, except the tail rotor,
//! which the computer computes with proportional yaw-rate feedback (the thesis: "the computer
//! simulates gyro gains while the helicopter is flying in manual mode").

use heli_proto::scb::Controls;

use crate::limit;

/// The computer's yaw-rate feedback ("gyro") on the tail rotor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawDamper {
    /// Tail command per rad/s of yaw rate (normalised s/rad).
    pub gain: f64,
    /// Tail command that holds the nose against the main-rotor torque in hover.
    pub trim: f64,
}

impl Default for YawDamper {
    fn default() -> Self {
        Self {
            gain: 0.15,
            trim: 0.3,
        }
    }
}

/// Pilot commands with the tail replaced by `rudder + trim − gain · r`.
pub fn manual_with_yaw_damping(
    pilot: &Controls,
    yaw_rate_rps: f64,
    damper: &YawDamper,
) -> Controls {
    let r = if yaw_rate_rps.is_finite() {
        yaw_rate_rps
    } else {
        0.0
    };
    Controls {
        rudder: limit(pilot.rudder + damper.trim - damper.gain * r, 1.0),
        ..*pilot
    }
    .clamped()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_rate_to_the_right_is_opposed_and_other_channels_pass_through() {
        let pilot = Controls {
            aileron: 0.2,
            elevator: -0.1,
            rudder: 0.0,
            collective: 0.5,
            throttle: 0.8,
        };
        let d = YawDamper::default();
        let still = manual_with_yaw_damping(&pilot, 0.0, &d);
        let turning = manual_with_yaw_damping(&pilot, 1.0, &d);
        assert!(turning.rudder < still.rudder);
        assert_eq!(turning.aileron, 0.2);
        assert_eq!(turning.collective, 0.5);
        assert_eq!(
            manual_with_yaw_damping(&pilot, f64::NAN, &d).rudder,
            still.rudder
        );
    }
}
