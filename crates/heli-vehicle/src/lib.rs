//! The heli flight computer's runtime.
//!
//! What it is: the running programs of the vehicle (thesis §2.3 and ch. 4) around the
//! sans-I/O flight software of `heli-fsw`:
//! - [`bootstrap`]: the always-on supervisor. It starts the flight process as a separate OS
//!   process on Connect, hands it the flight parameters on Start Logging, stops it on Stop,
//!   and reports every change and a crashed child with its exit status. Commands arrive on a
//!   local control socket ([`ctl`]); the ground link plugs into the same command path.
//! - [`flight`]: the flight process. One driver thread per serial port ([`threads`], with
//!   [`port`] opening real ttys or the HILSim's pseudo-terminals), the compass's analog
//!   monitor ([`adc`]: Linux IIO files), the control loop woken by the drivers and timed by
//!   the IMU with its watchdogs, the live [`streams`], the battery and telemetry servers
//!   ([`telemetry`]) and the in-flight [`logger`], which records every device input
//!   ([`heli_log::inputs`]) so a flight can be replayed.
//! - [`devices`]: where the devices are (a TOML file, or the HILSim's directory).
//! - [`rt`]: `SCHED_FIFO` and `mlockall` when permitted.
//!
//! What it is not: flight logic. Parsing, estimation, control and the watchdogs' verdicts
//! are `heli-fsw`'s, and the same code runs in lockstep simulation and in replay.
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

pub mod adc;
pub mod bootstrap;
pub mod cli;
pub mod compass_file;
pub mod ctl;
pub mod devices;
pub mod error;
pub mod flight;
pub mod flight_process;
pub mod hotswap;
pub mod link;
pub mod logger;
pub mod params;
pub mod plans;
pub mod port;
pub mod rt;
pub mod standalone;
pub mod streams;
pub mod supervisor;
pub mod telemetry;
pub mod threads;
pub mod warm;
