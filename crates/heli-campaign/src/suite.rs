//! A suite: every campaign file of a directory, flown and judged together — the robustness
//! suite (campaigns/robustness, docs/robustness.md). It passes when no flight crashed or
//! could not be flown and the share of all flights that passed reaches its floor.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::{Campaign, CampaignError, Report, Totals};

/// The campaign files of `dir` (every `*.toml`, in name order), each loaded and checked
/// before any flight is flown.
pub fn load(dir: &Path) -> Result<Vec<(PathBuf, Campaign)>, CampaignError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| CampaignError::SuiteDirectory {
            dir: dir.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(CampaignError::EmptySuite(dir.to_path_buf()));
    }
    files
        .into_iter()
        .map(|f| Campaign::load(&f).map(|c| (f, c)))
        .collect()
}

/// A suite's verdict.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// Each campaign's name, file and totals.
    pub campaigns: Vec<CampaignRow>,
    /// Flights of all campaigns.
    pub flights: u64,
    /// Of them passed.
    pub pass: u64,
    /// Crashed.
    pub crash: u64,
    /// Could not be flown.
    pub error: u64,
    /// Share passed (percent).
    pub pass_rate_percent: f64,
    /// The floor (percent).
    pub min_pass_rate_percent: f64,
    /// No crash, no error, and the floor reached.
    pub passed: bool,
}

/// One campaign of a suite.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignRow {
    /// Its name.
    pub campaign: String,
    /// Its file.
    pub file: String,
    /// Its totals.
    pub totals: Totals,
}

/// Judges the suite's reports against the floor `min_pass_rate_percent`.
pub fn judge(reports: &[Report], min_pass_rate_percent: f64) -> Verdict {
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
    Verdict {
        campaigns: reports
            .iter()
            .map(|r| CampaignRow {
                campaign: r.campaign.clone(),
                file: r.file.clone(),
                totals: r.totals.clone(),
            })
            .collect(),
        flights,
        pass,
        crash,
        error,
        pass_rate_percent: rate,
        min_pass_rate_percent,
        passed: crash == 0 && error == 0 && rate >= min_pass_rate_percent,
    }
}

impl Verdict {
    /// One row per campaign and the totals, as `heli campaign suite` prints them.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<16} {:>8} {:>6} {:>6} {:>6} {:>6}  pass rate",
            "campaign", "flights", "pass", "fail", "crash", "error"
        );
        for r in &self.campaigns {
            let t = &r.totals;
            let _ = writeln!(
                out,
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
        let _ = writeln!(
            out,
            "{:<16} {:>8} {:>6} {:>6} {:>6} {:>6}  {:>6.1} %",
            "all",
            self.flights,
            self.pass,
            self.flights - self.pass - self.crash - self.error,
            self.crash,
            self.error,
            self.pass_rate_percent
        );
        out
    }

    /// The last line: passed, or why not.
    pub fn outcome(&self) -> String {
        if self.passed {
            format!(
                "suite passed ({:.1} % ≥ {} %, no crash)",
                self.pass_rate_percent, self.min_pass_rate_percent
            )
        } else {
            format!(
                "suite FAILED ({:.1} % of {} flights passed, {} crashed, {} could not be flown)",
                self.pass_rate_percent, self.flights, self.crash, self.error
            )
        }
    }
}
