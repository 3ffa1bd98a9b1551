//! The vehicle ↔ ground link of the heli avionics.
//!
//! What it is: the thesis's ground-station messages — Connect, Start Logging with the flight
//! parameters, Stop, the telemetry request, the final parameters of the cleanup routine —
//! as typed values, with the validation a flight computer must apply to anything the ground
//! sends ([`messages`]) — carried over MAVLink 2, common dialect (docs/link.md): framing
//! ([`frame`]) and signing ([`signing`]) of our own, the commands ([`command`]), telemetry
//! ([`telemetry`]), the log protocol ([`logs`]), the flight plan over the mission protocol
//! ([`mission`]), and the two ends of the link, the vehicle's
//! ([`vehicle`]) and the ground's ([`ground`]). All of it is sans-I/O: datagrams and the time
//! go in, datagrams and events come out; the sockets are the runtime's. The one exception is
//! [`setup`], which reads what both ends need to open a link: the `udp:HOST:PORT` address
//! and the signing key file.
//!
//! What it is not: flight code, a socket layer or ground-station UI.

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

pub mod attest;
pub mod command;
pub mod frame;
pub mod ground;
pub mod logs;
pub mod messages;
pub mod mission;
pub mod outgoing;
pub mod params;
pub mod setup;
pub mod signing;
pub mod status;
pub mod telemetry;
pub mod vehicle;

pub use messages::{FinalParameters, GroundCommand, LinkError, StartParameters};

#[cfg(test)]
mod clock_tests;
