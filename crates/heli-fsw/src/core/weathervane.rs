//! Nose into the wind: a hold in a strong wind turns the helicopter to face it, as a pilot
//! would (and as ArduPilot's weathervaning does), so that the fuselage's smallest face and
//! the tail rotor's best angle meet the wind, and the roll limit is not used up holding
//! against a crosswind. The wind is read off the hover controller's trim: the acceleration
//! its velocity integrator holds points into the wind, once the tail rotor's own side force
//! (which the helicopter leans against in still air, [`TAIL_SIDE_TRIM_MPS2`]) is taken out.

use super::*;

/// Wind trim (m/s²) above which a hold turns its nose into the wind: about 7 m/s of wind on
/// the X-Cell 60.
pub const WEATHERVANE_ABOVE_MPS2: f64 = 0.8;

/// The tail rotor's side force in hover as an acceleration to the right (m/s², body): the
/// X-Cell 60 hovers rolled about 5 deg into it, and the trim holds it in still air.
pub const TAIL_SIDE_TRIM_MPS2: f64 = 0.85;

/// How fast the held heading turns toward the wind (rad/s).
pub const WEATHERVANE_RATE_RPS: f64 = 0.25;

impl FlightCore {
    /// The hold's target with its heading turned toward the wind, when the wind is strong.
    pub(super) fn weathervane(&self, target: Target, dt_s: f64) -> Target {
        let (sin_yaw, cos_yaw) = target.yaw_rad.sin_cos();
        let side = self.hover.trim_accel_ned_mps2();
        let trim = Vector3::new(
            side.x + sin_yaw * TAIL_SIDE_TRIM_MPS2,
            side.y - cos_yaw * TAIL_SIDE_TRIM_MPS2,
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
}
