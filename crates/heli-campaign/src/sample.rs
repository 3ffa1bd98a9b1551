//! Flight `i` of a campaign: its grid point, its draws and its scenario, a pure function of
//! the campaign file and `i`.
//!
//! Flight `i` is at grid point `i / samples` (the last grid in the file varies fastest).
//! Its random numbers come from ChaCha8 seeded with the campaign's seed, on stream `i`:
//! first the flight's scenario seed, then one draw per non-grid `[[vary]]` entry in file
//! order. No flight's draws depend on another's, so a shard (`--shard I/N`) and a whole run
//! fly the very same flights, and adding a `[[vary]]` entry at the end changes no seed.

use std::collections::BTreeMap;

use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use toml::{Table, Value};

use super::CampaignError;
use super::file::Campaign;
use super::keys::{self, Segment};
use super::vary::{Draw, Target, edits};
use crate::error::FlightError;
use heli_scenario::{self as scenario, Scenario};

/// Draws from a truncated normal before it is clamped instead.
const NORMAL_TRIES: usize = 1000;

/// One flight of a campaign, drawn but not flown.
#[derive(Clone, Debug, PartialEq)]
pub struct Flight {
    /// Its index in the campaign (0-based).
    pub index: u64,
    /// Its scenario's seed (drawn, or the varied `seed`).
    pub seed: u64,
    /// The value each varied key got (for a window: its start).
    pub values: BTreeMap<String, serde_json::Value>,
    /// Its scenario file: the campaign's base and `[scenario]`, with the values written in.
    pub file: Table,
}

impl Campaign {
    /// Flight `index`: its values and its scenario file.
    pub fn flight(&self, index: u64) -> Result<Flight, CampaignError> {
        let total = self.flights_total();
        if index >= total {
            return Err(CampaignError::NoSuchFlight {
                file: self.file.clone(),
                index,
                total,
            });
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(index);
        // A TOML integer is an i64: seeds stay below 2^63 so that the file can hold them.
        let mut seed = rng.next_u64() >> 1;
        let mut grid_index = self.grid_indexes(index / self.samples);
        let mut file = self.scenario.clone();
        let mut values = BTreeMap::new();
        for v in &self.vary {
            let value = match &v.draw {
                Draw::Grid(list) => {
                    let i = grid_index.next().unwrap_or(0);
                    list.get(i).cloned().unwrap_or(Value::Integer(0))
                }
                Draw::Choice(list) => {
                    let i = rng.random_range(0..list.len() as u64) as usize;
                    list.get(i).cloned().unwrap_or(Value::Integer(0))
                }
                Draw::Uniform { min, max } => Value::Float(min + (max - min) * rng.random::<f64>()),
                Draw::Normal {
                    mean,
                    sigma,
                    min,
                    max,
                } => Value::Float(normal(&mut rng, *mean, *sigma, *min, *max)),
            };
            let mut recorded = None;
            for (path, x) in edits(v, &value) {
                recorded.get_or_insert_with(|| x.clone());
                keys::set(&mut file, &self.resolved, &path, x).map_err(|error| {
                    CampaignError::Draw {
                        file: self.file.clone(),
                        index,
                        key: v.key.clone(),
                        error: Box::new(error),
                    }
                })?;
            }
            let recorded = match (v.target, recorded) {
                (Target::Window, Some(Value::Array(pair))) => pair.first().cloned(),
                (_, r) => r,
            };
            if v.path == [Segment::Field("seed".into())]
                && let Some(Value::Integer(s)) = &recorded
            {
                seed = u64::try_from(*s).unwrap_or(0);
            }
            values.insert(
                v.key.clone(),
                recorded
                    .and_then(|r| serde_json::to_value(r).ok())
                    .unwrap_or(serde_json::Value::Null),
            );
        }
        file.insert(
            "name".into(),
            Value::String(format!("{}-{index}", self.name)),
        );
        file.insert("seed".into(), Value::Integer(seed as i64));
        Ok(Flight {
            index,
            seed,
            values,
            file,
        })
    }

    /// The index into each grid (in file order) of grid point `point`; the last grid
    /// varies fastest.
    fn grid_indexes(&self, mut point: u64) -> std::vec::IntoIter<usize> {
        let mut indexes: Vec<usize> = Vec::new();
        for v in self.vary.iter().rev() {
            if let Draw::Grid(list) = &v.draw {
                let n = list.len().max(1) as u64;
                indexes.push((point % n) as usize);
                point /= n;
            }
        }
        indexes.reverse();
        indexes.into_iter()
    }
}

impl Flight {
    /// The flight's scenario, through the same loading and checks as a scenario file; the
    /// error says which values it drew.
    pub fn scenario(&self) -> Result<Scenario, FlightError> {
        let text = toml::to_string(&self.file).map_err(FlightError::Write)?;
        scenario::from_toml(&text).map_err(|error| FlightError::Scenario {
            index: self.index,
            drawn: self
                .values
                .iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect(),
            error,
        })
    }

    /// The flight's whole scenario as a scenario file that `heli sim --scenario` flies:
    /// every field written out, over `base` (the built-in at the root of the campaign's
    /// base; listing every field leaves nothing of it but the fields no file can unset).
    pub fn scenario_file_text(&self, base: &str, header: &str) -> Result<String, FlightError> {
        let s = self.scenario()?;
        let mut table = Table::try_from(&s).map_err(FlightError::Write)?;
        // A limit the base judges and this scenario does not is written "unset" (an absent
        // one would be the base's again).
        if let Some(base_scenario) = scenario::builtin(base) {
            let limits = table
                .entry("limits")
                .or_insert_with(|| Value::Table(Table::new()));
            if let (Value::Table(limits), Ok(Value::Table(base_limits))) =
                (limits, Value::try_from(base_scenario.limits))
            {
                for key in base_limits.keys() {
                    if !limits.contains_key(key) {
                        limits.insert(key.clone(), Value::String("unset".into()));
                    }
                }
            }
        }
        let body = toml::to_string(&table).map_err(FlightError::Write)?;
        let base = Value::String(base.to_string());
        Ok(format!("{header}base = {base}\n{body}"))
    }
}

/// A normal draw truncated to `[min, max]`.
fn normal(rng: &mut ChaCha8Rng, mean: f64, sigma: f64, min: Option<f64>, max: Option<f64>) -> f64 {
    let lo = min.unwrap_or(f64::NEG_INFINITY);
    let hi = max.unwrap_or(f64::INFINITY);
    let mut x = mean;
    for _ in 0..NORMAL_TRIES {
        let z: f64 = StandardNormal.sample(rng);
        x = mean + sigma * z;
        if (lo..=hi).contains(&x) {
            return x;
        }
    }
    x.clamp(lo, hi)
}
