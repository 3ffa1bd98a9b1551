//! What a campaign varies: each `[[vary]]` key as written and as checked, how its value is
//! drawn, what it points at in the scenario, and how a value edits the scenario.

use serde::Deserialize;
use toml::{Table, Value};

use super::keys::Segment;
use heli_scenario as scenario;

/// Most values one grid or choice may list.
pub const MAX_LIST: usize = 10_000;

/// One `[[vary]]` entry as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct VaryToml {
    pub(crate) key: String,
    pub(crate) uniform: Option<Vec<f64>>,
    pub(crate) normal: Option<NormalToml>,
    pub(crate) grid: Option<Vec<Value>>,
    pub(crate) choice: Option<Vec<Value>>,
    pub(crate) length_s: Option<f64>,
}

/// A `normal = { ... }` as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct NormalToml {
    pub(crate) mean: f64,
    pub(crate) sigma: f64,
    pub(crate) min: Option<f64>,
    pub(crate) max: Option<f64>,
}

/// How a varied value is chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Draw {
    /// Uniformly from `[min, max)`.
    Uniform {
        /// Least value.
        min: f64,
        /// Greatest value (not drawn).
        max: f64,
    },
    /// Normally, truncated to `[min, max]` (drawn again until inside; clamped after 1000
    /// tries).
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation (> 0).
        sigma: f64,
        /// Least value, if bounded below.
        min: Option<f64>,
        /// Greatest value, if bounded above.
        max: Option<f64>,
    },
    /// Each value in turn: the campaign flies the cartesian product of its grids, `samples`
    /// flights at each grid point.
    Grid(Vec<Value>),
    /// One of the values, each as likely, drawn for every flight.
    Choice(Vec<Value>),
}

/// What a varied key points at in the scenario.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    /// A number; `integer` ones get draws rounded to the nearest integer.
    Number {
        /// The scenario holds an integer there.
        integer: bool,
    },
    /// Text or a boolean: only grids and choices vary it.
    Other,
    /// A `[start, end]` window: the value is the start, the end `length_s` later.
    Window,
    /// A `start_s` with an `end_s` beside it: `end_s` is set `length_s` later.
    StartEnd,
}

/// One varied key.
#[derive(Clone, Debug, PartialEq)]
pub struct Vary {
    /// The key as written (`wind_ned_mps.0`).
    pub key: String,
    /// How its value is chosen.
    pub draw: Draw,
    /// For a window: its length (s); the drawn value is its start.
    pub length_s: Option<f64>,
    pub(crate) path: Vec<Segment>,
    pub(crate) target: Target,
}

/// What writing `value` for `v` changes in the scenario file: the key itself, and for a
/// window its end (`length_s` after the value).
pub(crate) fn edits(v: &Vary, value: &Value) -> Vec<(Vec<Segment>, Value)> {
    let number = match value {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    };
    let length = v.length_s.unwrap_or(0.0);
    match (v.target, number) {
        (Target::Window, Some(start)) => vec![(
            v.path.clone(),
            Value::Array(vec![Value::Float(start), Value::Float(start + length)]),
        )],
        (Target::StartEnd, Some(start)) => {
            let mut end = v.path.clone();
            end.pop();
            end.push(Segment::Field("end_s".into()));
            vec![
                (v.path.clone(), Value::Float(start)),
                (end, Value::Float(start + length)),
            ]
        }
        (Target::Number { integer: true }, Some(x)) => {
            let whole = match value {
                Value::Integer(i) => Value::Integer(*i),
                // Rounded (and held within an i64, which the scenario's checks then judge).
                _ => Value::Integer(x.round() as i64),
            };
            vec![(v.path.clone(), whole)]
        }
        (Target::Number { integer: false }, Some(x)) => vec![(v.path.clone(), Value::Float(x))],
        _ => vec![(v.path.clone(), value.clone())],
    }
}

/// A sparse scenario file resolved through the scenario checks, as a full table.
pub(crate) fn resolve(file: &Table) -> Result<Table, ResolveError> {
    let text = toml::to_string(file).map_err(ResolveError::Write)?;
    let s = scenario::from_toml(&text).map_err(ResolveError::Refused)?;
    Table::try_from(&s).map_err(ResolveError::Write)
}

/// A sparse scenario file that does not resolve to a scenario.
#[derive(Debug)]
pub enum ResolveError {
    /// It could not be written out as TOML.
    Write(toml::ser::Error),
    /// The scenario checks refuse it.
    Refused(heli_scenario::ScenarioError),
}

impl std::fmt::Display for ResolveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ResolveError::Write(e) => e.fmt(f),
            ResolveError::Refused(e) => f.write_str(e.to_string().trim_end()),
        }
    }
}

impl std::error::Error for ResolveError {}
