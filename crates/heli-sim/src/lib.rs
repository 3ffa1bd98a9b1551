//! HILSim: the hardware-in-the-loop simulator of the X-Cell 60.
//!
//! What it is: the Gavrilets nonlinear helicopter model ([`model`], [`rotor`], [`ground`],
//! parameters in [`params`]); the actuators between servo board and rotor ([`actuators`]);
//! simulated devices that emit the real byte streams at their real rates ([`devices`]);
//! scenarios ([`scenario`]); and the lockstep runner that flies the flight software against
//! all of it on one virtual clock ([`lockstep`]), with the summary it measures ([`summary`]);
//! and the same simulation in real time against a flight computer outside, its devices on
//! pseudo-terminals and IIO-style ADC files ([`hil`], `heli hilsim --ptys`).
//!
//! What it is not: flight software. It drives `heli-fsw` from the outside, through device
//! bytes only; the flight code never knows it is simulated.

pub mod actuators;
pub mod analysis;
pub mod bench;
pub mod device_faults;
pub mod devices;
pub mod empennage;
pub mod engine_failures;
pub mod faults;
pub mod ground;
pub mod hil;
pub mod hil_replay;
pub mod lockstep;
pub mod logging;
pub mod model;
pub mod params;
pub mod pilot;
pub mod power_scenarios;
pub mod replay_compare;
pub mod rotor;
pub mod scenario;
pub mod summary;
pub mod trainer;
pub mod turbulence;
pub mod validate;

pub use lockstep::{RunOptions, Simulation, run};
pub use scenario::Scenario;
pub use summary::{Outcome, Summary};
