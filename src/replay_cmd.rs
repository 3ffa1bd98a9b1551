//! `heli log replay FILE`: the flight's recorded device inputs fed to a fresh flight
//! computer; reports whether its servo commands and state estimates match the log bit for
//! bit, and where the first difference is.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_log::{LogContents, StopKind};
use heli_sim::replay::log as replay;
use heli_sim::replay::setup::setup_of;

/// What `heli log replay` concluded, with its exit status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every servo command and state estimate of the whole flight matched (exit 0).
    Exact,
    /// A difference (exit 1).
    Different,
    /// The log is cut off or damaged: what could be read matched, the rest is unknown
    /// (exit 3).
    Incomplete,
}

impl Verdict {
    /// The exit status.
    pub fn exit_code(self) -> ExitCode {
        ExitCode::from(match self {
            Verdict::Exact => 0,
            Verdict::Different => 1,
            Verdict::Incomplete => 3,
        })
    }
}

/// Replays a log and prints the verdict. Exit 0 on an exact match over the whole flight, 1
/// on a difference, 3 for a cut-off or damaged log; an error (exit 2) when it cannot be
/// replayed or nothing could be compared.
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
    let seconds = contents
        .span_us()
        .map_or(0.0, |(first, last)| (last - first) as f64 * 1e-6);
    let verdict = verdict(&outcome, contents)?;
    match (&outcome.first_difference, &contents.stopped) {
        (Some(d), _) => {
            let t = d.logged_t_us.or(d.replayed_t_us).unwrap_or(0) as f64 * 1e-6;
            println!(
                "  FIRST DIFFERENCE  {} message {} at t={t:.6} s",
                d.channel, d.index
            );
            for f in &d.fields {
                println!("    {f}");
            }
        }
        (None, Some(stop)) => {
            let what = match stop.kind {
                StopKind::Truncated => "CUT OFF",
                _ => "DAMAGED",
            };
            let share = stop.at_byte as f64 / stop.file_bytes.max(1) as f64 * 100.0;
            println!(
                "  {what}: the {seconds:.1} s of flight that could be read match bit for bit; the log \
                 stops there ({stop}; {share:.0} % of the file read), the rest was not compared"
            );
        }
        (None, None) => println!(
            "  EXACT MATCH over the whole flight ({seconds:.1} s): servo commands and state \
             estimates identical bit for bit"
        ),
    }
    Ok(verdict.exit_code())
}

/// The verdict of a replay of `contents`; an error when nothing could be compared on a
/// channel (no match is ever made of nothing).
fn verdict(outcome: &replay::ReplayOutcome, contents: &LogContents) -> Result<Verdict> {
    if outcome.first_difference.is_some() {
        return Ok(Verdict::Different);
    }
    if let Some((channel, _)) = outcome.compared.iter().find(|(_, n)| **n == 0) {
        let why = contents
            .stopped
            .as_ref()
            .map(|s| format!(" (the log stops early: {s})"))
            .unwrap_or_default();
        bail!("nothing to compare: the log has no {channel} messages{why}");
    }
    if outcome.compared.is_empty() {
        bail!("nothing to compare: the log has no servo or state messages");
    }
    Ok(if contents.stopped.is_some() {
        Verdict::Incomplete
    } else {
        Verdict::Exact
    })
}
