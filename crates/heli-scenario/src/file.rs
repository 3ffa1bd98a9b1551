//! Scenario files: TOML over a built-in base (`base = "hover"`), every field checked
//! ([`crate::validate`]); and a scenario by name or path ([`load`]).

use crate::builtin::builtin;
use crate::scenario::Scenario;

/// Why a scenario could not be loaded.
#[derive(Debug)]
pub enum ScenarioError {
    /// Neither a built-in name nor a readable file.
    NotFound(String),
    /// The file is not valid TOML or has unknown or mistyped fields.
    Invalid(String),
}

impl std::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScenarioError::NotFound(s) => write!(
                f,
                "no built-in scenario or file named '{s}' (see `heli sim --list`)"
            ),
            ScenarioError::Invalid(s) => write!(f, "invalid scenario file: {s}"),
        }
    }
}

impl std::error::Error for ScenarioError {}

/// Parses a scenario file's text: its fields override those of its `base` built-in
/// (default `hover`); a file without a `name` is called after its base.
pub fn from_toml(text: &str) -> Result<Scenario, ScenarioError> {
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| ScenarioError::Invalid(e.to_string()))?;
    let base_name = match table.remove("base") {
        Some(toml::Value::String(s)) => s,
        Some(other) => {
            return Err(ScenarioError::Invalid(format!(
                "'base' must be a scenario name, not {other}"
            )));
        }
        None => "hover".to_string(),
    };
    let base = builtin(&base_name)
        .ok_or_else(|| ScenarioError::Invalid(format!("unknown base scenario '{base_name}'")))?;
    let mut merged =
        toml::Table::try_from(&base).map_err(|e| ScenarioError::Invalid(e.to_string()))?;
    merge(&mut merged, table);
    unset_limits(&mut merged)?;
    non_finite("", &toml::Value::Table(merged.clone())).map_or(Ok(()), |key| {
        Err(ScenarioError::Invalid(format!(
            "{key}: must be a finite number (nan and inf are refused)"
        )))
    })?;
    let scenario: Scenario = toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| ScenarioError::Invalid(e.to_string()))?;
    crate::validate::scenario(&scenario).map_err(|e| ScenarioError::Invalid(e.to_string()))?;
    Ok(scenario)
}

/// The key of the first number in `value` that is not finite (NaN, ±inf), if any. (Checked
/// on the TOML itself: a NaN in an optional field reaches serde as nothing at all.)
fn non_finite(path: &str, value: &toml::Value) -> Option<String> {
    match value {
        toml::Value::Float(x) if !x.is_finite() => Some(path.to_string()),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| {
            let key = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            non_finite(&key, v)
        }),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(&format!("{path}[{i}]"), v)),
        _ => None,
    }
}

/// A limit set to `"unset"` in a file is removed: the criterion the base scenario judged is
/// not judged (TOML has no null).
fn unset_limits(scenario: &mut toml::Table) -> Result<(), ScenarioError> {
    let Some(toml::Value::Table(limits)) = scenario.get_mut("limits") else {
        return Ok(());
    };
    let mut unset = Vec::new();
    for (key, value) in limits.iter() {
        match value {
            toml::Value::String(s) if s == "unset" => unset.push(key.clone()),
            toml::Value::String(s) => {
                return Err(ScenarioError::Invalid(format!(
                    "limits.{key}: '{s}' is not a limit (a number, or \"unset\" to drop the base's)"
                )));
            }
            _ => {}
        }
    }
    for key in unset {
        limits.remove(&key);
    }
    Ok(())
}

fn merge(into: &mut toml::Table, from: toml::Table) {
    for (key, value) in from {
        match (into.get_mut(&key), value) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
            (_, v) => {
                into.insert(key, v);
            }
        }
    }
}

/// A built-in name or a path to a TOML file.
pub fn load(name_or_path: &str) -> Result<Scenario, ScenarioError> {
    if let Some(s) = builtin(name_or_path) {
        return Ok(s);
    }
    let text = std::fs::read_to_string(name_or_path)
        .map_err(|_| ScenarioError::NotFound(name_or_path.into()))?;
    from_toml(&text).map_err(|e| match e {
        ScenarioError::Invalid(why) => ScenarioError::Invalid(format!("{name_or_path}: {why}")),
        other => other,
    })
}

#[cfg(test)]
mod tests;
