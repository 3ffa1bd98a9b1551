//! Why a campaign could not be loaded, run or merged, by kind. The text names the file, and
//! where it applies the key, the flight or the allowed range.

use std::fmt;
use std::path::PathBuf;

use heli_scenario::ScenarioError;

use crate::checks::VaryError;
use crate::keys::KeyError;
use crate::vary::ResolveError;

/// A campaign that cannot be loaded, run or merged.
#[derive(Debug)]
pub enum CampaignError {
    /// The campaign file could not be read.
    Read {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// The campaign file is not a valid campaign.
    File {
        /// The file.
        file: String,
        /// What is wrong with it.
        problem: Box<FileProblem>,
    },
    /// A flight number the campaign does not have.
    NoSuchFlight {
        /// The campaign file.
        file: String,
        /// The number asked for.
        index: u64,
        /// The campaign's flights.
        total: u64,
    },
    /// A drawn value cannot be written into a flight's scenario.
    Draw {
        /// The campaign file.
        file: String,
        /// The flight.
        index: u64,
        /// The varied key.
        key: String,
        /// Why.
        error: Box<KeyError>,
    },
    /// `--shard` is not `I/N` with `0 <= I < N`.
    Shard {
        /// What was given.
        given: String,
        /// What is wrong with it.
        problem: ShardProblem,
    },
    /// `--jobs 0`.
    NoJobs,
    /// The worker threads could not be started.
    Workers(rayon::ThreadPoolBuildError),
    /// Shard reports that do not make one campaign.
    Merge(Box<MergeProblem>),
    /// A suite's directory could not be read.
    SuiteDirectory {
        /// The directory.
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A suite's directory holds no campaign file.
    EmptySuite(PathBuf),
}

/// What is wrong with a campaign file.
#[derive(Debug)]
pub enum FileProblem {
    /// Not TOML, or fields of the wrong type or name.
    Toml(toml::de::Error),
    /// `name` is empty.
    NoName,
    /// `samples` is out of range.
    Samples {
        /// The value.
        samples: u64,
        /// The most allowed.
        max: u64,
    },
    /// `[scenario]` sets what the campaign gives (its base, seed or name).
    Reserved {
        /// The field.
        key: &'static str,
        /// Why, and what to do instead.
        why: &'static str,
    },
    /// The base is neither a built-in scenario nor a readable scenario file.
    BaseNotFound {
        /// The base given.
        base: String,
        /// The file looked for.
        path: PathBuf,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// The base scenario file is not TOML.
    BaseFile {
        /// The file.
        path: PathBuf,
        /// Why.
        source: toml::de::Error,
    },
    /// `[scenario]` over the base is refused by the scenario checks.
    Scenario {
        /// The base.
        base: String,
        /// Why.
        error: ResolveError,
    },
    /// A `[[vary]]` entry is wrong.
    Vary {
        /// Its place in the file.
        index: usize,
        /// Its key.
        key: String,
        /// What is wrong.
        error: VaryError,
    },
    /// The grids times the samples give too many flights.
    TooManyFlights {
        /// The most allowed.
        max: u64,
    },
}

/// What is wrong with `--shard I/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardProblem {
    /// No `/`.
    NoSlash,
    /// `I` is not a whole number.
    IndexNotWhole,
    /// `N` is not a whole number.
    CountNotWhole,
    /// `N` is 0.
    NoShards,
    /// `I` is not below `N`.
    IndexTooLarge {
        /// `N`.
        count: u64,
    },
}

/// Why shard reports cannot be merged.
#[derive(Debug)]
pub enum MergeProblem {
    /// No report given.
    Nothing,
    /// Reports of different campaign files (or versions of one).
    Campaigns {
        /// The report that differs.
        name: String,
        /// Its campaign and fingerprint.
        campaign: (String, String),
        /// The first report.
        first_name: String,
        /// Its campaign and fingerprint.
        first: (String, String),
    },
    /// Reports flown by different software.
    Software {
        /// The report that differs, and its software.
        name: (String, String),
        /// The first report, and its software.
        first: (String, String),
    },
    /// Reports of campaigns of different sizes.
    Totals {
        /// The report that differs, and its flights in the campaign.
        name: (String, u64),
        /// The first report, and its flights in the campaign.
        first: (String, u64),
    },
    /// A flight beyond the campaign's flights.
    Beyond {
        /// The report.
        name: String,
        /// The flight.
        index: u64,
        /// The campaign's flights.
        total: u64,
    },
    /// A flight in two reports.
    Overlap {
        /// The flight.
        index: u64,
        /// The two reports.
        reports: (String, String),
    },
    /// Flights in no report.
    Missing {
        /// The flights missing.
        missing: Vec<u64>,
        /// The campaign's flights.
        total: u64,
        /// Which shards would hold them (text for the message, may be empty).
        shards: String,
    },
}

/// A flight of a campaign that could not be flown.
#[derive(Debug)]
pub enum FlightError {
    /// Its scenario file could not be written out.
    Write(toml::ser::Error),
    /// The scenario checks refuse its scenario.
    Scenario {
        /// The flight.
        index: u64,
        /// What it drew (`key = value`).
        drawn: Vec<String>,
        /// Why.
        error: ScenarioError,
    },
    /// The simulation refused it.
    Simulation {
        /// The flight.
        index: u64,
        /// Why.
        error: ScenarioError,
    },
}

impl fmt::Display for CampaignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CampaignError::Read { file, source } => {
                write!(f, "{file}: cannot read the campaign file: {source}")
            }
            CampaignError::File { file, problem } => write!(f, "{file}: {problem}"),
            CampaignError::NoSuchFlight { file, index, total } => write!(
                f,
                "{file}: flight {index} does not exist: the campaign has {total} flights (0 to {})",
                total.saturating_sub(1)
            ),
            CampaignError::Draw {
                file,
                index,
                key,
                error,
            } => write!(f, "{file}: flight {index}: key {key}: {error}"),
            CampaignError::Shard { given, problem } => write!(
                f,
                "--shard {given}: {problem} (write I/N, 0 <= I < N: I is 0-based, as $SLURM_ARRAY_TASK_ID and $JOB_COMPLETION_INDEX are)"
            ),
            CampaignError::NoJobs => f.write_str("--jobs must be at least 1"),
            CampaignError::Workers(e) => write!(f, "cannot start the worker threads: {e}"),
            CampaignError::Merge(problem) => problem.fmt(f),
            CampaignError::SuiteDirectory { dir, source } => {
                write!(f, "reading {}: {source}", dir.display())
            }
            CampaignError::EmptySuite(dir) => {
                write!(f, "no campaign files (*.toml) in {}", dir.display())
            }
        }
    }
}

impl fmt::Display for FileProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FileProblem::Toml(e) => e.fmt(f),
            FileProblem::NoName => f.write_str("name = \"\": give the campaign a name"),
            FileProblem::Samples { samples, max } => {
                write!(f, "samples = {samples}: must be from 1 to {max}")
            }
            FileProblem::Reserved { key, why } => {
                write!(f, "scenario.{key} cannot be set here: {why}")
            }
            FileProblem::BaseNotFound { base, path, source } => write!(
                f,
                "base = \"{base}\": neither a built-in scenario (heli sim --list) nor a readable scenario file ({}: {source})",
                path.display()
            ),
            FileProblem::BaseFile { path, source } => {
                write!(f, "base scenario file {}: {source}", path.display())
            }
            FileProblem::Scenario { base, error } => write!(
                f,
                "[scenario] over base \"{base}\" is not a valid scenario: {error}"
            ),
            FileProblem::Vary { index, key, error } => {
                write!(f, "vary[{index}] (key = \"{key}\"): {error}")
            }
            FileProblem::TooManyFlights { max } => {
                write!(f, "grids × samples give more than {max} flights")
            }
        }
    }
}

impl fmt::Display for ShardProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShardProblem::NoSlash => f.write_str("no '/'"),
            ShardProblem::IndexNotWhole => f.write_str("I is not a whole number"),
            ShardProblem::CountNotWhole => f.write_str("N is not a whole number"),
            ShardProblem::NoShards => f.write_str("N must be at least 1"),
            ShardProblem::IndexTooLarge { count } => {
                write!(f, "I must be from 0 to {}", count.saturating_sub(1))
            }
        }
    }
}

impl fmt::Display for MergeProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MergeProblem::Nothing => f.write_str("merge needs at least one report"),
            MergeProblem::Campaigns {
                name,
                campaign,
                first_name,
                first,
            } => write!(
                f,
                "{name}: campaign \"{}\" (fingerprint {}) is not {first_name}'s \"{}\" ({}): reports of different campaign files, or of two versions of one, cannot be merged",
                campaign.0, campaign.1, first.0, first.1
            ),
            MergeProblem::Software { name, first } => write!(
                f,
                "{} was flown by {}, {} by {}: shards must be flown by the same software",
                name.0, name.1, first.0, first.1
            ),
            MergeProblem::Totals { name, first } => write!(
                f,
                "{}: {} flights in the campaign, {}: {}",
                name.0, name.1, first.0, first.1
            ),
            MergeProblem::Beyond { name, index, total } => write!(
                f,
                "{name}: flight {index} is beyond the campaign's {total} flights"
            ),
            MergeProblem::Overlap { index, reports } => write!(
                f,
                "flight {index} is in both {} and {}: the shards overlap",
                reports.0, reports.1
            ),
            MergeProblem::Missing {
                missing,
                total,
                shards,
            } => {
                let listed: Vec<String> = missing.iter().take(10).map(u64::to_string).collect();
                let more = if missing.len() > 10 {
                    format!(" and {} more", missing.len() - 10)
                } else {
                    String::new()
                };
                write!(
                    f,
                    "{} of {total} flights are in no report (flights {}{more}){shards}",
                    missing.len(),
                    listed.join(", ")
                )
            }
        }
    }
}

impl fmt::Display for FlightError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlightError::Write(e) => e.fmt(f),
            FlightError::Scenario {
                index,
                drawn,
                error,
            } => write!(
                f,
                "flight {index} ({}): {error}",
                if drawn.is_empty() {
                    "nothing varied".to_string()
                } else {
                    drawn.join(", ")
                }
            ),
            FlightError::Simulation { index, error } => {
                write!(f, "flight {index}: the simulation refused it: {error}")
            }
        }
    }
}

impl std::error::Error for CampaignError {}
impl std::error::Error for FlightError {}
