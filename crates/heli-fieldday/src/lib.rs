//! The field-day fault campaign (`heli field-day`): each single fault a field day can bring,
//! injected into the vehicle's real processes — `heli hilsim` on pseudo-terminals, the
//! bootstrap `heli-vehicle` and the flight process it starts — while the helicopter hovers
//! and while it rolls, and judged three ways:
//!
//! 1. **The truth.** The HILSim's summary says the helicopter was not lost (no crash: it
//!    flew on, or landed softly).
//! 2. **The data.** Every log opens in the official Python MCAP reader; the log being written
//!    when the fault struck (copied through the flight process's open file just after it,
//!    or the log of a process the fault killed) ends at most 100 ms and one flush interval
//!    before the fault.
//! 3. **The operator.** The bootstraps said what the fault requires (their lines are the
//!    ground station's status texts).
//!
//! The faults and how each is made are in [`fault`] and [`storage`]; one trial is
//! [`trial::run`]. This crate runs processes and reads their output; it is not flight code
//! and no part of it flies. docs/robustness.md has the table of the last whole run.

pub mod fault;
pub mod judge;
pub mod procs;
pub mod report;
pub mod storage;
pub mod trial;

use std::fmt;
use std::path::PathBuf;

pub use fault::{Fault, Phase};
pub use trial::Outcome;

/// Why the campaign could not run.
#[derive(Debug)]
pub enum FieldDayError {
    /// A wrong argument: what, and what is allowed.
    Usage(String),
    /// Something to set up failed: what it said.
    Setup(String),
    /// A file or process operation failed: what was being done, and the system's answer.
    Io(String, std::io::Error),
}

impl fmt::Display for FieldDayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldDayError::Usage(what) | FieldDayError::Setup(what) => f.write_str(what),
            FieldDayError::Io(what, e) => write!(f, "{what}: {e}"),
        }
    }
}

impl std::error::Error for FieldDayError {}

/// What to run.
#[derive(Clone, Debug)]
pub struct Options {
    /// The programs.
    pub programs: procs::Programs,
    /// A Python with the official `mcap` package.
    pub python: PathBuf,
    /// Where each trial keeps its logs, its snapshots and what was said.
    pub out: PathBuf,
    /// The trials: each fault in each phase.
    pub trials: Vec<(Fault, Phase)>,
    /// The HILSim's seed.
    pub seed: u64,
    /// Make the storage faults on a tmpfs of their own where this process may mount one
    /// (root); otherwise, or when false, by a file-size limit and the directory's permissions.
    pub mount: bool,
}

/// The trials CI runs (`heli field-day --ci`): each kind of recovery once, in both phases —
/// the brown-out in the roll, where the restart must carry the roll through (the record's
/// wall-clock time set against the new process's clock: only real processes exercise it).
pub fn ci_trials() -> Vec<(Fault, Phase)> {
    vec![
        (Fault::KillFlight, Phase::Hover),
        (Fault::KillBootstrap, Phase::Rolls),
        (Fault::DiskFull, Phase::Hover),
        (Fault::Stall(3000), Phase::Rolls),
        (Fault::Brownout, Phase::Rolls),
    ]
}

/// Every fault in both phases.
pub fn all_trials() -> Vec<(Fault, Phase)> {
    fault::ALL
        .into_iter()
        .flat_map(|f| fault::PHASES.map(|p| (f, p)))
        .collect()
}

/// Tries of one trial at most: a failed try in which the machine starved the HILSim
/// ([`Outcome::starved`]) is void and run again, up to this many in all; a trial void every
/// time fails, saying so.
pub const TRIES: usize = 3;

/// Runs the trials one after the other (real time: never two at once), telling `progress`
/// of each try as it ends (`true`: the trial's verdict; `false`: a void try, run again).
pub fn run(
    options: &Options,
    mut progress: impl FnMut(&Outcome, bool),
) -> Result<Vec<Outcome>, FieldDayError> {
    if !judge::python_has_mcap(&options.python) {
        return Err(FieldDayError::Setup(format!(
            "{} cannot import the official MCAP reader: install it (python3 -m venv /tmp/mcap && /tmp/mcap/bin/pip install mcap) and give --python /tmp/mcap/bin/python",
            options.python.display()
        )));
    }
    for program in [&options.programs.heli, &options.programs.vehicle] {
        if !program.exists() {
            return Err(FieldDayError::Setup(format!(
                "{} is missing: build it (cargo build --release --workspace)",
                program.display()
            )));
        }
    }
    let mut outcomes = Vec::new();
    for &(fault, phase) in &options.trials {
        let mut void_tries = Vec::new();
        let outcome = loop {
            let mut outcome = trial::run(
                &options.programs,
                &options.python,
                &options.out,
                fault,
                phase,
                options.seed,
                options.mount,
            )?;
            let void = !outcome.pass && !outcome.starved.is_empty();
            if void && void_tries.len() + 1 < TRIES {
                void_tries.push(format!(
                    "try {} void: {}",
                    void_tries.len() + 1,
                    outcome.starved.join("; ")
                ));
                progress(&outcome, false);
                continue;
            }
            if void {
                outcome.problems.push(format!(
                    "void in each of {TRIES} tries: the machine could not keep the HILSim in real time ({})",
                    outcome.starved.join("; ")
                ));
            }
            outcome.void_tries = std::mem::take(&mut void_tries);
            break outcome;
        };
        progress(&outcome, true);
        outcomes.push(outcome);
    }
    Ok(outcomes)
}
