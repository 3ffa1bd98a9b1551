//! Replay: recorded flights flown again by the flight software, the thesis's only true
//! certification of changed software ("the system still accepts these already-tested
//! inputs").
//!
//! - [`setup`]: how the logged flight's computer was set up, from the log's metadata;
//! - [`log`]: the log's device inputs fed to a fresh flight computer in this process, its
//!   servo commands and state estimates compared with the log's bit for bit
//!   (`heli log replay`);
//! - [`hil`]: the same inputs played onto the HILSim's pseudo-terminals and ADC files at
//!   their recorded times, for a flight computer outside (`heli hilsim --replay`);
//! - [`compare`]: how that computer's servo commands are judged against the recording,
//!   within a tolerance, since its inputs arrive with this machine's jitter.

pub mod compare;
pub mod hil;
pub mod log;
pub mod setup;
