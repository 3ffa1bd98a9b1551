//! `heli sim --library DIR`: every built-in scenario flown in lockstep with its log kept, a
//! library of recorded flights. Replayed later with `heli hilsim --replay DIR/NAME.mcap`
//! against `heli vehicle`, they check that changed flight software still gives the recorded
//! servo commands on these already-tested inputs (thesis §3.2).

use std::fmt::Write as _;
use std::path::Path;

use heli_scenario as scenario;

use crate::logging::{FlyError, fly};
use crate::{Outcome, RunOptions};

/// Why the library could not be recorded.
#[derive(Debug)]
pub enum LibraryError {
    /// The directory or the index could not be written.
    Io(std::io::Error),
    /// A flight could not be flown or logged.
    Fly(FlyError),
}

impl std::fmt::Display for LibraryError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LibraryError::Io(e) => write!(f, "{e}"),
            LibraryError::Fly(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for LibraryError {}

/// Records the library into `dir`, a line for each flight to `say`; true when every flight
/// passed (a failed one's log is kept all the same).
pub fn record(dir: &Path, say: &mut dyn FnMut(&str)) -> Result<bool, LibraryError> {
    let io = |what: String| {
        move |e: std::io::Error| {
            LibraryError::Io(std::io::Error::new(e.kind(), format!("{what}: {e}")))
        }
    };
    std::fs::create_dir_all(dir).map_err(io(format!("creating {}", dir.display())))?;
    let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
    let mut index = format!(
        "# recorded flights of the built-in scenarios ({software}); replay one with\n\
         # heli hilsim --ptys DEV --replay FILE, then heli vehicle --hilsim DEV and\n\
         # heli vehicle ctl start-logging SUFFIX MODE PLAN (as the replay prints them)\n\
         # file, scenario, seed, simulated s, outcome\n"
    );
    let mut all_passed = true;
    for s in scenario::builtins() {
        let (name, seed) = (s.name.clone(), s.seed);
        let file = dir.join(format!("{name}.mcap"));
        let summary = fly(s, RunOptions::default(), Some(&file), None, |_, _| {})
            .map_err(LibraryError::Fly)?;
        let outcome = if summary.outcome == Outcome::Pass {
            "pass"
        } else {
            all_passed = false;
            "FAIL"
        };
        say(&format!(
            "{:<16} {:>7.1} s  {outcome}  {}",
            name,
            summary.sim_time_s,
            file.display()
        ));
        let _ = writeln!(
            index,
            "{name}.mcap, {name}, {seed}, {:.1}, {outcome}",
            summary.sim_time_s
        );
    }
    let path = dir.join("index.txt");
    std::fs::write(&path, index).map_err(io(format!("writing {}", path.display())))?;
    say(&format!("index      {}", path.display()));
    Ok(all_passed)
}
