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
    /// Fly the flight software with a vehicle's parameter file (`<log-dir>/params`) instead
    /// of its defaults.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
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
    /// With --flight: write the simulator's truth beside the estimate here (CSV), as
    /// `heli sim --truth`.
    #[arg(long, requires = "flight", value_name = "PATH")]
    truth: Option<PathBuf>,
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
    Suite(SuiteArgs),
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
    let software = software_of(args.params.as_deref())?;
    let report = fly_campaign(&campaign, shard, args.jobs, &software)?;
    finish(&report, args.out.as_deref(), args.json)
}

/// Flies a campaign's flights of `shard` on `jobs` threads, with a progress bar on a
/// terminal.
pub(crate) fn fly_campaign(
    campaign: &Campaign,
    shard: Shard,
    jobs: Option<usize>,
    software: &heli_fsw::CoreConfig,
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
    let report =
        campaign::run_with_software(campaign, RunConfig { jobs, shard }, software, |flight| {
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
    let written = match out {
        Some(dir) => heli_campaign::files::write_report(report, dir)?,
        None => Vec::new(),
    };
    if json {
        println!("{}", serde_json::to_string_pretty(report)?);
    } else {
        print!("{}", heli_campaign::table::report_table(report));
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

/// `--flight I`: flies one flight as `heli sim` does.
fn one_flight(campaign: &Campaign, index: u64, args: &RunArgs) -> Result<ExitCode> {
    let flight = campaign.flight(index)?;
    let values = if flight.values.is_empty() {
        "nothing varied".to_string()
    } else {
        heli_campaign::table::values_text(&flight.values, ", ")
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
        truth: args.truth.clone(),
        ui: false,
        http: std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
        calibration_s: 0.0,
    };
    crate::fly(scenario, &sim)
}

/// The arguments of `heli campaign suite`.
#[derive(clap::Args)]
pub(crate) struct SuiteArgs {
    /// The directory of campaign files (every *.toml in it, in name order).
    #[arg(value_name = "DIR")]
    dir: PathBuf,
    /// Worker threads [default: one per core].
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Write each campaign's report.json and plots into DIR/<campaign>, and suite.json.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Least share of all flights that must pass (percent).
    #[arg(long, default_value_t = 99.0, value_name = "PERCENT")]
    min_pass_rate: f64,
    /// Fly the flight software with a vehicle's parameter file (`<log-dir>/params`, as the
    /// link's parameter protocol writes it) instead of its defaults.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
}

/// The flight software configured with the parameter file `path` (its defaults without one).
pub(crate) fn software_of(path: Option<&std::path::Path>) -> Result<heli_fsw::CoreConfig> {
    let mut config = heli_fsw::CoreConfig::default();
    if let Some(path) = path {
        let table = heli_vehicle::params::load_file(path)?;
        heli_vehicle::params::apply(&table, &mut config);
    }
    Ok(config)
}

/// Flies every campaign of the suite `dir` with the flight software `software`, saying each
/// as it ends; the reports, with their files.
pub(crate) fn fly_suite(
    dir: &std::path::Path,
    jobs: Option<usize>,
    software: &heli_fsw::CoreConfig,
) -> Result<Vec<(PathBuf, Report)>> {
    let campaigns = heli_campaign::suite::load(dir)?;
    let mut reports = Vec::new();
    for (file, campaign) in &campaigns {
        let report = fly_campaign(campaign, Shard::ALL, jobs, software)?;
        eprintln!(
            "{}: {} of {} passed",
            campaign.name, report.totals.pass, report.totals.flights
        );
        reports.push((file.clone(), report));
    }
    Ok(reports)
}

/// Flies the suite and prints one row per campaign and the totals.
pub(crate) fn suite(args: &SuiteArgs) -> Result<ExitCode> {
    if !(0.0..=100.0).contains(&args.min_pass_rate) {
        bail!(
            "--min-pass-rate {}: must be from 0 to 100",
            args.min_pass_rate
        );
    }
    let software = software_of(args.params.as_deref())?;
    let mut reports: Vec<Report> = Vec::new();
    for (file, report) in fly_suite(&args.dir, args.jobs, &software)? {
        // By file, not by campaign name: two files may share a name.
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        if let Some(dir) = &args.out {
            let out = dir.join(stem.unwrap_or_else(|| report.campaign.clone()));
            heli_campaign::files::write_report(&report, &out)?;
        }
        reports.push(report);
    }
    let verdict = heli_campaign::suite::judge(&reports, args.min_pass_rate);
    print!("{}", verdict.table());
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir)?;
        let path = dir.join("suite.json");
        std::fs::write(&path, serde_json::to_string_pretty(&verdict)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote      {}", path.display());
    }
    println!("outcome    {}", verdict.outcome());
    Ok(if verdict.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
