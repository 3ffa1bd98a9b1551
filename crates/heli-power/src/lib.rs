//! Power: the avionics' batteries, as the thesis's operators logged them by hand and as a
//! fuel gauge sees them.
//!
//! What it is: pack characterizations ([`pack`]: open-circuit curve, resistance and
//! capacity against temperature, capacity fade), a fuel gauge per battery ([`gauge`]:
//! state of charge and time left from the voltage under load, the current where a sensor
//! gives it and the temperature, with warning and critical levels and the field rule of an
//! abnormal drain), and the hot-swap's log of time on the flight and ground batteries
//! ([`source`]). The simulator's batteries follow the same characterization, so the gauge
//! can be checked against the truth.
//!
//! What it is not: it reads no ADC, GPIO or clock; readings and their times come in as
//! arguments. It never panics.
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects,
        clippy::unreachable
    )
)]

pub mod gauge;
pub mod pack;
pub mod source;

pub use gauge::{FuelGauge, GaugeConfig, GaugeState, Level, Levels, Reading, ReadingError};
pub use pack::PackType;
pub use source::{PowerSource, SwapLog};
