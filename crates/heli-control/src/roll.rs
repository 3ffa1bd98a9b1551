//! The aileron roll, after the pilot's strategy (Gavrilets et al.; the thesis's flight of
//! November 18, 2001): from a steady forward-flight trim the helicopter pulls up into a climb,
//! rolls about its longitudinal axis at a commanded rate on the lateral cyclic while the
//! longitudinal cyclic and the tail hold pitch and yaw rates at zero, with the collective
//! scheduled on the roll angle — positive upright, negative inverted, so that the rotor keeps
//! pushing away from the ground — and hands back to the trim-trajectory controller just
//! before the roll angle reaches 360°.

use heli_proto::scb::Controls;
use nalgebra::Vector3;

use crate::{GOVERNED_THROTTLE, limit};

/// Gains and schedule of the roll.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollGains {
    /// Roll rate commanded through the roll (rad/s).
    pub rate_cmd_rps: f64,
    /// Lateral cyclic per rad/s of commanded rate (the rotor's inverse DC gain).
    pub rate_feedforward: f64,
    /// Lateral cyclic per rad/s of roll-rate error.
    pub rate_feedback: f64,
    /// Longitudinal cyclic per rad/s of pitch rate (holds q at zero).
    pub pitch_rate_feedback: f64,
    /// Tail per rad/s of yaw rate (holds r at zero).
    pub yaw_rate_feedback: f64,
    /// Collective upright (and its negative inverted): collective = amplitude · cos(roll).
    pub collective_amplitude: f64,
    /// Tail feedforward during the roll (torque of the scheduled collective).
    pub tail_feedforward: f64,
    /// The roll ends this far short of 360° and the trim controller takes the rest (rad).
    pub exit_lead_rad: f64,
    /// Climb rate commanded in the pull-up before each roll (m/s).
    pub pull_up_climb_mps: f64,
    /// Length of the pull-up (s).
    pub pull_up_s: f64,
    /// Time the trim-trajectory controller gets after each roll before the next (s).
    pub recover_s: f64,
    /// In the recovery the trajectory's point is kept at most this far ahead of the
    /// helicopter, horizontally (m). A roll leaves the helicopter below the trim speed and
    /// drifting with the air (in a crosswind by metres): the distance beyond this is given
    /// up, and this much is made up at no more than the hover controller's position gain
    /// times it (0.5/s · 2 m = 1 m/s) on top of the trim velocity.
    pub recover_lead_m: f64,
    /// Time constant of the body roll rate's response to a step of lateral cyclic (s): the
    /// rotor's flapping and the fuselage's damping together. A process started again in a
    /// roll uses it to reckon how far the helicopter turned while nobody saw it.
    pub rate_response_s: f64,
}

impl Default for RollGains {
    fn default() -> Self {
        Self {
            rate_cmd_rps: 3.0,
            rate_feedforward: 0.3,
            rate_feedback: 0.05,
            pitch_rate_feedback: 0.15,
            yaw_rate_feedback: 0.3,
            collective_amplitude: 0.75,
            tail_feedforward: 0.4,
            exit_lead_rad: 0.35,
            pull_up_climb_mps: 5.0,
            pull_up_s: 1.5,
            recover_s: 4.0,
            recover_lead_m: 2.0,
            rate_response_s: 0.1,
        }
    }
}

/// Servo commands during the roll, `angle_rad` into it, at the body rates `rate_body_rps`
/// (the estimate's; the commanded roll rate alone when the roll is finished blind, so that
/// only the feedforward acts).
pub fn rolling_controls(rate_body_rps: &Vector3<f64>, angle_rad: f64, g: &RollGains) -> Controls {
    let rate = rate_body_rps;
    let aileron = g.rate_feedforward * g.rate_cmd_rps + g.rate_feedback * (g.rate_cmd_rps - rate.x);
    let collective = g.collective_amplitude * angle_rad.cos();
    // The rotor's torque follows the magnitude of the collective, upright or inverted.
    let tail = g.tail_feedforward * collective.abs() / g.collective_amplitude.max(1e-6)
        - g.yaw_rate_feedback * rate.z;
    Controls {
        aileron: limit(aileron, 1.0),
        elevator: limit(-g.pitch_rate_feedback * rate.y, 1.0),
        rudder: limit(tail, 1.0),
        collective: limit(collective, 1.0),
        throttle: GOVERNED_THROTTLE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(rate: Vector3<f64>) -> Vector3<f64> {
        rate
    }

    #[test]
    fn collective_reverses_inverted_and_cyclic_rolls_right() {
        let g = RollGains::default();
        let upright = rolling_controls(&est(Vector3::zeros()), 0.0, &g);
        let inverted = rolling_controls(&est(Vector3::zeros()), std::f64::consts::PI, &g);
        assert!(upright.collective > 0.5 && inverted.collective < -0.5);
        assert!(upright.aileron > 0.8);
        assert!(
            (upright.rudder - inverted.rudder).abs() < 1e-9,
            "same torque either way up"
        );
    }

    #[test]
    fn pitch_and_yaw_rates_are_opposed() {
        let g = RollGains::default();
        let u = rolling_controls(&est(Vector3::new(3.0, 0.5, 0.5)), 1.0, &g);
        let still = rolling_controls(&est(Vector3::new(3.0, 0.0, 0.0)), 1.0, &g);
        assert!(u.elevator < still.elevator);
        assert!(u.rudder < still.rudder);
    }
}
