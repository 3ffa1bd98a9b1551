//! `heli field-day`: the field-day fault campaign on the real processes (heli-fieldday).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use heli_fieldday::{Fault, Options, Phase};

/// Arguments of `heli field-day`.
#[derive(clap::Args)]
pub struct FieldDayArgs {
    /// Faults to inject (comma-separated; default all): kill-flight, kill-bootstrap,
    /// disk-full, read-only, port-hangup, stall-0.2, stall-1, stall-3, servo-silent, brownout.
    #[arg(long, value_delimiter = ',')]
    pub faults: Vec<String>,
    /// Phases to strike in (comma-separated; default both): hover, rolls.
    #[arg(long, value_delimiter = ',')]
    pub phases: Vec<String>,
    /// Only CI's subset: each kind of recovery once (kill-flight in the hover, kill-bootstrap
    /// in the rolls, disk-full in the hover, stall-3 and brownout in the rolls).
    #[arg(long, conflicts_with_all = ["faults", "phases"])]
    pub ci: bool,
    /// Where each trial keeps its logs, snapshots and what was said.
    #[arg(long, default_value = "field-day")]
    pub out: PathBuf,
    /// A Python with the official MCAP reader (`pip install mcap`).
    #[arg(long, env = "HELI_MCAP_PYTHON", default_value = "python3")]
    pub python: PathBuf,
    /// The HILSim's seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Make the storage faults by a file-size limit and the directory's permissions even where
    /// a tmpfs could be mounted (as without root).
    #[arg(long)]
    pub no_mount: bool,
    /// Print the outcomes as JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs the campaign; exit status 0 only when every trial passes.
pub fn field_day(args: &FieldDayArgs) -> Result<ExitCode> {
    let trials = if args.ci {
        heli_fieldday::ci_trials()
    } else {
        let faults: Vec<Fault> = if args.faults.is_empty() {
            heli_fieldday::fault::ALL.to_vec()
        } else {
            args.faults
                .iter()
                .map(|f| Fault::parse(f))
                .collect::<Result<_, _>>()?
        };
        let phases: Vec<Phase> = if args.phases.is_empty() {
            heli_fieldday::fault::PHASES.to_vec()
        } else {
            args.phases
                .iter()
                .map(|p| Phase::parse(p))
                .collect::<Result<_, _>>()?
        };
        faults
            .iter()
            .flat_map(|&f| phases.iter().map(move |&p| (f, p)))
            .collect()
    };
    let heli = std::env::current_exe().context("finding this program")?;
    let vehicle = crate::onboard_program("")?;
    let options = Options {
        programs: heli_fieldday::procs::Programs { heli, vehicle },
        python: args.python.clone(),
        out: args.out.clone(),
        trials,
        seed: args.seed,
        mount: !args.no_mount,
    };
    eprintln!(
        "field day: {} trials in real time, one at a time, in {}",
        options.trials.len(),
        options.out.display()
    );
    let options_out = options.out.clone();
    let outcomes = heli_fieldday::run(&options, |o, verdict| {
        let said = match (verdict, o.pass) {
            (false, _) => format!("VOID, trying again ({})", o.starved.join("; ")),
            (true, true) if o.void_tries.is_empty() => "pass".into(),
            (true, true) => format!("pass (after {} void tries)", o.void_tries.len()),
            (true, false) => "FAIL".into(),
        };
        eprintln!(
            "field day: {} while {}: {said} ({:.0} s)",
            o.fault, o.phase, o.seconds
        );
        if !o.pass {
            eprint!(
                "{}",
                story(&options_out.join(format!("{}-{}", o.fault, o.phase)))
            );
        }
    })?;
    let report = heli_fieldday::report::table(&outcomes);
    std::fs::create_dir_all(&args.out)?;
    std::fs::write(args.out.join("table.md"), &report)?;
    std::fs::write(
        args.out.join("outcomes.json"),
        serde_json::to_string_pretty(&outcomes)?,
    )?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&outcomes)?);
    } else {
        print!("{report}");
    }
    Ok(if outcomes.iter().all(|o| o.pass) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// What a failed trial's processes said, for a reader who has only the console (CI keeps
/// nothing else): the vehicle's lines less the routine late/ok notices, and the HILSim's last.
fn story(trial_dir: &std::path::Path) -> String {
    const VEHICLE_LINES: usize = 60;
    const HILSIM_LINES: usize = 15;
    let read = |name: &str| std::fs::read_to_string(trial_dir.join(name)).unwrap_or_default();
    let said = read("said.txt");
    let told: Vec<&str> = said
        .lines()
        .filter(|l| !(l.ends_with(" late") || l.ends_with(" ok")))
        .collect();
    let hilsim = read("hilsim.txt");
    let hil: Vec<&str> = hilsim.lines().collect();
    let mut text = format!(
        "  what the vehicle said (less late/ok notices; last {VEHICLE_LINES} of {}):\n",
        told.len()
    );
    for line in &told[told.len().saturating_sub(VEHICLE_LINES)..] {
        text.push_str(&format!("    {line}\n"));
    }
    text.push_str(&format!(
        "  what the HILSim said (last {HILSIM_LINES} of {}):\n",
        hil.len()
    ));
    for line in &hil[hil.len().saturating_sub(HILSIM_LINES)..] {
        text.push_str(&format!("    {line}\n"));
    }
    text
}
