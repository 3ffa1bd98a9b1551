//! `heli sim --library DIR`: every built-in scenario flown in lockstep with its log kept, a
//! library of recorded flights. Replayed later with `heli hilsim --replay DIR/NAME.mcap`
//! against `heli vehicle`, they check that changed flight software still gives the recorded
//! servo commands on these already-tested inputs (thesis §3.2).

use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use heli_scenario as scenario;
use heli_sim::{Outcome, RunOptions};

/// Records the library into `dir`; exit 1 if a flight failed (its log is kept all the same).
pub fn record(dir: &Path) -> Result<ExitCode> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
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
        let summary = crate::run_flight(s, RunOptions::default(), Some(&file), false)?;
        let outcome = if summary.outcome == Outcome::Pass {
            "pass"
        } else {
            all_passed = false;
            "FAIL"
        };
        println!(
            "{:<16} {:>7.1} s  {outcome}  {}",
            name,
            summary.sim_time_s,
            file.display()
        );
        let _ = writeln!(
            index,
            "{name}.mcap, {name}, {seed}, {:.1}, {outcome}",
            summary.sim_time_s
        );
    }
    let path = dir.join("index.txt");
    std::fs::write(&path, index).with_context(|| format!("writing {}", path.display()))?;
    println!("index      {}", path.display());
    Ok(if all_passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
