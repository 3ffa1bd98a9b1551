//! The ground station of the heli avionics.
//!
//! What it is today: the automated safety checks the thesis's chapter 4 asks for
//! ([`checks`]) — the GPS satellite indicator and the battery meter as pure functions of
//! telemetry. The link client and log transfer are `heli_link::ground` (used by `heli
//! ground`); the web display is still to come.
//!
//! What it is not: flight code. The ground station never links the flight software; it only
//! speaks the link protocol (`heli-link`).

pub mod checks;
pub mod display;
