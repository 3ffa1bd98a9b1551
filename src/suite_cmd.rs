//! `heli campaign suite DIR`: every campaign file of a directory flown and judged together —
//! the robustness suite (campaigns/robustness, docs/robustness.md).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_campaign::{Campaign, Report, Shard};

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
}

/// Flies the suite and prints one row per campaign and the totals.
pub(crate) fn suite(args: &SuiteArgs) -> Result<ExitCode> {
    if !(0.0..=100.0).contains(&args.min_pass_rate) {
        bail!(
            "--min-pass-rate {}: must be from 0 to 100",
            args.min_pass_rate
        );
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&args.dir)
        .with_context(|| format!("reading {}", args.dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("no campaign files (*.toml) in {}", args.dir.display());
    }
    // Every file is checked before any flight is flown.
    let campaigns = files
        .iter()
        .map(|f| Campaign::load(f).map_err(anyhow::Error::from))
        .collect::<Result<Vec<_>>>()?;
    let mut reports: Vec<Report> = Vec::new();
    for (campaign, file) in campaigns.iter().zip(&files) {
        let report = crate::campaign_cmd::fly_campaign(campaign, Shard::ALL, args.jobs)?;
        // By file, not by campaign name: two files may share a name.
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        let out = args
            .out
            .as_ref()
            .map(|d| d.join(stem.unwrap_or_else(|| campaign.name.clone())));
        crate::campaign_cmd::write_report(&report, out.as_deref())?;
        eprintln!(
            "{}: {} of {} passed",
            campaign.name, report.totals.pass, report.totals.flights
        );
        reports.push(report);
    }
    let (flights, pass, crash, error) = reports.iter().fold((0, 0, 0, 0), |acc, r| {
        let t = &r.totals;
        (
            acc.0 + t.flights,
            acc.1 + t.pass,
            acc.2 + t.crash,
            acc.3 + t.error,
        )
    });
    let rate = if flights > 0 {
        100.0 * pass as f64 / flights as f64
    } else {
        0.0
    };
    println!(
        "{:<16} {:>8} {:>6} {:>6} {:>6} {:>6}  pass rate",
        "campaign", "flights", "pass", "fail", "crash", "error"
    );
    for r in &reports {
        let t = &r.totals;
        println!(
            "{:<16} {:>8} {:>6} {:>6} {:>6} {:>6}  {:>6.1} %",
            r.campaign,
            t.flights,
            t.pass,
            t.fail,
            t.crash,
            t.error,
            t.pass_rate.unwrap_or(0.0) * 100.0
        );
    }
    println!(
        "{:<16} {:>8} {:>6} {:>6} {:>6} {:>6}  {:>6.1} %",
        "all",
        flights,
        pass,
        flights - pass - crash - error,
        crash,
        error,
        rate
    );
    let passed = crash == 0 && error == 0 && rate >= args.min_pass_rate;
    if let Some(dir) = &args.out {
        let rows: Vec<serde_json::Value> = reports
            .iter()
            .map(|r| serde_json::json!({ "campaign": r.campaign, "file": r.file, "totals": r.totals }))
            .collect();
        let json = serde_json::json!({
            "campaigns": rows,
            "flights": flights,
            "pass": pass,
            "crash": crash,
            "error": error,
            "pass_rate_percent": rate,
            "min_pass_rate_percent": args.min_pass_rate,
            "passed": passed,
        });
        std::fs::create_dir_all(dir)?;
        let path = dir.join("suite.json");
        std::fs::write(&path, serde_json::to_string_pretty(&json)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote      {}", path.display());
    }
    println!(
        "outcome    {}",
        if passed {
            format!(
                "suite passed ({rate:.1} % ≥ {} %, no crash)",
                args.min_pass_rate
            )
        } else {
            format!(
                "suite FAILED ({rate:.1} % of {flights} flights passed, {crash} crashed, {error} could not be flown)"
            )
        }
    );
    Ok(if passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
