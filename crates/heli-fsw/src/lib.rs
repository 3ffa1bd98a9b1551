//! The heli flight computer.
//!
//! What it is:
//! - [`core`]: the thesis's main control process as a sans-I/O state machine. Samples and
//!   time go in ([`core::Input`], `now_us`), actions come out ([`core::Action`]: servo
//!   commands and records for the seven streams). It holds the 12 ms IMU watchdog, the 80 s
//!   bias calibration, the 50 Hz estimation and control step and the flight phases, as
//!   F´-style components (the main loop, the calibration, the devices' watch, the aids, the
//!   sequencer, the roll, the mode check, the engine, the power, the restart in the air),
//!   each owning its state, routed by a thin [`FlightCore`].
//! - [`computer`]: the single code path of the flight software — device bytes and ADC
//!   readings in, servo and device commands out ([`FlightComputer`]), used alike by the
//!   vehicle, the lockstep simulator and replay.
//! - [`drivers`]: the device drivers' protocol halves, also sans-I/O — bytes in, samples out,
//!   and for the altimeter the reset / rate / continuous handshake with its timeouts.
//! - [`health`]: every driver's watchdog.
//! - [`invariants`]: what the core relies on, stated and checked after every input by
//!   property tests and by every simulated flight.
//! - [`phase`]: the phases of a flight and the stages of the roll.
//! - [`streams`]: the seven single-writer buffers (IMU, state, servo, uplink, GPS, altimeter,
//!   compass) with a freshest value for telemetry and a history for the logger.
//!
//! What it is not: the runtime with threads, serial ports, the bootstrap supervisor,
//! telemetry and the logger; those are `heli-vehicle`'s and drive the same core. Nothing
//! here reads a clock or touches a file, socket or thread.

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

pub mod computer;
pub mod core;
pub mod drivers;
pub mod health;
pub mod invariants;
pub mod phase;
pub mod streams;

pub use crate::computer::{DeviceInput, FlightComputer, RecordedInput};
pub use crate::core::{Action, CoreConfig, CoreStats, FlightCore, FlightParams, Input};
pub use crate::phase::Phase;
pub use crate::streams::{Record, Stamped, Streams};
