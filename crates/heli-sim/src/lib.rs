//! HILSim: the hardware-in-the-loop simulator of the X-Cell 60.
//!
//! What it is: simulated devices that turn the model's true state into the real byte streams
//! at their real rates, and read the servo board's commands back ([`devices`]); the lockstep
//! runner that flies the flight software against the model (`heli-model`) and a scenario
//! (`heli-scenario`) on one virtual clock ([`lockstep`]), with the summary it measures
//! ([`summary`]) and its log ([`logging`]), and every built-in flight kept as a library of
//! recorded flights ([`library`]); the same simulation in real time against a
//! flight computer outside, its devices on pseudo-terminals and IIO-style ADC files
//! ([`hil`], `heli hilsim --ptys`); the replay of recorded flights, in this process or to a
//! flight computer outside, and the comparison of what it commands ([`replay`]); the page that
//! shows the simulator's truth in 3D and lets a pilot fly it ([`view`]); and the
//! simulator's benchmarks ([`bench`]); and the whole system as separate processes, the
//! HILSim, the vehicle and the ground station's display ([`system`], `heli sim --ui`); and the
//! truth beside the estimate, as CSV, for the engineer who asks why a flight failed
//! ([`truth_trace`], `heli sim --truth`).
//!
//! What it is not: flight software, the model, or the scenarios. It drives `heli-fsw` from
//! the outside, through device bytes only; the flight code never knows it is simulated.

pub mod bench;
pub mod devices;
pub mod hil;
pub mod library;
pub mod lockstep;
pub mod logging;
pub mod replay;
pub mod summary;
pub mod system;
pub mod truth_trace;
pub mod view;

pub use heli_scenario::Scenario;
pub use lockstep::{RunOptions, Simulation, run};
pub use summary::{Outcome, Summary};
