//! State estimation for the heli avionics.
//!
//! What it is: the math that turns IMU samples, GPS fixes, barometric pressure and compass
//! field into an estimate of attitude, velocity and position — the 80 s IMU bias
//! calibration of the thesis ([`calibration`]), a flat-earth frame about the first GPS fix
//! ([`geo`]), and the navigation filter itself ([`navigator`]): a strapdown INS propagated at
//! 50 Hz from pairs of 100 Hz IMU samples, corrected by complementary gains from the aiding
//! sensors, with GPS fused at its time of validity about one second in the past.
//!
//! What it is not: it owns no clock, file, socket or thread. Time arrives as an argument
//! (`t_us`, microseconds), so the same code runs on the vehicle, in lockstep simulation and in
//! replay. It never panics on bad input: a sample that makes no sense is rejected and counted.
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

pub mod calibration;
pub mod compass_cal;
pub mod geo;
pub mod navigator;

pub use calibration::{BiasCalibration, CalibrationPhase, ImuBiases};
pub use geo::GeoOrigin;
pub use navigator::{
    FilterHealth, GroundReferences, NavConfig, NavSensorStats, NavState, Navigator,
};

/// Standard gravity used by the navigation equations (m/s²).
pub const GRAVITY_MPS2: f64 = 9.81;

/// Seconds between two microsecond timestamps (`later` − `earlier`), never negative.
pub fn seconds_between(earlier_us: u64, later_us: u64) -> f64 {
    later_us.saturating_sub(earlier_us) as f64 * 1e-6
}
