//! A campaign's report (JSON): every flight, the totals, failures per criterion and the
//! worst cases, each with the command that flies it again. [`super::merge()`] joins shard
//! reports into the report a whole run would have written.
//!
//! Everything but [`Report::wall`] is a function of the campaign file and the flights'
//! results, so a report is compared without it ([`Report::without_wall`]).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::Campaign;
use super::sample::Flight;
pub use super::score::SCORE_CAP;
use super::score::score;
use super::shard::Shard;
use heli_sim::summary::{Outcome, Summary};

/// Worst cases a report lists.
pub const WORST_CASES: usize = 10;

/// How one flight ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FlightOutcome {
    /// Every criterion passed.
    Pass,
    /// A criterion failed.
    Fail,
    /// The helicopter hit the ground too hard or rolled over.
    Crash,
    /// The flight could not be flown (its scenario was refused) or the simulation panicked.
    Error,
}

impl FlightOutcome {
    /// The outcome's name, as in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            FlightOutcome::Pass => "pass",
            FlightOutcome::Fail => "fail",
            FlightOutcome::Crash => "crash",
            FlightOutcome::Error => "error",
        }
    }
}

/// A criterion a flight failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailedCriterion {
    /// Its name, as in `heli sim`'s summary.
    pub name: String,
    /// What was measured (`null`: nothing was).
    pub value: Option<f64>,
    /// The limit.
    pub limit: f64,
}

/// One flight's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlightRecord {
    /// Its index in the campaign.
    pub index: u64,
    /// Its scenario's seed.
    pub seed: u64,
    /// The value of each varied key.
    pub values: BTreeMap<String, serde_json::Value>,
    /// How it ended.
    pub outcome: FlightOutcome,
    /// Simulated time flown (s); `null` for an error.
    pub sim_time_s: Option<f64>,
    /// Why it crashed.
    pub crash: Option<String>,
    /// Why it could not be flown, or the panic's message and place.
    pub error: Option<String>,
    /// The criteria it failed.
    pub failed: Vec<FailedCriterion>,
    /// Ranking score: the worst criterion's value over its limit, turned so that above 1
    /// fails (limit over value for a failed at-least criterion), at most [`SCORE_CAP`];
    /// passing at-least criteria (flags, counts, durations) do not count, and it is 0 when
    /// nothing else was judged; `null` for an error.
    pub score: Option<f64>,
    /// The criterion that gave the score.
    pub worst_criterion: Option<String>,
}

impl FlightRecord {
    /// The record of a flight that was flown.
    pub fn flown(flight: &Flight, summary: &Summary) -> Self {
        let outcome = match summary.outcome {
            Outcome::Pass => FlightOutcome::Pass,
            Outcome::Fail => FlightOutcome::Fail,
            Outcome::Crash => FlightOutcome::Crash,
        };
        let (score, worst_criterion) = score(&summary.criteria);
        FlightRecord {
            index: flight.index,
            seed: flight.seed,
            values: flight.values.clone(),
            outcome,
            sim_time_s: Some(summary.sim_time_s),
            crash: summary.crash.clone(),
            error: None,
            failed: summary
                .criteria
                .iter()
                .filter(|c| !c.pass)
                .map(|c| FailedCriterion {
                    name: c.name.clone(),
                    value: c.value,
                    limit: c.limit,
                })
                .collect(),
            score: Some(score),
            worst_criterion,
        }
    }

    /// The record of a flight that could not be flown.
    pub fn error(
        index: u64,
        seed: u64,
        values: BTreeMap<String, serde_json::Value>,
        why: String,
    ) -> Self {
        FlightRecord {
            index,
            seed,
            values,
            outcome: FlightOutcome::Error,
            sim_time_s: None,
            crash: None,
            error: Some(why),
            failed: Vec::new(),
            score: None,
            worst_criterion: None,
        }
    }

    /// One line on why it ranks where it does.
    pub fn why(&self) -> String {
        if let Some(e) = &self.error {
            return e.clone();
        }
        if let Some(c) = &self.crash {
            return format!("crash: {c}");
        }
        if !self.failed.is_empty() {
            let failed: Vec<String> = self
                .failed
                .iter()
                .map(|f| match f.value {
                    Some(v) => format!("{} {v:.3} (limit {})", f.name, f.limit),
                    None => format!("{} not measured (limit {})", f.name, f.limit),
                })
                .collect();
            return format!("failed {}", failed.join(", "));
        }
        match (&self.worst_criterion, self.score) {
            (Some(name), Some(s)) => format!("passed; closest to its limit: {name} at {s:.2}"),
            _ => "passed".into(),
        }
    }
}

/// Flights by outcome.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    /// Flights in the report.
    pub flights: u64,
    /// Passed.
    pub pass: u64,
    /// Failed a criterion.
    pub fail: u64,
    /// Crashed.
    pub crash: u64,
    /// Could not be flown, or panicked.
    pub error: u64,
    /// Passed / flights (`null` without flights).
    pub pass_rate: Option<f64>,
    /// 95 % confidence interval of the pass rate (Wilson score interval).
    pub pass_rate_ci95: Option<[f64; 2]>,
}

/// A worst case, with the command that flies it again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorstCase {
    /// The flight's index.
    pub index: u64,
    /// How it ended.
    pub outcome: FlightOutcome,
    /// Its ranking score.
    pub score: Option<f64>,
    /// Its varied values.
    pub values: BTreeMap<String, serde_json::Value>,
    /// Why it ranks here.
    pub why: String,
    /// `heli campaign FILE --flight I`.
    pub reproduce: String,
}

/// How long the flights took on the host: kept out of every comparison.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    /// From the first flight's start to the last one's end (s); merged: the sum over the
    /// shards.
    pub elapsed_s: f64,
    /// The flights' own times added up (s).
    pub flights_s: f64,
    /// Worker threads (merged: the largest).
    pub jobs: usize,
}

/// A campaign's report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The campaign's name.
    pub campaign: String,
    /// The campaign file, as given on the command line.
    pub file: String,
    /// Hash of the campaign file (and its base scenario file): reports of different files
    /// are not merged.
    pub fingerprint: String,
    /// The software that flew it.
    pub software: String,
    /// Flights in the whole campaign.
    pub flights_total: u64,
    /// The shard this report holds (`null`: every flight).
    pub shard: Option<Shard>,
    /// The varied keys, in file order.
    pub keys: Vec<String>,
    /// Flights by outcome.
    pub totals: Totals,
    /// Per criterion: how many flights failed it.
    pub criterion_failures: BTreeMap<String, u64>,
    /// The worst flights: errors, then crashes, then by score; at most [`WORST_CASES`].
    pub worst: Vec<WorstCase>,
    /// Every flight, by index.
    pub flights: Vec<FlightRecord>,
    /// Host timing (not deterministic; ignored by comparisons).
    #[serde(default)]
    pub wall: Wall,
}

/// What this build is called in reports.
pub fn software() -> String {
    concat!("heli-sim ", env!("CARGO_PKG_VERSION")).into()
}

impl Report {
    /// The report of `flights` (any order) of `campaign`.
    pub fn new(
        campaign: &Campaign,
        shard: Option<Shard>,
        flights: Vec<FlightRecord>,
        wall: Wall,
    ) -> Self {
        Self::assemble(
            Header {
                campaign: campaign.name.clone(),
                file: campaign.file.clone(),
                fingerprint: campaign.fingerprint.clone(),
                software: software(),
                flights_total: campaign.flights_total(),
                keys: campaign.vary.iter().map(|v| v.key.clone()).collect(),
            },
            shard,
            flights,
            wall,
        )
    }

    /// The report of `flights` under `h`.
    pub(crate) fn assemble(
        h: Header,
        shard: Option<Shard>,
        mut flights: Vec<FlightRecord>,
        wall: Wall,
    ) -> Self {
        flights.sort_by_key(|f| f.index);
        let count = |o: FlightOutcome| flights.iter().filter(|f| f.outcome == o).count() as u64;
        let n = flights.len() as u64;
        let pass = count(FlightOutcome::Pass);
        let totals = Totals {
            flights: n,
            pass,
            fail: count(FlightOutcome::Fail),
            crash: count(FlightOutcome::Crash),
            error: count(FlightOutcome::Error),
            pass_rate: (n > 0).then(|| pass as f64 / n as f64),
            pass_rate_ci95: (n > 0).then(|| wilson(pass, n)),
        };
        let mut criterion_failures = BTreeMap::new();
        for f in &flights {
            for c in &f.failed {
                *criterion_failures.entry(c.name.clone()).or_insert(0) += 1;
            }
        }
        let mut ranked: Vec<&FlightRecord> = flights.iter().collect();
        ranked.sort_by(|a, b| {
            rank_class(a)
                .cmp(&rank_class(b))
                .then(b.score.unwrap_or(0.0).total_cmp(&a.score.unwrap_or(0.0)))
                .then(a.index.cmp(&b.index))
        });
        let worst = ranked
            .into_iter()
            .take(WORST_CASES)
            .map(|f| WorstCase {
                index: f.index,
                outcome: f.outcome,
                score: f.score,
                values: f.values.clone(),
                why: f.why(),
                reproduce: reproduce(&h.file, f.index),
            })
            .collect();
        Report {
            campaign: h.campaign,
            file: h.file,
            fingerprint: h.fingerprint,
            software: h.software,
            flights_total: h.flights_total,
            shard,
            keys: h.keys,
            totals,
            criterion_failures,
            worst,
            flights,
            wall,
        }
    }

    /// The report with its host timing cleared: what two runs of one campaign agree on.
    pub fn without_wall(&self) -> Self {
        Report {
            wall: Wall::default(),
            ..self.clone()
        }
    }

    /// Every flight passed.
    pub fn all_passed(&self) -> bool {
        self.totals.pass == self.totals.flights
    }
}

/// What a report says about its campaign.
pub(crate) struct Header {
    pub(crate) campaign: String,
    pub(crate) file: String,
    pub(crate) fingerprint: String,
    pub(crate) software: String,
    pub(crate) flights_total: u64,
    pub(crate) keys: Vec<String>,
}

fn rank_class(f: &FlightRecord) -> u8 {
    match f.outcome {
        FlightOutcome::Error => 0,
        FlightOutcome::Crash => 1,
        FlightOutcome::Fail | FlightOutcome::Pass => 2,
    }
}

/// The Wilson score interval at 95 % for `k` successes in `n` trials.
fn wilson(k: u64, n: u64) -> [f64; 2] {
    const Z: f64 = 1.96;
    let n = n as f64;
    let p = k as f64 / n;
    let denom = 1.0 + Z * Z / n;
    let centre = (p + Z * Z / (2.0 * n)) / denom;
    let half = Z * (p * (1.0 - p) / n + Z * Z / (4.0 * n * n)).sqrt() / denom;
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// The command that flies flight `index` of the campaign in `file` again.
pub fn reproduce(file: &str, index: u64) -> String {
    format!("heli campaign {} --flight {index}", shell_quote(file))
}

fn shell_quote(s: &str) -> String {
    let plain = !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"/._-+:,=@".contains(&b));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}
