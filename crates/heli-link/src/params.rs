//! The parameter protocol on the vehicle's side (`PARAM_REQUEST_LIST`, `PARAM_REQUEST_READ`,
//! `PARAM_SET` → `PARAM_VALUE`), over a table of named values each with its range. A value
//! is checked on board before it is taken: a name the vehicle does not have, a value that is
//! not finite or outside its range changes nothing; the vehicle answers with the value it
//! keeps (as the protocol asks) and a status text with the reason.
//!
//! Which parameters exist and what they do is the vehicle's ([`ParamSpec`] lists).

use mavlink::dialects::common::*;

/// One parameter: name (at most 16 characters, as MAVLink allows), range and default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// Name on the link.
    pub name: &'static str,
    /// What it sets, with its unit.
    pub what: &'static str,
    /// Smallest value taken.
    pub min: f32,
    /// Largest value taken.
    pub max: f32,
    /// Value at first start.
    pub default: f32,
}

/// Why a value was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamError {
    /// No parameter of that name.
    Unknown(String),
    /// Not a finite number, or outside its range.
    OutOfRange {
        /// Name.
        name: String,
        /// Value asked for.
        value: f32,
        /// Range.
        min: f32,
        /// Range.
        max: f32,
    },
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamError::Unknown(n) => write!(f, "param {n}: no such parameter"),
            ParamError::OutOfRange {
                name,
                value,
                min,
                max,
            } => write!(f, "param {name}: {value} refused, range {min}..{max}"),
        }
    }
}

/// The table: specs and current values.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamTable {
    specs: Vec<ParamSpec>,
    values: Vec<f32>,
}

impl ParamTable {
    /// A table of `specs` at their defaults.
    pub fn new(specs: &[ParamSpec]) -> Self {
        Self {
            specs: specs.to_vec(),
            values: specs.iter().map(|s| s.default).collect(),
        }
    }

    /// The parameters, with their values.
    pub fn iter(&self) -> impl Iterator<Item = (&ParamSpec, f32)> {
        self.specs.iter().zip(self.values.iter().copied())
    }

    /// The value of `name`.
    pub fn get(&self, name: &str) -> Option<f32> {
        self.index(name).and_then(|i| self.values.get(i).copied())
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.specs.iter().position(|s| s.name == name)
    }

    /// Sets `name` to `value` if it is a parameter and the value is in its range.
    pub fn set(&mut self, name: &str, value: f32) -> Result<(), ParamError> {
        let i = self
            .index(name)
            .ok_or_else(|| ParamError::Unknown(name.to_string()))?;
        let spec = self
            .specs
            .get(i)
            .ok_or_else(|| ParamError::Unknown(name.to_string()))?;
        if !(value.is_finite() && value >= spec.min && value <= spec.max) {
            return Err(ParamError::OutOfRange {
                name: name.to_string(),
                value,
                min: spec.min,
                max: spec.max,
            });
        }
        if let Some(v) = self.values.get_mut(i) {
            *v = value;
        }
        Ok(())
    }

    /// The `PARAM_VALUE` of parameter `index`.
    pub fn value_message(&self, index: usize) -> Option<MavMessage> {
        let spec = self.specs.get(index)?;
        let value = self.values.get(index).copied()?;
        Some(MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: value,
            param_count: u16::try_from(self.specs.len()).unwrap_or(u16::MAX),
            param_index: u16::try_from(index).unwrap_or(u16::MAX),
            param_id: spec.name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }))
    }

    /// The `PARAM_VALUE` of `name`.
    pub fn value_message_named(&self, name: &str) -> Option<MavMessage> {
        self.value_message(self.index(name)?)
    }

    /// The values as a text file: `NAME = value` lines.
    pub fn to_text(&self) -> String {
        let mut out = String::from("# heli parameters, set over the link (docs/link.md)\n");
        for (spec, value) in self.iter() {
            out.push_str(&format!("{} = {value}\n", spec.name));
        }
        out
    }

    /// Takes the values of a text made by [`ParamTable::to_text`]; every line is checked as a
    /// `PARAM_SET` would be, and the first bad one is the error (naming its line).
    pub fn load_text(&mut self, text: &str) -> Result<(), LoadError> {
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = n.saturating_add(1);
            let error = |problem| LoadError { line: at, problem };
            let (name, value) = line
                .split_once('=')
                .ok_or_else(|| error(LoadProblem::NotNameValue))?;
            let value: f32 = value
                .trim()
                .parse()
                .map_err(|_| error(LoadProblem::NotANumber(value.trim().to_string())))?;
            self.set(name.trim(), value)
                .map_err(|e| error(LoadProblem::Refused(e)))?;
        }
        Ok(())
    }
}

/// A line of a parameters text that cannot be taken.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadError {
    /// The line's number, from 1.
    pub line: usize,
    /// What is wrong with it.
    pub problem: LoadProblem,
}

/// What is wrong with a line of a parameters text.
#[derive(Clone, Debug, PartialEq)]
pub enum LoadProblem {
    /// Not `NAME = value`.
    NotNameValue,
    /// The value is not a number.
    NotANumber(String),
    /// The value is refused as a `PARAM_SET` would be.
    Refused(ParamError),
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let at = self.line;
        match &self.problem {
            LoadProblem::NotNameValue => write!(f, "line {at}: expected NAME = value"),
            LoadProblem::NotANumber(v) => write!(f, "line {at}: '{v}' is not a number"),
            LoadProblem::Refused(e) => write!(f, "line {at}: {e}"),
        }
    }
}

impl std::error::Error for LoadError {}

/// The name in a `param_id` (NUL-padded).
pub fn param_name(id: &mavlink::types::CharArray<16>) -> String {
    id.to_str().unwrap_or("").trim_end_matches('\0').to_string()
}

/// One gain of 0 to 1, 0.5 by default: the parameter table of the link's tests.
#[cfg(test)]
pub(crate) const ONE_GAIN: [ParamSpec; 1] = [ParamSpec {
    name: "A_GAIN",
    what: "",
    min: 0.0,
    max: 1.0,
    default: 0.5,
}];

#[cfg(test)]
mod tests {
    use super::*;

    const SPECS: [ParamSpec; 2] = [
        ParamSpec {
            name: "HOV_YAW_P",
            what: "tail per rad/s",
            min: 0.0,
            max: 1.0,
            default: 0.3,
        },
        ParamSpec {
            name: "HOV_MAX_TILT_DEG",
            what: "deg",
            min: 5.0,
            max: 45.0,
            default: 30.0,
        },
    ];

    #[test]
    fn values_in_range_are_taken_and_others_change_nothing() {
        let mut t = ParamTable::new(&SPECS);
        assert_eq!(t.set("HOV_YAW_P", 0.4), Ok(()));
        assert_eq!(t.get("HOV_YAW_P"), Some(0.4));
        let err = t.set("HOV_YAW_P", 7.0).unwrap_err().to_string();
        assert!(err.contains("range 0..1"), "{err}");
        assert!(t.set("HOV_YAW_P", f32::NAN).is_err());
        assert_eq!(t.get("HOV_YAW_P"), Some(0.4));
        assert!(matches!(t.set("NOPE", 1.0), Err(ParamError::Unknown(_))));
    }

    #[test]
    fn the_file_round_trips_and_a_bad_line_is_named() {
        let mut t = ParamTable::new(&SPECS);
        t.set("HOV_MAX_TILT_DEG", 20.0).unwrap();
        let mut u = ParamTable::new(&SPECS);
        u.load_text(&t.to_text()).unwrap();
        assert_eq!(u, t);
        let err = u
            .load_text("HOV_YAW_P = 0.2\nHOV_MAX_TILT_DEG = 90\n")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("line 2:"), "{err}");
    }

    #[test]
    fn a_value_message_names_its_parameter() {
        let t = ParamTable::new(&SPECS);
        let Some(MavMessage::PARAM_VALUE(v)) = t.value_message(1) else {
            panic!()
        };
        assert_eq!(param_name(&v.param_id), "HOV_MAX_TILT_DEG");
        assert_eq!((v.param_index, v.param_count, v.param_value), (1, 2, 30.0));
    }
}
