//! The checks of a `[[vary]]` entry: its numbers, its key, and the scenarios its ends give.

use toml::{Table, Value};

use super::keys::{self, Segment};
use super::vary::{Draw, MAX_LIST, Target, Vary, VaryToml, edits, resolve};
use heli_scenario::validate::MAX_DURATION_S;

fn finite(name: &str, x: f64) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{name} = {x}: must be a finite number"))
    }
}

pub(crate) fn check_vary(v: VaryToml, resolved: &Table) -> Result<Vary, String> {
    let given = [
        v.uniform.is_some(),
        v.normal.is_some(),
        v.grid.is_some(),
        v.choice.is_some(),
    ];
    if given.iter().filter(|g| **g).count() != 1 {
        return Err("give exactly one of uniform, normal, grid or choice".into());
    }
    let draw = if let Some(u) = v.uniform {
        let [min, max] = u[..] else {
            return Err(format!(
                "uniform has {} numbers: write uniform = [min, max]",
                u.len()
            ));
        };
        finite("uniform min", min)?;
        finite("uniform max", max)?;
        if min >= max {
            return Err(format!(
                "uniform = [{min}, {max}]: must be [min, max] with min < max"
            ));
        }
        Draw::Uniform { min, max }
    } else if let Some(n) = v.normal {
        finite("normal.mean", n.mean)?;
        finite("normal.sigma", n.sigma)?;
        if n.sigma <= 0.0 {
            return Err(format!("normal.sigma = {}: must be more than 0", n.sigma));
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
            return Err(format!(
                "normal = {{ mean = {}, min = {lo}, max = {hi} }}: must have min < max and the mean from min to max",
                n.mean
            ));
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
        return Err(format!(
            "length_s = {len}: must be from more than 0 to {MAX_DURATION_S} s"
        ));
    }
    let path = keys::parse(&v.key)?;
    if matches!(path.first(), Some(Segment::Field(f)) if f == "base" || f == "name") {
        return Err("base and name are the campaign's, not varied".into());
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
        return Err(format!(
            "the scenario's {} is not a number: only grid or choice can vary it",
            v.key
        ));
    }
    if matches!(
        target,
        Target::Window | Target::StartEnd | Target::Number { .. }
    ) && !list_all_numbers
    {
        return Err(format!(
            "the scenario's {} is a number: every value listed must be a number",
            v.key
        ));
    }
    Ok(Vary {
        key: v.key,
        draw,
        length_s: v.length_s,
        path,
        target,
    })
}

fn check_list(what: &str, values: &[Value]) -> Result<(), String> {
    if values.is_empty() || values.len() > MAX_LIST {
        return Err(format!(
            "{what} has {} values: must have from 1 to {MAX_LIST}",
            values.len()
        ));
    }
    for (i, x) in values.iter().enumerate() {
        match x {
            Value::Float(f) if !f.is_finite() => {
                return Err(format!("{what}[{i}] = {f}: must be a finite number"));
            }
            Value::Table(_) | Value::Array(_) | Value::Datetime(_) => {
                return Err(format!(
                    "{what}[{i}] = {x}: values are numbers, text or booleans"
                ));
            }
            _ => {}
        }
    }
    Ok(())
}

/// What the key points at, checked against what the draw can write there.
fn target_of(path: &[Segment], resolved: &Table, window: bool) -> Result<Target, String> {
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
        return Err(
            "length_s needs a window: a [start, end] pair (faults.gps_outages.0) or a start_s with an end_s beside it"
                .into(),
        );
    }
    match value {
        Value::Integer(_) => Ok(Target::Number { integer: true }),
        Value::Float(_) => Ok(Target::Number { integer: false }),
        Value::String(_) | Value::Boolean(_) => Ok(Target::Other),
        Value::Array(_) => Err(
            "is a list: vary one of its entries (e.g. .0), or give length_s for a [start, end] window"
                .into(),
        ),
        _ => Err("is a table: vary one of its fields".into()),
    }
}

/// The values a draw can reach at its ends (every value of a list): each must give a valid
/// scenario on its own, so a range the scenario refuses is found now, not in flight 731.
pub(crate) fn check_ends(v: &Vary, start: &Table, resolved: &Table) -> Result<(), String> {
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
        resolve(&file)
            .map_err(|e| format!("{which} = {value} gives a scenario the checks refuse: {e}"))?;
    }
    Ok(())
}
