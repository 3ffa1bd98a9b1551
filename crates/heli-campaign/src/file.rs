//! The campaign file (TOML, docs/campaigns.md), checked when it is loaded.
//!
//! ```toml
//! name = "hover-wind"
//! base = "hover"                 # built-in scenario, or a scenario file beside this one
//! seed = 1                       # drives the draws and each flight's scenario seed
//! samples = 20                   # draws per grid point
//! [scenario]                     # overrides of the base, as in a scenario file
//! duration_s = 150.0
//! [[vary]]
//! key = "wind_ned_mps.0"
//! uniform = [0.0, 8.0]
//! ```
//!
//! Every error names the file, the `[[vary]]` entry and its key, and the allowed range.

use std::path::Path;

use serde::Deserialize;
use toml::{Table, Value};

use super::checks::{check_ends, check_vary};
use super::fingerprint;
use super::keys;
use super::vary::{Draw, Vary, VaryToml, resolve};
use crate::checks::VaryError;
use crate::error::{CampaignError, FileProblem};
use heli_scenario as scenario;

/// Most flights one campaign may have (grid points × samples).
pub const MAX_FLIGHTS: u64 = 100_000_000;

/// The file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default = "default_base")]
    base: String,
    #[serde(default = "one")]
    seed: u64,
    #[serde(default = "one")]
    samples: u64,
    #[serde(default)]
    scenario: Table,
    #[serde(default)]
    vary: Vec<VaryToml>,
}

fn default_base() -> String {
    "hover".into()
}

fn one() -> u64 {
    1
}

/// A loaded, checked campaign.
#[derive(Clone, Debug)]
pub struct Campaign {
    /// Its name (also the name of each flight's scenario: `NAME-INDEX`).
    pub name: String,
    /// One line on what it explores.
    pub description: String,
    /// The file it was loaded from, as given (used in reproduce commands).
    pub file: String,
    /// The base scenario: a built-in name or a file path (relative to the campaign file).
    pub base: String,
    /// The campaign's seed: drives every draw.
    pub seed: u64,
    /// Flights per grid point.
    pub samples: u64,
    /// The varied keys, in file order.
    pub vary: Vec<Vary>,
    /// Hash of the file's text (and the base scenario file's, if any), in hex.
    pub fingerprint: String,
    /// The scenario file each flight starts from: the base with `[scenario]` merged in.
    pub(crate) scenario: Table,
    /// The same scenario resolved, every field present (where keys are looked up).
    pub(crate) resolved: Table,
}

impl Campaign {
    /// Reads and checks the campaign file at `path`.
    pub fn load(path: &Path) -> Result<Self, CampaignError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CampaignError::Read {
            file: file.clone(),
            source,
        })?;
        let dir = path.parent().unwrap_or_else(|| Path::new("."));
        Self::from_toml(&text, &file, dir)
    }

    /// Checks a campaign file's `text`; `file` names it in errors and reproduce commands,
    /// `dir` is where a base scenario file is looked for.
    pub fn from_toml(text: &str, file: &str, dir: &Path) -> Result<Self, CampaignError> {
        let err = |problem: FileProblem| CampaignError::File {
            file: file.to_string(),
            problem: Box::new(problem),
        };
        let raw: FileToml = toml::from_str(text).map_err(|e| err(FileProblem::Toml(e)))?;
        if raw.name.trim().is_empty() {
            return Err(err(FileProblem::NoName));
        }
        if !(1..=MAX_FLIGHTS).contains(&raw.samples) {
            return Err(err(FileProblem::Samples {
                samples: raw.samples,
                max: MAX_FLIGHTS,
            }));
        }
        for (key, why) in [
            ("base", "set base at the top of the campaign file"),
            (
                "seed",
                "each flight's seed is drawn from the campaign's seed; to choose it, vary it (key = \"seed\")",
            ),
            (
                "name",
                "each flight is named after the campaign (NAME-INDEX)",
            ),
        ] {
            if raw.scenario.contains_key(key) {
                return Err(err(FileProblem::Reserved { key, why }));
            }
        }
        let (mut start, base_text) = base_file(&raw.base, dir).map_err(err)?;
        keys::merge(&mut start, &raw.scenario);
        let resolved = resolve(&start).map_err(|error| {
            err(FileProblem::Scenario {
                base: raw.base.clone(),
                error,
            })
        })?;
        let mut vary: Vec<Vary> = Vec::with_capacity(raw.vary.len());
        for (k, v) in raw.vary.into_iter().enumerate() {
            let key = v.key.clone();
            let vary_err = |error: VaryError| {
                err(FileProblem::Vary {
                    index: k,
                    key: key.clone(),
                    error,
                })
            };
            let checked = check_vary(v, &resolved).map_err(vary_err)?;
            if vary.iter().any(|other| other.path == checked.path) {
                return Err(vary_err(VaryError::Twice));
            }
            check_ends(&checked, &start, &resolved).map_err(vary_err)?;
            vary.push(checked);
        }
        let mut flights: u64 = raw.samples;
        for v in &vary {
            if let Draw::Grid(values) = &v.draw {
                flights = flights
                    .checked_mul(values.len() as u64)
                    .filter(|n| *n <= MAX_FLIGHTS)
                    .ok_or_else(|| err(FileProblem::TooManyFlights { max: MAX_FLIGHTS }))?;
            }
        }
        let fingerprint = fingerprint(&[text.as_bytes(), base_text.as_bytes()]);
        Ok(Campaign {
            name: raw.name,
            description: raw.description,
            file: file.to_string(),
            base: raw.base,
            seed: raw.seed,
            samples: raw.samples,
            vary,
            fingerprint,
            scenario: start,
            resolved,
        })
    }

    /// Grid points: the product of the grids' lengths (1 without a grid).
    pub fn grid_points(&self) -> u64 {
        self.vary
            .iter()
            .map(|v| match &v.draw {
                Draw::Grid(values) => values.len() as u64,
                _ => 1,
            })
            .product()
    }

    /// Flights in the whole campaign: grid points × samples.
    pub fn flights_total(&self) -> u64 {
        self.grid_points() * self.samples
    }

    /// The built-in scenario at the root of the base (what `base = ...` in a flight's
    /// scenario file names).
    pub fn root_base(&self) -> String {
        match self.scenario.get("base") {
            Some(Value::String(s)) => s.clone(),
            _ => "hover".into(),
        }
    }
}

/// The base as a sparse scenario file, and the base file's text (empty for a built-in).
fn base_file(base: &str, dir: &Path) -> Result<(Table, String), FileProblem> {
    if scenario::builtin(base).is_some() {
        let mut t = Table::new();
        t.insert("base".into(), Value::String(base.into()));
        return Ok((t, String::new()));
    }
    let path = dir.join(base);
    let text = std::fs::read_to_string(&path).map_err(|source| FileProblem::BaseNotFound {
        base: base.to_string(),
        path: path.clone(),
        source,
    })?;
    let mut table: Table = text.parse().map_err(|source| FileProblem::BaseFile {
        path: path.clone(),
        source,
    })?;
    // Its name and seed are the campaign's to give.
    table.remove("name");
    table.remove("seed");
    Ok((table, text))
}
