//! The ground station of the heli avionics: the operator's display of thesis §2.4 and
//! Fig. 2-4, in a browser.
//!
//! What it is:
//! - a sans-I/O core, [`station::Station`]: the link's ground end (`heli_link::ground`) with
//!   the panel of §2.4 ([`panel`]), the telemetry rows ([`rows`]), the battery meter and GPS
//!   indicator ([`checks`]), the automated safety checks of §4.3 judged on telemetry
//!   ([`facts`], on the rule of `heli_control::safety` that the vehicle enforces), the
//!   operators' control token ([`operators`]), the log transfer after Stop ([`transfer`]),
//!   and the [`view::View`] a page draws;
//! - its I/O, [`server`]: a UDP socket to the vehicle and an HTTP server with a WebSocket
//!   (axum on tokio) serving the page, whose files are embedded in the binary (`web/`);
//!   what it says when the network fails its datagrams is [`datagrams`].
//!
//! What it is not: flight code. The ground station never links the flight software; it only
//! speaks the link protocol (`heli-link`) and shares the safety rule (`heli-control`).
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

pub mod bench;
pub mod checks;
pub mod client;
pub mod command;
pub mod datagrams;
pub mod display;
pub mod facts;
pub mod lab;
pub mod messages;
pub mod operators;
pub mod pack_log;
pub mod panel;
pub mod power_view;
pub mod refusal;
pub mod rows;
pub mod server;
pub mod station;
#[cfg(test)]
mod station_tests;
#[cfg(test)]
mod stop_tests;
pub mod transfer;
#[cfg(test)]
mod truth_tests;
pub mod view;
