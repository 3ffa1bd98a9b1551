//! Device wire formats for the avionics of MIT's X-Cell 60 autonomous
//! helicopter (K. Sprague's 2001 thesis), rebuilt in Rust.
//!
//! # What this crate is
//!
//! The byte-level side of every device the flight computer talks to:
//!
//! | module | device | link |
//! |---|---|---|
//! | [`imu`] | inertial measurement unit (rates, specific force, temperature) | 16-byte binary frame, 100 Hz, 38400 baud |
//! | [`scb`] | servo controller board: pilot uplink in, servo commands out | 17/12-byte binary frames, 50 Hz, 38400 baud |
//! | [`gps`] | GPS receiver navigation solution | SuperStar II–style binary message, 1 Hz, 19200 baud |
//! | [`baro`] | barometric altimeter | HPB200A-style ASCII commands and replies, 9600 baud |
//! | [`compass`] | three-axis magnetoresistive compass | three ADC channels, 20 Hz |
//! | [`battery`] | flight battery voltage | one ADC channel through a 3:1 divider |
//!
//! Each binary module follows the shape of smoltcp's `wire` module: named
//! byte offsets, a validated typed representation with
//! `parse(frame: &[u8]) -> Result<Self, Error>` and
//! `emit(&self, buf: &mut [u8]) -> Result<usize, Error>`, and a
//! byte-at-a-time [`framer`] (the thesis's interrupt service routine) that
//! hunts for the header byte, fills, checks the checksum and delivers or
//! resynchronises. [`adc`] holds the analog-input conversion shared by the
//! compass and the battery monitor.
//!
//! The crate is `no_std`, allocates nothing, and no input can make it panic:
//! malformed input gives an [`Error`], a short output buffer gives
//! [`Error::BufferTooSmall`].
//!
//! # What it is not
//!
//! It knows nothing about state estimation, control, time sources or I/O. It
//! does not open serial ports, schedule reads or timestamp anything; it turns
//! bytes into typed, SI-unit values and back, nothing more. The exact field
//! layouts are this project's documented equivalents of the real devices'
//! formats (see `docs/protocols.md`).

#![cfg_attr(not(test), no_std)]
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

mod bytes;

pub mod adc;
pub mod baro;
pub mod battery;
pub mod compass;
pub mod error;
pub mod framer;
pub mod gps;
pub mod imu;
pub mod scb;

#[cfg(test)]
mod testutil;

pub use error::Error;
