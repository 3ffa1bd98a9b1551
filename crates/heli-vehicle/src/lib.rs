//! The heli flight computer's runtime: the onboard program `heli-vehicle`.
//!
//! What it is: the running programs of the vehicle (thesis §2.3 and ch. 4) around the
//! sans-I/O flight software of `heli-fsw`, built as their own lean binary (`src/main.rs`:
//! no simulator, web server or plotting is linked into what flies). The workstation's
//! `heli vehicle` / `heli flight` / `heli driver` run the same code through [`cli`].
//! - [`bootstrap`]: the always-on supervisor. It starts the flight process as a separate OS
//!   process on Connect, hands it the flight parameters on Start Logging, stops it on Stop,
//!   restarts it in the air after a crash, and reports every change and a crashed child with
//!   its exit status. Commands arrive on a local control socket ([`ctl`]) and from the
//!   ground's MAVLink [`link`]; both go through the same typed request path.
//! - [`supervisor`]: the bootstrap ↔ flight-process protocol, one typed message per line on
//!   the child's standard input and output.
//! - [`flight_process`]: the flight process's program (ready, the start line, the plan from
//!   [`plans`], the [`params`], the [`warm`]-start record, the log's name), around
//!   [`flight`]: one driver thread per serial port ([`threads`], with [`port`] opening real
//!   ttys or the HILSim's pseudo-terminals), the compass's analog monitor ([`adc`]: Linux
//!   IIO files, calibrated by [`compass_file`]), the [`hotswap`] line, the control loop woken
//!   by the drivers and timed by the IMU with its watchdogs, the live [`streams`], the
//!   battery and telemetry servers ([`telemetry`]) and the in-flight [`logger`], which
//!   records every device input ([`heli_log::inputs`]) so a flight can be replayed.
//! - [`standalone`]: each device's stand-alone driver with its own log.
//! - [`devices`]: where the devices are (a TOML file, or the HILSim's directory).
//! - [`rt`]: `SCHED_FIFO`, `mlockall` and each thread's measured stack size.
//! - [`error`]: what can go wrong outside the flight logic, by kind ([`error::VehicleError`]).
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
pub mod adopt;
pub mod args;
pub mod bootstrap;
pub mod cli;
pub mod compass_file;
pub mod control_socket;
pub mod ctl;
pub mod device_writes;
pub mod devices;
pub mod error;
pub mod flight;
pub mod flight_process;
pub mod hotswap;
pub mod lab;
pub mod latency;
pub mod link;
pub mod logger;
pub mod params;
pub mod plans;
pub mod port;
pub mod rt;
pub mod standalone;
pub mod streams;
pub mod supervision;
pub mod supervisor;
pub mod telemetry;
pub mod threads;
pub mod warm;
mod warm_keeper;
