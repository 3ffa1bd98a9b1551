//! Scenarios: what to fly and how to judge it. Built-in ones are listed by `heli sim --list`;
//! a TOML file can describe a new one, starting from a built-in (`base = "hover"`) and
//! overriding any field (see `docs/scenarios.md`).

use serde::{Deserialize, Serialize};

use crate::params::{Airframe, Atmosphere};

/// Control system the flight software is started with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Pilot flies; computer yaw damping.
    Manual,
    /// Computer takes off and holds position when the pilot's auto switch is on.
    Autonomous,
}

/// The pilot's transmitter for the whole flight (scripted inputs come in a later issue).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pilot {
    /// Aileron stick, −1..1.
    pub aileron: f64,
    /// Elevator stick, −1..1.
    pub elevator: f64,
    /// Rudder stick, −1..1.
    pub rudder: f64,
    /// Collective stick, −1..1.
    pub collective: f64,
    /// Throttle channel, 0..1 (0.8 governs the rotor at 1600 rpm).
    pub throttle: f64,
    /// Auto switch.
    pub auto: bool,
}

impl Default for Pilot {
    fn default() -> Self {
        Self {
            aileron: 0.0,
            elevator: 0.0,
            rudder: 0.0,
            collective: 0.0,
            throttle: 0.8,
            auto: true,
        }
    }
}

/// Pass/fail limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Horizontal hold error RMS, estimate against target (m).
    pub hold_horizontal_rms_m: f64,
    /// Altitude hold error RMS, estimate against target (m).
    pub hold_altitude_rms_m: f64,
    /// Largest true distance from the target during the hold (m).
    pub hold_true_max_m: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            hold_horizontal_rms_m: 1.0,
            hold_altitude_rms_m: 0.5,
            hold_true_max_m: 3.0,
        }
    }
}

/// Faults injected into the run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Faults {
    /// Probability that an IMU packet is lost (0..1).
    pub imu_drop_rate: f64,
    /// Intervals [start, end) in seconds during which the GPS sends nothing.
    pub gps_outages: Vec<[f64; 2]>,
}

/// One scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Name.
    pub name: String,
    /// One line on what it flies.
    pub description: String,
    /// Random seed of every noise source.
    pub seed: u64,
    /// Longest simulated time (s); the run ends earlier when the flight plan is complete.
    pub duration_s: f64,
    /// Steady wind, NED (m/s).
    pub wind_ned_mps: [f64; 3],
    /// Turbulence: vertical gust intensity σ_w (m/s); Dryden, low altitude. 0 for none.
    pub turbulence_sigma_mps: f64,
    /// Air and gravity.
    pub atmosphere: Atmosphere,
    /// The helicopter's parameters (default: the MIT X-Cell 60 SE).
    pub airframe: Airframe,
    /// Control system.
    pub mode: Mode,
    /// Autonomous take-off height (m).
    pub takeoff_alt_m: f64,
    /// How long to hold position once there (s).
    pub hold_s: f64,
    /// Pilot's transmitter.
    pub pilot: Pilot,
    /// Injected faults.
    pub faults: Faults,
    /// Pass/fail limits.
    pub limits: Limits,
}

impl Default for Scenario {
    fn default() -> Self {
        hover()
    }
}

/// Built-in scenario `hover`: rotor governed at 1600 rpm on the ground, 80 s calibration,
/// autonomous take-off to 10 m, 60 s position hold.
pub fn hover() -> Scenario {
    Scenario {
        name: "hover".into(),
        description:
            "calibrate on the ground, take off autonomously to 10 m, hold position for 60 s".into(),
        seed: 1,
        duration_s: 200.0,
        wind_ned_mps: [0.0; 3],
        turbulence_sigma_mps: 0.0,
        atmosphere: Atmosphere::default(),
        airframe: Airframe::default(),
        mode: Mode::Autonomous,
        takeoff_alt_m: 10.0,
        hold_s: 60.0,
        pilot: Pilot::default(),
        faults: Faults::default(),
        limits: Limits::default(),
    }
}

/// All built-in scenarios, most complete flight first (the default of `heli sim`).
pub fn builtins() -> Vec<Scenario> {
    vec![hover()]
}

/// A built-in scenario by name.
pub fn builtin(name: &str) -> Option<Scenario> {
    builtins().into_iter().find(|s| s.name == name)
}

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
    toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| ScenarioError::Invalid(e.to_string()))
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
    from_toml(&text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_overrides_its_base() {
        let s = from_toml("name = \"windy\"\nseed = 7\nwind_ned_mps = [3.0, 0.0, 0.0]\n[faults]\nimu_drop_rate = 0.01\n")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.name, "windy");
        assert_eq!(s.seed, 7);
        assert_eq!(s.wind_ned_mps, [3.0, 0.0, 0.0]);
        assert_eq!(s.faults.imu_drop_rate, 0.01);
        assert_eq!(s.hold_s, 60.0, "inherited from hover");
        assert_eq!(s.limits, Limits::default());
    }

    #[test]
    fn unknown_fields_and_bases_are_clear_errors() {
        let e = from_toml("wnd = 3")
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("wnd"), "{e}");
        assert!(from_toml("base = \"loop-the-loop\"").is_err());
    }
}
