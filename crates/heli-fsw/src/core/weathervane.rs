//! Nose into the wind: a hold in a strong wind turns the helicopter to face it, as a pilot
//! would (and as ArduPilot's weathervaning does), so that the fuselage's smallest face and
//! the tail rotor's best angle meet the wind, and the roll limit is not used up holding
//! against a crosswind. The wind is read off the hover controller's trim: the acceleration
//! its velocity integrator holds points into the wind, once the tail rotor's own side force
//! (which the helicopter leans against in still air, [`TAIL_SIDE_TRIM_MPS2`]) is taken out.

use heli_control::Target;
use nalgebra::Vector3;

/// Wind trim (m/s²) above which a hold turns its nose into the wind: about 7 m/s of wind on
/// the X-Cell 60.
pub const WEATHERVANE_ABOVE_MPS2: f64 = 0.8;

/// The tail rotor's side force in hover as an acceleration to the right (m/s², body): the
/// X-Cell 60 hovers rolled about 5 deg into it, and the trim holds it in still air.
pub const TAIL_SIDE_TRIM_MPS2: f64 = 0.85;

/// How fast the held heading turns toward the wind (rad/s).
pub const WEATHERVANE_RATE_RPS: f64 = 0.25;

/// The hold's `target` with its heading turned toward the wind, when the wind is strong:
/// `trim_ned_mps2` is the hover controller's trim (the acceleration its velocity integrator
/// holds, NED), `dt_s` the control step.
pub(super) fn weathervane(target: Target, trim_ned_mps2: Vector3<f64>, dt_s: f64) -> Target {
    let (sin_yaw, cos_yaw) = target.yaw_rad.sin_cos();
    let trim = Vector3::new(
        trim_ned_mps2.x + sin_yaw * TAIL_SIDE_TRIM_MPS2,
        trim_ned_mps2.y - cos_yaw * TAIL_SIDE_TRIM_MPS2,
        0.0,
    );
    let horizontal = trim.x.hypot(trim.y);
    if horizontal.is_nan() || horizontal <= WEATHERVANE_ABOVE_MPS2 {
        return target;
    }
    let into_wind = trim.y.atan2(trim.x);
    let error = heli_nav::navigator::wrap_pi(into_wind - target.yaw_rad);
    let step = WEATHERVANE_RATE_RPS * dt_s.clamp(0.0, 0.1);
    Target {
        yaw_rad: heli_nav::navigator::wrap_pi(target.yaw_rad + error.clamp(-step, step)),
        ..target
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trim of a hold at `yaw_rad` in a wind that needs `wind_mps2` of trim toward
    /// `from_rad`: the wind's part plus the tail rotor's side force, which the trim holds
    /// to the right of the heading in still air.
    fn trim(yaw_rad: f64, wind_mps2: f64, from_rad: f64) -> Vector3<f64> {
        let (s, c) = yaw_rad.sin_cos();
        let right = Vector3::new(-s, c, 0.0);
        Vector3::new(from_rad.cos(), from_rad.sin(), 0.0) * wind_mps2 + right * TAIL_SIDE_TRIM_MPS2
    }

    fn at(yaw_rad: f64) -> Target {
        Target::hold(Vector3::new(3.0, -4.0, -20.0), yaw_rad)
    }

    #[test]
    fn in_still_air_or_a_light_wind_the_heading_is_kept() {
        for yaw in [0.0, 0.5, core::f64::consts::FRAC_PI_2, 2.5, -3.0] {
            assert_eq!(weathervane(at(yaw), trim(yaw, 0.0, 0.0), 0.02), at(yaw));
            // A wind needing 0.8 m/s² or less (about 7 m/s) is not worth turning for.
            assert_eq!(weathervane(at(yaw), trim(yaw, 0.79, 2.0), 0.02), at(yaw));
        }
        let nan = Vector3::new(f64::NAN, 0.0, 0.0);
        assert_eq!(weathervane(at(0.3), nan, 0.02), at(0.3));
    }

    #[test]
    fn in_a_strong_wind_the_nose_turns_into_it_at_its_rate() {
        // The wind a tenth of a step to the left: the nose is put exactly into it.
        let t = weathervane(at(0.5), trim(0.5, 2.0, 0.5 + 0.004), 0.02);
        assert!((t.yaw_rad - 0.504).abs() < 1e-12, "{}", t.yaw_rad);
        assert_eq!(t.pos_ned_m, at(0.5).pos_ned_m, "only the heading turns");
        // Far off, either way: one step of 0.25 rad/s.
        let left = weathervane(at(0.5), trim(0.5, 2.0, 2.5), 0.02);
        assert!((left.yaw_rad - 0.505).abs() < 1e-12, "{}", left.yaw_rad);
        let right = weathervane(at(0.5), trim(0.5, 2.0, -1.0), 0.02);
        assert!((right.yaw_rad - 0.495).abs() < 1e-12, "{}", right.yaw_rad);
        // A step longer than 0.1 s turns no more than 0.1 s does.
        let long = weathervane(at(0.5), trim(0.5, 2.0, 2.5), 1.0);
        assert!((long.yaw_rad - 0.525).abs() < 1e-12, "{}", long.yaw_rad);
        // Across south the heading wraps: from 3.13 toward −3.0 it turns left through π.
        let wrap = weathervane(at(3.13), trim(3.13, 2.0, -3.0), 0.1);
        let expected = 3.13 + 0.025 - 2.0 * core::f64::consts::PI;
        assert!((wrap.yaw_rad - expected).abs() < 1e-12, "{}", wrap.yaw_rad);
    }
}
