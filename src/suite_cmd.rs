//! `heli campaign suite DIR`: every campaign file of a directory flown and judged together —
//! the robustness suite (campaigns/robustness, docs/robustness.md).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_campaign::{Report, Shard};

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
    let campaigns = heli_campaign::suite::load(&args.dir)?;
    let mut reports: Vec<Report> = Vec::new();
    for (file, campaign) in &campaigns {
        let report = crate::campaign_cmd::fly_campaign(campaign, Shard::ALL, args.jobs)?;
        // By file, not by campaign name: two files may share a name.
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        if let Some(dir) = &args.out {
            let out = dir.join(stem.unwrap_or_else(|| campaign.name.clone()));
            heli_campaign::files::write_report(&report, &out)?;
        }
        eprintln!(
            "{}: {} of {} passed",
            campaign.name, report.totals.pass, report.totals.flights
        );
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
