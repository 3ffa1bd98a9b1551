//! The vehicle ↔ ground link of the heli avionics.
//!
//! What it is: the thesis's ground-station messages — Connect, Start Logging with the flight
//! parameters, Stop, the telemetry request, the final parameters of the cleanup routine —
//! as typed values, with the validation a flight computer must apply to anything the ground
//! sends ([`messages`]). Their mapping onto MAVLink 2 (`docs/link.md`) and the UDP transport
//! arrive with the ground-station issue.
//!
//! What it is not: flight code or ground-station UI; both sides use these types.

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

pub mod command;
pub mod frame;
pub mod messages;
pub mod signing;
pub mod telemetry;

pub use messages::{
    AugmentedMode, FinalParameters, FlightMode, GroundCommand, LinkError, StartParameters,
};
