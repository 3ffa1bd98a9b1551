//! From the servo controller board's outputs to what the rotor sees: normalised servo
//! commands scaled to blade pitch (H15 §15.5 command limits) and the throttle channel to the
//! governor's set point. Servo dynamics and quantisation come in here in the next issue.

use heli_proto::scb::Controls;

use crate::model::ControlInputs;
use crate::params::Airframe;

/// Blade pitch and governor set point for normalised servo commands.
pub fn control_inputs(airframe: &Airframe, servo: &Controls) -> ControlInputs {
    let c = servo.clamped();
    ControlInputs {
        lat_rad: c.aileron * airframe.cyclic_max_rad,
        lon_rad: c.elevator * airframe.cyclic_max_rad,
        col_rad: c.collective * airframe.collective_max_rad,
        tail_rad: c.rudder * airframe.tail_max_rad,
        governor_setpoint_rps: c.throttle * airframe.governor_full_scale_rpm * std::f64::consts::PI
            / 30.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn governed_throttle_is_1600_rpm_and_full_stick_is_the_published_limit() {
        let a = Airframe::default();
        let u = control_inputs(
            &a,
            &Controls {
                aileron: 1.0,
                elevator: -2.0,
                rudder: 0.0,
                collective: 0.5,
                throttle: 0.8,
            },
        );
        assert!((u.governor_setpoint_rps - 1600.0 * std::f64::consts::PI / 30.0).abs() < 1e-9);
        assert!((u.lat_rad - 0.096).abs() < 1e-12);
        assert!((u.lon_rad + 0.096).abs() < 1e-12, "clamped to the limit");
        assert!((u.col_rad - 0.0915).abs() < 1e-12);
    }
}
