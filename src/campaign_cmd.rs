//! `heli campaign`: Monte Carlo campaigns of simulated flights (docs/campaigns.md).
//!
//! `heli campaign FILE` flies every flight of the campaign on all cores (or `--jobs N`),
//! `--shard I/N` only the flights whose index is I modulo N, for a batch system's array job;
//! `heli campaign merge REPORT...` joins the shards' reports. `--flight I` flies one flight
//! as `heli sim` would, to look at a worst case. The exit status is 0 only when every
//! flight flown (or merged) passed, 1 when one did not, 2 when the campaign could not run.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use heli_campaign::log_plot::ImageFormat;
use heli_campaign::{self as campaign, Campaign, FlightOutcome, Report, RunConfig, Shard};

/// `heli campaign FILE ...`.
#[derive(clap::Args)]
pub(crate) struct RunArgs {
    /// The campaign file (TOML, docs/campaigns.md).
    #[arg(required = true)]
    file: Option<PathBuf>,
    /// Worker threads [default: one per core].
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Fly only shard I of N: the flights whose index is I modulo N. I counts from 0, as
    /// $SLURM_ARRAY_TASK_ID and $JOB_COMPLETION_INDEX do; join the reports with `merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Write report.json and the outcome plots (outcomes.svg, outcomes.png) into this
    /// directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print the report as JSON on stdout instead of the table (with --flight: the
    /// flight's summary, as `heli sim --json`).
    #[arg(long)]
    json: bool,
    /// Fly only flight I, as `heli sim` does, and print its table: the reproduce command of
    /// a worst case.
    #[arg(long, value_name = "I", conflicts_with_all = ["shard", "jobs", "out"])]
    flight: Option<u64>,
    /// With --flight: write its flight log (MCAP) here, as `heli sim --log`.
    #[arg(long, requires = "flight", value_name = "PATH")]
    log: Option<PathBuf>,
    /// With --flight: write its whole scenario here, so that `heli sim --scenario PATH`
    /// flies it.
    #[arg(long, requires = "flight", value_name = "PATH")]
    write_scenario: Option<PathBuf>,
}

/// `heli campaign merge ...`.
#[derive(Subcommand)]
pub(crate) enum MergeCommand {
    /// Join shard reports (report.json of each `--shard I/N`) into the report of the whole
    /// campaign; refused when they are of different campaign files, overlap or miss a
    /// flight.
    Merge(MergeArgs),
    /// Fly every campaign file of a directory (a suite, such as campaigns/robustness) and
    /// judge them together: exit 0 only when no flight crashed or could not be flown and the
    /// pass rate over all flights reaches --min-pass-rate.
    Suite(crate::suite_cmd::SuiteArgs),
}

/// The arguments of `heli campaign merge`.
#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// The shards' reports.
    #[arg(required = true, value_name = "REPORT")]
    reports: Vec<PathBuf>,
    /// Write the merged report.json and the outcome plots into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print the merged report as JSON on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

/// `heli campaign FILE`: flies the campaign (or one shard, or one flight).
pub(crate) fn campaign(args: &RunArgs) -> Result<ExitCode> {
    let Some(file) = &args.file else {
        bail!("give a campaign file: heli campaign FILE (or heli campaign merge REPORT...)");
    };
    let campaign = Campaign::load(file)?;
    if let Some(index) = args.flight {
        return one_flight(&campaign, index, args);
    }
    let shard = match &args.shard {
        Some(s) => s.parse::<Shard>()?,
        None => Shard::ALL,
    };
    let report = fly_campaign(&campaign, shard, args.jobs)?;
    finish(&report, args.out.as_deref(), args.json)
}

/// Flies a campaign's flights of `shard` on `jobs` threads, with a progress bar on a
/// terminal.
pub(crate) fn fly_campaign(
    campaign: &Campaign,
    shard: Shard,
    jobs: Option<usize>,
) -> Result<Report> {
    let in_shard = (0..campaign.flights_total())
        .filter(|i| shard.contains(*i))
        .count() as u64;
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = indicatif::ProgressBar::new(in_shard);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {msg} [{bar:40}] {pos}/{len} flights, {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(format!("campaign {}", campaign.name));
        bar
    });
    let not_passed = AtomicU64::new(0);
    let report = campaign::run(campaign, RunConfig { jobs, shard }, |flight| {
        if flight.outcome != FlightOutcome::Pass {
            not_passed.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(bar) = &bar {
            bar.inc(1);
            bar.set_message(format!(
                "campaign {}: {} not passed",
                campaign.name,
                not_passed.load(Ordering::Relaxed)
            ));
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    Ok(report)
}

/// `heli campaign merge REPORT...`.
pub(crate) fn merge(args: &MergeArgs) -> Result<ExitCode> {
    let mut reports = Vec::with_capacity(args.reports.len());
    for path in &args.reports {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {name}"))?;
        let report: Report = serde_json::from_str(&text)
            .with_context(|| format!("{name} is not a campaign report"))?;
        reports.push((name, report));
    }
    let merged = campaign::merge(&reports)?;
    finish(&merged, args.out.as_deref(), args.json)
}

/// Writes the report's files, prints it, and says by the exit status whether every flight
/// passed.
fn finish(report: &Report, out: Option<&Path>, json: bool) -> Result<ExitCode> {
    let written = write_report(report, out)?;
    if json {
        println!("{}", serde_json::to_string_pretty(report)?);
    } else {
        print_report(report);
        for path in &written {
            println!("wrote      {}", path.display());
        }
    }
    Ok(if report.all_passed() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Writes report.json and the outcome plots into `out`, if given; returns what it wrote.
pub(crate) fn write_report(report: &Report, out: Option<&Path>) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join("report.json");
        std::fs::write(&path, serde_json::to_string_pretty(report)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
        for (name, format) in [
            ("outcomes.svg", ImageFormat::Svg),
            ("outcomes.png", ImageFormat::Png),
        ] {
            let path = dir.join(name);
            campaign::plot::render(report, format, &path).map_err(anyhow::Error::msg)?;
            written.push(path);
        }
    }
    Ok(written)
}

/// `--flight I`: flies one flight as `heli sim` does.
fn one_flight(campaign: &Campaign, index: u64, args: &RunArgs) -> Result<ExitCode> {
    let flight = campaign.flight(index)?;
    let values = if flight.values.is_empty() {
        "nothing varied".to_string()
    } else {
        values_text(&flight.values, ", ")
    };
    if let Some(path) = &args.write_scenario {
        let header = format!(
            "# Flight {index} of campaign \"{}\" ({}): {values}\n# heli sim --scenario {}\n",
            campaign.name,
            campaign.file,
            path.display()
        );
        let text = flight
            .scenario_file_text(&campaign.root_base(), &header)
            .map_err(anyhow::Error::msg)?;
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
        if !args.json {
            println!("wrote      {}", path.display());
        }
    }
    let scenario = flight.scenario().map_err(anyhow::Error::msg)?;
    if !args.json {
        println!(
            "flight     {index} of campaign {} (seed {}): {values}",
            campaign.name, flight.seed
        );
    }
    let sim = crate::SimArgs {
        scenario: None,
        duration: None,
        realtime: false,
        seed: None,
        json: args.json,
        list: false,
        library: None,
        log: args.log.clone(),
        ui: false,
        http: String::new(),
        calibration_s: 0.0,
    };
    crate::fly(scenario, &sim)
}

fn values_text(
    values: &std::collections::BTreeMap<String, serde_json::Value>,
    sep: &str,
) -> String {
    let parts: Vec<String> = values
        .iter()
        .map(|(k, v)| match v.as_f64() {
            Some(x) if !v.is_i64() && !v.is_u64() => format!("{k} = {x:.3}"),
            _ => format!("{k} = {v}"),
        })
        .collect();
    parts.join(sep)
}

fn print_report(r: &Report) {
    println!(
        "campaign   {} ({}, fingerprint {})",
        r.campaign, r.file, r.fingerprint
    );
    match r.shard {
        Some(s) => println!(
            "flights    {} of {} (shard {s}: the flights whose index is {} modulo {})",
            r.totals.flights, r.flights_total, s.index, s.count
        ),
        None => println!("flights    {} of {}", r.totals.flights, r.flights_total),
    }
    if r.wall.jobs > 0 {
        println!(
            "wall time  {:.1} s on {} threads ({:.1} s of flights)",
            r.wall.elapsed_s, r.wall.jobs, r.wall.flights_s
        );
    }
    let t = &r.totals;
    let share = |n: u64| {
        if t.flights == 0 {
            0.0
        } else {
            100.0 * n as f64 / t.flights as f64
        }
    };
    println!();
    println!("{:<10} {:>8} {:>8}", "outcome", "flights", "share");
    for (name, n) in [
        ("pass", t.pass),
        ("fail", t.fail),
        ("crash", t.crash),
        ("error", t.error),
    ] {
        println!("{name:<10} {n:>8} {:>7.1}%", share(n));
    }
    if let (Some(rate), Some([lo, hi])) = (t.pass_rate, t.pass_rate_ci95) {
        println!(
            "pass rate  {:.1} % (95 % interval {:.1} to {:.1} %)",
            100.0 * rate,
            100.0 * lo,
            100.0 * hi
        );
    }
    if !r.criterion_failures.is_empty() {
        println!();
        println!("{:<32} {:>8}", "criterion", "failed");
        for (name, n) in &r.criterion_failures {
            println!("{name:<32} {n:>8}");
        }
    }
    if !r.worst.is_empty() {
        println!();
        println!(
            "worst cases (errors, crashes, then by score: worst criterion / its limit, above 1 fails)"
        );
        for w in &r.worst {
            let score = w.score.map_or("-".to_string(), |s| format!("{s:.2}"));
            println!(
                "  flight {:<6} {:<6} score {score:<6} {}",
                w.index,
                w.outcome.name(),
                values_text(&w.values, ", ")
            );
            println!("    {}", w.why);
            println!("    {}", w.reproduce);
        }
    }
    println!();
    println!(
        "outcome    {}",
        if r.all_passed() {
            "every flight passed"
        } else {
            "NOT every flight passed"
        }
    );
}
