//! `heli log replay FILE`: the flight's recorded device inputs fed to a fresh flight
//! computer; reports whether its servo commands and state estimates match the log bit for
//! bit, and where the first difference is.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_log::LogContents;
use heli_sim::replay::log as replay;
use heli_sim::replay::setup::setup_of;

/// Replays a log; exit 0 on an exact match, 1 on a difference.
pub fn replay(file: &Path, contents: &LogContents) -> Result<ExitCode> {
    let setup = setup_of(contents).with_context(|| format!("{}", file.display()))?;
    let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
    let logged = contents
        .metadata
        .iter()
        .find_map(|m| m.entries.get("software"))
        .map(String::as_str);
    if logged.is_some_and(|l| l != software) {
        eprintln!(
            "heli log replay: the log was written by {}, this is {software}: a difference may be the software's",
            logged.unwrap_or("?")
        );
    }
    let outcome =
        replay::replay(&setup, contents).with_context(|| format!("{}", file.display()))?;
    println!("{}", file.display());
    println!("  device inputs fed  {}", outcome.inputs);
    for (channel, n) in &outcome.compared {
        println!("  {channel:<8} {n} messages compared");
    }
    match &outcome.first_difference {
        None if outcome.exact() => {
            println!("  EXACT MATCH: servo commands and state estimates identical bit for bit");
            Ok(ExitCode::SUCCESS)
        }
        None => bail!("nothing to compare: the log has no servo or state messages"),
        Some(d) => {
            let t = d.logged_t_us.or(d.replayed_t_us).unwrap_or(0) as f64 * 1e-6;
            println!(
                "  FIRST DIFFERENCE  {} message {} at t={t:.6} s",
                d.channel, d.index
            );
            for f in &d.fields {
                println!("    {f}");
            }
            Ok(ExitCode::FAILURE)
        }
    }
}
