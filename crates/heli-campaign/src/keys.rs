//! Dotted keys into a scenario's TOML (`airframe.mass_kg`, `wind_ned_mps.0`,
//! `plan.1.alt_m`, also written `wind_ned_mps[0]`): parsing, reading, and writing a value
//! into a sparse scenario file.

use toml::{Table, Value};

/// One step of a key: a table's field or a list's index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Segment {
    /// A field of a table.
    Field(String),
    /// An index into a list (0-based).
    Index(usize),
}

/// Parses `a.b.0` or `a.b[0]`; all-digit steps are indexes.
pub(crate) fn parse(key: &str) -> Result<Vec<Segment>, String> {
    let normalised = key.replace('[', ".").replace(']', "");
    let mut path = Vec::new();
    for step in normalised.split('.') {
        if step.is_empty() {
            return Err(format!(
                "key \"{key}\" has an empty step: write fields and indexes separated by dots, e.g. wind_ned_mps.0 or plan.1.alt_m"
            ));
        }
        if step.bytes().all(|b| b.is_ascii_digit()) {
            let i = step
                .parse()
                .map_err(|_| format!("key \"{key}\": index {step} is too large"))?;
            path.push(Segment::Index(i));
        } else {
            path.push(Segment::Field(step.to_string()));
        }
    }
    Ok(path)
}

/// The key's text for messages: `faults.gps_outages.0`.
pub(crate) fn show(path: &[Segment]) -> String {
    let steps: Vec<String> = path
        .iter()
        .map(|s| match s {
            Segment::Field(f) => f.clone(),
            Segment::Index(i) => i.to_string(),
        })
        .collect();
    steps.join(".")
}

/// The value at `path` in `table`, or why there is none (what the scenario has there
/// instead).
pub(crate) fn get<'a>(table: &'a Table, path: &[Segment]) -> Result<&'a Value, String> {
    let Some((Segment::Field(first), rest)) = path.split_first() else {
        return Err("a key starts with a field name, not an index".into());
    };
    let mut value = table.get(first).ok_or_else(|| {
        format!(
            "the scenario has no field \"{first}\" (it has: {})",
            names(table)
        )
    })?;
    for (depth, step) in rest.iter().enumerate() {
        let here = show(&path[..=depth]);
        value = match (value, step) {
            (Value::Table(t), Segment::Field(f)) => t
                .get(f)
                .ok_or_else(|| format!("{here} has no field \"{f}\" (it has: {})", names(t)))?,
            (Value::Array(a), Segment::Index(i)) => a.get(*i).ok_or_else(|| {
                format!(
                    "{here} has {} entries (indexes from 0); give it more in [scenario] first",
                    a.len()
                )
            })?,
            (Value::Table(_), Segment::Index(i)) => {
                return Err(format!(
                    "{here} is a table: name one of its fields, not {i}"
                ));
            }
            (Value::Array(_), Segment::Field(f)) => {
                return Err(format!("{here} is a list: give an index, not \"{f}\""));
            }
            (_, _) => return Err(format!("{here} is a single value: it has nothing inside")),
        };
    }
    Ok(value)
}

fn names(table: &Table) -> String {
    let names: Vec<&str> = table.keys().map(String::as_str).collect();
    if names.is_empty() {
        "nothing".into()
    } else {
        names.join(", ")
    }
}

/// Writes `value` at `path` into the sparse scenario file `sparse`, whose resolved form
/// (every field, after its base) is `full`. Tables stay sparse; a list on the way is copied
/// whole from `full` first (a scenario file replaces lists whole).
pub(crate) fn set(
    sparse: &mut Table,
    full: &Table,
    path: &[Segment],
    value: Value,
) -> Result<(), String> {
    let Some((Segment::Field(first), rest)) = path.split_first() else {
        return Err("a key starts with a field name, not an index".into());
    };
    if rest.is_empty() {
        sparse.insert(first.clone(), value);
        return Ok(());
    }
    match full.get(first) {
        Some(Value::Table(full_inner)) => {
            let entry = sparse
                .entry(first.clone())
                .or_insert_with(|| Value::Table(Table::new()));
            match entry {
                Value::Table(inner) => set(inner, full_inner, rest, value),
                _ => Err(format!("{first} is not a table in the scenario file")),
            }
        }
        Some(full_value) => {
            let entry = sparse
                .entry(first.clone())
                .or_insert_with(|| full_value.clone());
            set_within(entry, rest, value, first)
        }
        None => Err(format!("the scenario has no field \"{first}\"")),
    }
}

/// Writes `value` at `path` inside a whole value (a list copied from the full scenario).
fn set_within(into: &mut Value, path: &[Segment], value: Value, at: &str) -> Result<(), String> {
    let Some((step, rest)) = path.split_first() else {
        *into = value;
        return Ok(());
    };
    let inner = match (into, step) {
        (Value::Array(a), Segment::Index(i)) => a
            .get_mut(*i)
            .ok_or_else(|| format!("{at} has no entry {i}"))?,
        (Value::Table(t), Segment::Field(f)) => t
            .get_mut(f)
            .ok_or_else(|| format!("{at} has no field \"{f}\""))?,
        _ => return Err(format!("{at} has no {}", show(std::slice::from_ref(step)))),
    };
    set_within(inner, rest, value, at)
}

/// Merges `from` into `into`: tables field by field, anything else replaced whole (how a
/// scenario file overrides its base).
pub(crate) fn merge(into: &mut Table, from: &Table) {
    for (key, value) in from {
        match (into.get_mut(key), value) {
            (Some(Value::Table(a)), Value::Table(b)) => merge(a, b),
            (_, v) => {
                into.insert(key.clone(), v.clone());
            }
        }
    }
}
