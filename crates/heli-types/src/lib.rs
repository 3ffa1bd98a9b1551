//! The heli avionics' shared flight vocabulary.
//!
//! What it is: the words every side of the system uses for the same things, defined once —
//! the flight mode the operator picks ([`mode`]), the autonomous flight plan and its legs
//! ([`plan`]) and the lab's library of named plans ([`library`]), the devices the flight
//! software watches and the serial ports they speak on ([`device`]), the pilot's
//! transmitter ([`transmitter`]), the airframe's outward shape that every picture of it
//! draws ([`shape`]), and a spell of failures ([`spell`]): the count by which a fault that
//! repeats is said once, and its end with the count. The vehicle, the simulator, the link
//! and the ground station all speak of these with these types, so none of them has to link
//! another to agree on a word.
//!
//! What it is not: behaviour beyond counting. No I/O, no clock, no flight logic; its only optional
//! dependency is `serde` (feature `serde`), for the forms written in files and on the link.
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects
    )
)]

pub mod device;
pub mod library;
pub mod mode;
pub mod phases;
pub mod plan;
pub mod shape;
pub mod spell;
pub mod transmitter;

pub use device::{Device, Port};
pub use mode::{AugmentedMode, FlightMode};
pub use plan::{Leg, MAX_LEGS, Plan, PlanError};
pub use spell::Spell;
pub use transmitter::Transmitter;
