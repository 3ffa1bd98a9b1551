//! HILSim: the hardware-in-the-loop simulator of the X-Cell 60.
//!
//! What it is: simulated devices that turn the model's true state into the real byte streams
//! at their real rates, and read the servo board's commands back ([`devices`]); the lockstep
//! runner that flies the flight software against the model (`heli-model`) and a scenario
//! (`heli-scenario`) on one virtual clock ([`lockstep`]), with the summary it measures
//! ([`summary`]) and its log ([`logging`]); the same simulation in real time against a
//! flight computer outside, its devices on pseudo-terminals and IIO-style ADC files
//! ([`hil`], `heli hilsim --ptys`); the playback of a recorded flight's inputs to one
//! ([`hil_replay`]) and the comparison of its commands ([`replay_compare`]); and the
//! simulator's benchmarks ([`bench`]).
//!
//! What it is not: flight software, the model, or the scenarios. It drives `heli-fsw` from
//! the outside, through device bytes only; the flight code never knows it is simulated.

pub mod bench;
pub mod devices;
pub mod hil;
pub mod hil_replay;
pub mod lockstep;
pub mod logging;
pub mod replay_compare;
pub mod summary;

pub use heli_scenario::Scenario;
pub use lockstep::{RunOptions, Simulation, run};
pub use summary::{Outcome, Summary};
