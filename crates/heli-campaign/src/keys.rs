//! Dotted keys into a scenario's TOML (`airframe.mass_kg`, `wind_ned_mps.0`,
//! `plan.1.alt_m`, also written `wind_ned_mps[0]`): parsing, reading, and writing a value
//! into a sparse scenario file.

use std::fmt;

use toml::{Table, Value};

/// A key that does not lead to a value of the scenario.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum KeyError {
    /// `a..b` or a trailing dot.
    EmptyStep {
        /// The key.
        key: String,
    },
    /// An index too large for a number.
    IndexTooLarge {
        /// The key.
        key: String,
        /// The step.
        step: String,
    },
    /// The key starts with an index.
    StartsWithIndex,
    /// A table without the field named.
    NoField {
        /// Where (`the scenario`, `airframe`).
        at: String,
        /// The field.
        field: String,
        /// The fields it has, when told.
        has: Option<String>,
    },
    /// A list shorter than the index.
    TooFewEntries {
        /// The list.
        at: String,
        /// Its entries.
        len: usize,
    },
    /// A list in the scenario file without the entry.
    NoEntry {
        /// The list.
        at: String,
        /// The index.
        index: usize,
    },
    /// An index into a table.
    TableNotList {
        /// The table.
        at: String,
        /// The index.
        index: usize,
    },
    /// A field of a list.
    ListNotTable {
        /// The list.
        at: String,
        /// The field.
        field: String,
    },
    /// A step into a single value.
    SingleValue {
        /// The value.
        at: String,
    },
    /// A step the value does not have.
    NoStep {
        /// The value.
        at: String,
        /// The step.
        step: String,
    },
    /// A field that is a table in the scenario and not in the file.
    NotATable {
        /// The field.
        field: String,
    },
}

impl fmt::Display for KeyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeyError::EmptyStep { key } => write!(
                f,
                "key \"{key}\" has an empty step: write fields and indexes separated by dots, e.g. wind_ned_mps.0 or plan.1.alt_m"
            ),
            KeyError::IndexTooLarge { key, step } => {
                write!(f, "key \"{key}\": index {step} is too large")
            }
            KeyError::StartsWithIndex => {
                f.write_str("a key starts with a field name, not an index")
            }
            KeyError::NoField {
                at,
                field,
                has: Some(has),
            } => write!(f, "{at} has no field \"{field}\" (it has: {has})"),
            KeyError::NoField {
                at,
                field,
                has: None,
            } => write!(f, "{at} has no field \"{field}\""),
            KeyError::TooFewEntries { at, len } => write!(
                f,
                "{at} has {len} entries (indexes from 0); give it more in [scenario] first"
            ),
            KeyError::NoEntry { at, index } => write!(f, "{at} has no entry {index}"),
            KeyError::TableNotList { at, index } => {
                write!(f, "{at} is a table: name one of its fields, not {index}")
            }
            KeyError::ListNotTable { at, field } => {
                write!(f, "{at} is a list: give an index, not \"{field}\"")
            }
            KeyError::SingleValue { at } => {
                write!(f, "{at} is a single value: it has nothing inside")
            }
            KeyError::NoStep { at, step } => write!(f, "{at} has no {step}"),
            KeyError::NotATable { field } => {
                write!(f, "{field} is not a table in the scenario file")
            }
        }
    }
}

impl std::error::Error for KeyError {}

/// One step of a key: a table's field or a list's index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Segment {
    /// A field of a table.
    Field(String),
    /// An index into a list (0-based).
    Index(usize),
}

/// Parses `a.b.0` or `a.b[0]`; all-digit steps are indexes.
pub(crate) fn parse(key: &str) -> Result<Vec<Segment>, KeyError> {
    let normalised = key.replace('[', ".").replace(']', "");
    let mut path = Vec::new();
    for step in normalised.split('.') {
        if step.is_empty() {
            return Err(KeyError::EmptyStep {
                key: key.to_string(),
            });
        }
        if step.bytes().all(|b| b.is_ascii_digit()) {
            let i = step.parse().map_err(|_| KeyError::IndexTooLarge {
                key: key.to_string(),
                step: step.to_string(),
            })?;
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
pub(crate) fn get<'a>(table: &'a Table, path: &[Segment]) -> Result<&'a Value, KeyError> {
    let Some((Segment::Field(first), rest)) = path.split_first() else {
        return Err(KeyError::StartsWithIndex);
    };
    let mut value = table.get(first).ok_or_else(|| KeyError::NoField {
        at: "the scenario".into(),
        field: first.clone(),
        has: Some(names(table)),
    })?;
    for (depth, step) in rest.iter().enumerate() {
        let here = show(&path[..=depth]);
        value = match (value, step) {
            (Value::Table(t), Segment::Field(f)) => t.get(f).ok_or_else(|| KeyError::NoField {
                at: here,
                field: f.clone(),
                has: Some(names(t)),
            })?,
            (Value::Array(a), Segment::Index(i)) => a.get(*i).ok_or(KeyError::TooFewEntries {
                at: here,
                len: a.len(),
            })?,
            (Value::Table(_), Segment::Index(i)) => {
                return Err(KeyError::TableNotList {
                    at: here,
                    index: *i,
                });
            }
            (Value::Array(_), Segment::Field(f)) => {
                return Err(KeyError::ListNotTable {
                    at: here,
                    field: f.clone(),
                });
            }
            (_, _) => return Err(KeyError::SingleValue { at: here }),
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
) -> Result<(), KeyError> {
    let Some((Segment::Field(first), rest)) = path.split_first() else {
        return Err(KeyError::StartsWithIndex);
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
                _ => Err(KeyError::NotATable {
                    field: first.clone(),
                }),
            }
        }
        Some(full_value) => {
            let entry = sparse
                .entry(first.clone())
                .or_insert_with(|| full_value.clone());
            set_within(entry, rest, value, first)
        }
        None => Err(KeyError::NoField {
            at: "the scenario".into(),
            field: first.clone(),
            has: None,
        }),
    }
}

/// Writes `value` at `path` inside a whole value (a list copied from the full scenario).
fn set_within(into: &mut Value, path: &[Segment], value: Value, at: &str) -> Result<(), KeyError> {
    let Some((step, rest)) = path.split_first() else {
        *into = value;
        return Ok(());
    };
    let inner = match (into, step) {
        (Value::Array(a), Segment::Index(i)) => a.get_mut(*i).ok_or_else(|| KeyError::NoEntry {
            at: at.to_string(),
            index: *i,
        })?,
        (Value::Table(t), Segment::Field(f)) => t.get_mut(f).ok_or_else(|| KeyError::NoField {
            at: at.to_string(),
            field: f.clone(),
            has: None,
        })?,
        _ => {
            return Err(KeyError::NoStep {
                at: at.to_string(),
                step: show(std::slice::from_ref(step)),
            });
        }
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
