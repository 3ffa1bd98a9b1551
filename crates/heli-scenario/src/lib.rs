//! Scenarios: what a simulated flight flies and how it is judged, and the catalogue of what
//! can go wrong in it.
//!
//! What it is: the scenario ([`Scenario`]: wind, air, airframe, batteries, control mode, the
//! plan from the plan library, the pilot's transmitter, faults and pass/fail limits), the
//! built-in scenarios (`heli sim --list`: here and in [`device_faults`], [`engine_failures`]
//! and [`power_scenarios`]), scenario files (TOML over a built-in base, [`from_toml`],
//! checked by [`validate`]), the fault catalogue ([`faults`]), the scripted and hovering
//! pilot ([`pilot`]) and the trainer's failures a pilot page triggers ([`trainer`]).
//!
//! What it is not: the simulation. It describes flights; `heli-sim` flies them.

mod builtin;
pub mod device_faults;
pub mod engine_failures;
pub mod fault_timing;
pub mod faults;
mod file;
mod flights;
pub mod pilot;
pub mod power_scenarios;
mod scenario;
pub mod trainer;
pub mod validate;

pub use builtin::{builtin, builtins};
pub use file::{ScenarioError, from_toml, load};
pub use flights::{augmented, demo, gps_outage, hover, manual_sweep, rc_loss, rolls};
pub use scenario::*;
