//! Control laws of the heli avionics.
//!
//! What it is: pure functions (and small integrator states) from the navigation estimate,
//! the pilot's sticks and a target to normalised servo commands ([`heli_proto::scb::Controls`]):
//! manual pass-through with computer yaw damping ([`manual`]) and the autonomous
//! take-off / position-hold controller ([`hover`]).
//!
//! What it is not: it reads no clock and owns no I/O; the step time arrives as an argument.
//! It never panics; non-finite inputs give neutral, bounded commands.
//!
//! Servo conventions (normalised, as everywhere inside heli): aileron +1 rolls right,
//! elevator +1 tilts the rotor aft and pitches the nose up, rudder +1 increases tail-rotor
//! pitch and yaws the nose right, collective +1 is full positive blade pitch, throttle 0..1
//! scales the governor set point.
#![cfg_attr(
    test,
    allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_possible_wrap,
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects,
        clippy::unreachable
    )
)]

pub mod augmented;
pub mod autorotation;
pub mod heading_lock;
pub mod hover;
pub mod manual;
pub mod roll;
pub mod safety;

pub use augmented::{StickScales, augmented_controls};
pub use hover::{HoverController, HoverGains, Target};
pub use manual::{YawDamper, manual_with_yaw_damping};
pub use roll::{RollGains, rolling_controls};

/// Throttle channel that sets the governor to 1600 rpm, the speed of every flight in the
/// thesis (the governor maps the channel to 0..2000 rpm).
pub const GOVERNED_THROTTLE: f64 = 0.8;

/// A value limited to ±`limit` (a non-finite value becomes 0).
pub fn limit(value: f64, limit: f64) -> f64 {
    if value.is_finite() {
        value.clamp(-limit, limit)
    } else {
        0.0
    }
}

/// A step time made safe: not finite becomes 0, and at most 0.1 s.
pub fn sanitize_dt(dt_s: f64) -> f64 {
    if dt_s.is_finite() {
        dt_s.clamp(0.0, 0.1)
    } else {
        0.0
    }
}
