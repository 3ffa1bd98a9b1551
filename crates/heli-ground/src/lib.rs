//! The ground station of the heli avionics.
//!
//! What it is today: the automated safety checks the thesis's chapter 4 asks for
//! ([`checks`]) — the GPS satellite indicator and the battery meter as pure functions of
//! telemetry. The web display, the link client and log transfer arrive with the
//! ground-station issue.
//!
//! What it is not: flight code. The ground station never links the flight software; it only
//! speaks the link protocol (`heli-link`).

pub mod checks;
pub mod display;
