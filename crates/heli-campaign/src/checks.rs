//! The checks of a `[[vary]]` entry: its numbers, its key, and the scenarios its ends give.

use std::fmt;

use toml::{Table, Value};

use super::keys::{self, Segment};
use super::vary::ResolveError;
use super::vary::{Draw, MAX_LIST, Target, Vary, VaryToml, edits, resolve};
use heli_scenario::validate::MAX_DURATION_S;

/// What is wrong with a `[[vary]]` entry.
#[derive(Debug)]
pub enum VaryError {
    /// A number that is not finite.
    NotFinite {
        /// Which (`uniform min`, `grid[2]`).
        name: String,
        /// The value.
        x: f64,
    },
    /// None, or more than one, of the draws.
    OneDraw,
    /// `uniform` is not `[min, max]`.
    UniformLength(usize),
    /// `uniform`'s min is not below its max.
    UniformOrder {
        /// Its min.
        min: f64,
        /// Its max.
        max: f64,
    },
    /// `normal.sigma` is not above 0.
    Sigma(f64),
    /// `normal`'s bounds are not ordered around its mean.
    NormalBounds {
        /// Its mean.
        mean: f64,
        /// Its min (or -inf).
        lo: f64,
        /// Its max (or +inf).
        hi: f64,
    },
    /// A list with no values, or too many.
    ListLength {
        /// `grid` or `choice`.
        what: &'static str,
        /// Its values.
        len: usize,
    },
    /// A list value that is a table, list or date.
    ListValue {
        /// `grid` or `choice`.
        what: &'static str,
        /// Its place.
        index: usize,
        /// The value.
        value: Value,
    },
    /// `length_s` is out of range.
    Length(f64),
    /// The key does not lead to a value.
    Key(super::keys::KeyError),
    /// `base` or `name` varied.
    Reserved,
    /// A number drawn for a value that is not a number.
    NotANumber(String),
    /// A value listed that is not a number, for a number.
    ListNotNumbers(String),
    /// `length_s` without a window to move.
    NoWindow,
    /// The key points at a list.
    AList,
    /// The key points at a table.
    ATable,
    /// The same key varied twice.
    Twice,
    /// An end of the draw gives a scenario the checks refuse.
    EndRefused {
        /// Which end.
        which: String,
        /// Its value.
        value: Value,
        /// Why.
        error: ResolveError,
    },
}

impl fmt::Display for VaryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VaryError::NotFinite { name, x } => write!(f, "{name} = {x}: must be a finite number"),
            VaryError::OneDraw => f.write_str("give exactly one of uniform, normal, grid or choice"),
            VaryError::UniformLength(n) => {
                write!(f, "uniform has {n} numbers: write uniform = [min, max]")
            }
            VaryError::UniformOrder { min, max } => write!(
                f,
                "uniform = [{min}, {max}]: must be [min, max] with min < max"
            ),
            VaryError::Sigma(sigma) => write!(f, "normal.sigma = {sigma}: must be more than 0"),
            VaryError::NormalBounds { mean, lo, hi } => write!(
                f,
                "normal = {{ mean = {mean}, min = {lo}, max = {hi} }}: must have min < max and the mean from min to max"
            ),
            VaryError::ListLength { what, len } => write!(
                f,
                "{what} has {len} values: must have from 1 to {MAX_LIST}"
            ),
            VaryError::ListValue { what, index, value } => write!(
                f,
                "{what}[{index}] = {value}: values are numbers, text or booleans"
            ),
            VaryError::Length(len) => write!(
                f,
                "length_s = {len}: must be from more than 0 to {MAX_DURATION_S} s"
            ),
            VaryError::Key(e) => e.fmt(f),
            VaryError::Reserved => f.write_str("base and name are the campaign's, not varied"),
            VaryError::NotANumber(key) => write!(
                f,
                "the scenario's {key} is not a number: only grid or choice can vary it"
            ),
            VaryError::ListNotNumbers(key) => write!(
                f,
                "the scenario's {key} is a number: every value listed must be a number"
            ),
            VaryError::NoWindow => f.write_str(
                "length_s needs a window: a [start, end] pair (faults.gps_outages.0) or a start_s with an end_s beside it",
            ),
            VaryError::AList => f.write_str(
                "is a list: vary one of its entries (e.g. .0), or give length_s for a [start, end] window",
            ),
            VaryError::ATable => f.write_str("is a table: vary one of its fields"),
            VaryError::Twice => f.write_str("this key is varied twice"),
            VaryError::EndRefused {
                which,
                value,
                error,
            } => write!(
                f,
                "{which} = {value} gives a scenario the checks refuse: {error}"
            ),
        }
    }
}

impl std::error::Error for VaryError {}

impl From<super::keys::KeyError> for VaryError {
    fn from(e: super::keys::KeyError) -> Self {
        VaryError::Key(e)
    }
}

fn finite(name: &str, x: f64) -> Result<f64, VaryError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(VaryError::NotFinite {
            name: name.to_string(),
            x,
        })
    }
}

pub(crate) fn check_vary(v: VaryToml, resolved: &Table) -> Result<Vary, VaryError> {
    let given = [
        v.uniform.is_some(),
        v.normal.is_some(),
        v.grid.is_some(),
        v.choice.is_some(),
    ];
    if given.iter().filter(|g| **g).count() != 1 {
        return Err(VaryError::OneDraw);
    }
    let draw = if let Some(u) = v.uniform {
        let [min, max] = u[..] else {
            return Err(VaryError::UniformLength(u.len()));
        };
        finite("uniform min", min)?;
        finite("uniform max", max)?;
        if min >= max {
            return Err(VaryError::UniformOrder { min, max });
        }
        Draw::Uniform { min, max }
    } else if let Some(n) = v.normal {
        finite("normal.mean", n.mean)?;
        finite("normal.sigma", n.sigma)?;
        if n.sigma <= 0.0 {
            return Err(VaryError::Sigma(n.sigma));
        }
        if let Some(min) = n.min {
            finite("normal.min", min)?;
        }
        if let Some(max) = n.max {
            finite("normal.max", max)?;
        }
        let (lo, hi) = (
            n.min.unwrap_or(f64::NEG_INFINITY),
            n.max.unwrap_or(f64::INFINITY),
        );
        if !(lo <= n.mean && n.mean <= hi && lo < hi) {
            return Err(VaryError::NormalBounds {
                mean: n.mean,
                lo,
                hi,
            });
        }
        Draw::Normal {
            mean: n.mean,
            sigma: n.sigma,
            min: n.min,
            max: n.max,
        }
    } else if let Some(values) = v.grid {
        check_list("grid", &values)?;
        Draw::Grid(values)
    } else {
        let values = v.choice.unwrap_or_default();
        check_list("choice", &values)?;
        Draw::Choice(values)
    };
    if let Some(len) = v.length_s
        && !(len.is_finite() && len > 0.0 && len <= MAX_DURATION_S)
    {
        return Err(VaryError::Length(len));
    }
    let path = keys::parse(&v.key)?;
    if matches!(path.first(), Some(Segment::Field(f)) if f == "base" || f == "name") {
        return Err(VaryError::Reserved);
    }
    let target = target_of(&path, resolved, v.length_s.is_some())?;
    let numeric_draw = matches!(draw, Draw::Uniform { .. } | Draw::Normal { .. });
    let list_all_numbers = match &draw {
        Draw::Grid(values) | Draw::Choice(values) => values
            .iter()
            .all(|x| matches!(x, Value::Integer(_) | Value::Float(_))),
        _ => true,
    };
    if target == Target::Other && numeric_draw {
        return Err(VaryError::NotANumber(v.key));
    }
    if matches!(
        target,
        Target::Window | Target::StartEnd | Target::Number { .. }
    ) && !list_all_numbers
    {
        return Err(VaryError::ListNotNumbers(v.key));
    }
    Ok(Vary {
        key: v.key,
        draw,
        length_s: v.length_s,
        path,
        target,
    })
}

fn check_list(what: &'static str, values: &[Value]) -> Result<(), VaryError> {
    if values.is_empty() || values.len() > MAX_LIST {
        return Err(VaryError::ListLength {
            what,
            len: values.len(),
        });
    }
    for (i, x) in values.iter().enumerate() {
        match x {
            Value::Float(f) if !f.is_finite() => {
                return Err(VaryError::NotFinite {
                    name: format!("{what}[{i}]"),
                    x: *f,
                });
            }
            Value::Table(_) | Value::Array(_) | Value::Datetime(_) => {
                return Err(VaryError::ListValue {
                    what,
                    index: i,
                    value: x.clone(),
                });
            }
            _ => {}
        }
    }
    Ok(())
}

/// What the key points at, checked against what the draw can write there.
fn target_of(path: &[Segment], resolved: &Table, window: bool) -> Result<Target, VaryError> {
    let value = keys::get(resolved, path)?;
    let is_number = |v: &Value| matches!(v, Value::Integer(_) | Value::Float(_));
    if window {
        if let Value::Array(pair) = value
            && pair.len() == 2
            && pair.iter().all(is_number)
        {
            return Ok(Target::Window);
        }
        if let (Some(Segment::Field(last)), Some(parent)) = (path.last(), path.len().checked_sub(1))
            && last == "start_s"
        {
            let mut end = path[..parent].to_vec();
            end.push(Segment::Field("end_s".into()));
            if keys::get(resolved, &end).is_ok_and(is_number) {
                return Ok(Target::StartEnd);
            }
        }
        return Err(VaryError::NoWindow);
    }
    match value {
        Value::Integer(_) => Ok(Target::Number { integer: true }),
        Value::Float(_) => Ok(Target::Number { integer: false }),
        Value::String(_) | Value::Boolean(_) => Ok(Target::Other),
        Value::Array(_) => Err(VaryError::AList),
        _ => Err(VaryError::ATable),
    }
}

/// The values a draw can reach at its ends (every value of a list): each must give a valid
/// scenario on its own, so a range the scenario refuses is found now, not in flight 731.
pub(crate) fn check_ends(v: &Vary, start: &Table, resolved: &Table) -> Result<(), VaryError> {
    const REACH_SIGMAS: f64 = 4.0;
    let ends: Vec<(String, Value)> = match &v.draw {
        Draw::Uniform { min, max } => vec![
            ("uniform min".into(), Value::Float(*min)),
            // Draws are below max; the check takes max itself, the tightest simple bound.
            ("uniform max".into(), Value::Float(*max)),
        ],
        Draw::Normal {
            mean,
            sigma,
            min,
            max,
        } => {
            let lo = min.unwrap_or(mean - REACH_SIGMAS * sigma);
            let hi = max.unwrap_or(mean + REACH_SIGMAS * sigma);
            let name = |bound: &Option<f64>, side: &str| match bound {
                Some(_) => format!("normal {side}"),
                None => format!(
                    "normal mean {} {REACH_SIGMAS} sigma (give normal.{side} to bound it)",
                    if side == "min" { "-" } else { "+" }
                ),
            };
            vec![
                (name(min, "min"), Value::Float(lo)),
                (name(max, "max"), Value::Float(hi)),
            ]
        }
        Draw::Grid(values) | Draw::Choice(values) => values
            .iter()
            .enumerate()
            .map(|(i, x)| (format!("value {i}"), x.clone()))
            .collect(),
    };
    for (which, value) in ends {
        let mut file = start.clone();
        for (path, x) in edits(v, &value) {
            keys::set(&mut file, resolved, &path, x)?;
        }
        if let Err(error) = resolve(&file) {
            return Err(VaryError::EndRefused {
                which,
                value,
                error,
            });
        }
    }
    Ok(())
}
