//! Scenarios: what to fly and how to judge it. Built-in ones are listed by `heli sim --list`;
//! a TOML file can describe a new one, starting from a built-in (`base = "hover"`) and
//! overriding any field (see `docs/scenarios.md`).

use serde::{Deserialize, Serialize};

use heli_model::params::{Airframe, Atmosphere};

pub use heli_types::{FlightMode, Leg};

pub use crate::pilot::{Channel, Pilot, Shape, StickInput};

/// Pass/fail limits; a criterion is judged only when its limit is set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Least time spent holding position (s).
    pub hold_min_s: Option<f64>,
    /// Horizontal hold error RMS, estimate against target (m).
    pub hold_horizontal_rms_m: Option<f64>,
    /// Altitude hold error RMS, estimate against target (m).
    pub hold_altitude_rms_m: Option<f64>,
    /// Largest true distance from the target during the holds (m).
    pub hold_true_max_m: Option<f64>,
    /// Fewest autonomous rolls completed.
    pub rolls_min: Option<f64>,
    /// Largest altitude loss over the roll sequence (m): true altitude at its start minus the
    /// lowest true altitude before the recovery ends.
    pub altitude_loss_max_m: Option<f64>,
    /// Largest attitude error (deg, roll or pitch) at the end of the recovery from the last
    /// roll, against the trim attitude the sequence began from (in wind the trim is not
    /// level).
    pub recovery_attitude_max_deg: Option<f64>,
    /// Largest airspeed error at the end of the recovery (m/s), against the airspeed the
    /// sequence began from: judged relative to the air, not the ground.
    pub recovery_speed_max_mps: Option<f64>,
    /// Estimator attitude error RMS over the flight (deg).
    pub att_err_rms_max_deg: Option<f64>,
    /// Estimator attitude error, worst case (deg).
    pub att_err_max_deg: Option<f64>,
    /// Estimator position error RMS, relative navigation (m).
    pub pos_err_rms_max_m: Option<f64>,
    /// After the transmitter is lost: hovering (true speed under 0.5 m/s) within this (s).
    pub rc_loss_hover_within_s: Option<f64>,
    /// After the transmitter is lost: largest true horizontal drift over the 20 s after the
    /// hover began (m).
    pub rc_loss_drift_max_m: Option<f64>,
    /// Estimator position error at the end of each GPS outage (m).
    pub gps_outage_pos_err_max_m: Option<f64>,
    /// The flight plan must be completed.
    pub plan_complete: Option<bool>,
    /// In manual flight (auto switch off): largest true yaw rate (deg/s) — the computer's yaw
    /// damping at work.
    pub manual_yaw_rate_max_dps: Option<f64>,
    /// In manual flight: largest true horizontal distance from where it began (m).
    pub manual_distance_max_m: Option<f64>,
    /// During scripted sweeps: least true roll-rate RMS (deg/s), i.e. the sweep was flown.
    pub sweep_roll_rate_rms_min_dps: Option<f64>,
    /// Augmented velocity mode: largest error between the velocity the sticks command and
    /// the true velocity, over the last second of each scripted aileron or elevator input
    /// (m/s).
    pub velocity_tracking_max_mps: Option<f64>,
    /// Augmented velocity mode: least true height gained (m).
    pub climb_min_m: Option<f64>,
    /// Augmented modes: largest error between the yaw rate the rudder stick commands and the
    /// true yaw rate, over the last second of each scripted rudder input (deg/s).
    pub yaw_rate_tracking_max_dps: Option<f64>,
    /// Stayed on the ground: the greatest height above the start (m) must not exceed this.
    pub ground_max_m: Option<f64>,
    /// Least true height above the start (m) from the end of the take-off climb (flown by
    /// hand: from when it first climbed above 2 m) until it begins to land (or the run ends).
    pub height_min_m: Option<f64>,
    /// Largest true tilt (deg) from level while airborne.
    pub tilt_max_deg: Option<f64>,
    /// After a flight, the touchdown: largest horizontal distance (m) between where the skids
    /// touched and where the flight software meant to land (its last target, as a true
    /// place).
    pub touchdown_distance_max_m: Option<f64>,
    /// Largest sink speed at touchdown (m/s).
    pub touchdown_sink_max_mps: Option<f64>,
    /// Largest horizontal ground speed at touchdown (m/s).
    pub touchdown_speed_max_mps: Option<f64>,
    /// Largest tilt from level (deg) when the skids first touch after a flight.
    pub touchdown_tilt_max_deg: Option<f64>,
    /// After an engine failure: least rotor speed (rpm) before the touchdown while more
    /// than 3 m above the start (the cushion near the ground spends it on purpose).
    pub rotor_min_rpm: Option<f64>,
    /// Least true charge of the flight pack over the run (fraction): the avionics still
    /// powered.
    pub flight_battery_soc_min: Option<f64>,
    /// Largest error of the flight software's time left on the flight pack against the
    /// truth (%), once its gauge has had two minutes and while five are left.
    pub battery_time_left_err_max_pct: Option<f64>,
    /// Time to hover (s): from the start of the first position hold until the true ground
    /// speed has stayed under 0.5 m/s for a second.
    pub hover_within_s: Option<f64>,
}

pub use crate::faults::{ByteLoss, Faults, ForcedSatellites, GpsGlitch};

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
    /// Wind shear: how much the wind changes per metre of height above the take-off point,
    /// NED ((m/s)/m).
    pub wind_shear_mps_per_m: [f64; 3],
    /// Wind changes over time (gusts, steps, ramps), added to the steady wind.
    pub wind_changes: Vec<crate::faults::WindChange>,
    /// Air and gravity.
    pub atmosphere: Atmosphere,
    /// The helicopter's parameters (default: the MIT X-Cell 60 SE).
    pub airframe: Airframe,
    /// The flight battery: capacity, charge at power-on, load, temperature, wear.
    pub battery: crate::faults::Battery,
    /// The servo board's packs and the hot-swap.
    pub power: crate::faults::Power,
    /// Control system.
    pub mode: FlightMode,
    /// The autonomous flight plan.
    pub plan: Vec<Leg>,
    /// Pilot's transmitter.
    pub pilot: Pilot,
    /// Injected faults.
    pub faults: Faults,
    /// Pass/fail limits.
    pub limits: Limits,
    /// Texts that must appear among the flight software's events (each is a criterion):
    /// how a fault scenario checks that the fault was raised, e.g. `"uplink lost"`.
    pub expect_events: Vec<String>,
}

impl Scenario {
    /// The wind at `t_s` and `height_m` above the take-off point, before turbulence: the
    /// steady wind, its shear with height and its changes over time.
    pub fn wind_at(&self, t_s: f64, height_m: f64) -> nalgebra::Vector3<f64> {
        let steady = nalgebra::Vector3::from(self.wind_ned_mps);
        let shear = nalgebra::Vector3::from(self.wind_shear_mps_per_m) * height_m.max(0.0);
        self.wind_changes.iter().fold(steady + shear, |w, c| {
            w + nalgebra::Vector3::from(c.wind_ned_mps) * c.fraction(t_s)
        })
    }
}

impl Default for Scenario {
    fn default() -> Self {
        hover()
    }
}

/// The plan of the library named `name` (the plan the built-in scenario of that name flies).
pub(crate) fn library_plan(name: &str) -> Vec<Leg> {
    heli_types::library::plan(name).map_or_else(Vec::new, |p| p.legs.to_vec())
}

fn base(name: &str, description: &str, duration_s: f64) -> Scenario {
    Scenario {
        name: name.into(),
        description: description.into(),
        seed: 1,
        duration_s,
        wind_ned_mps: [0.0; 3],
        turbulence_sigma_mps: 0.0,
        wind_shear_mps_per_m: [0.0; 3],
        wind_changes: Vec::new(),
        atmosphere: Atmosphere::default(),
        airframe: Airframe::default(),
        battery: crate::faults::Battery::default(),
        power: crate::faults::Power::default(),
        mode: FlightMode::Autonomous,
        plan: library_plan(name),
        pilot: Pilot::default(),
        faults: Faults::default(),
        limits: Limits::default(),
        expect_events: Vec::new(),
    }
}

/// Built-in scenario `hover`: rotor governed at 1600 rpm on the ground, 80 s calibration,
/// autonomous take-off to 10 m, 60 s position hold.
pub fn hover() -> Scenario {
    let mut s = base(
        "hover",
        "calibrate on the ground, take off autonomously to 10 m, hold position for 60 s",
        200.0,
    );
    s.limits = Limits {
        hold_min_s: Some(60.0),
        hold_horizontal_rms_m: Some(1.0),
        hold_altitude_rms_m: Some(0.5),
        hold_true_max_m: Some(3.0),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `rolls`: forward flight at 8 m/s, three autonomous aileron rolls,
/// recovery to the trim trajectory.
pub fn rolls() -> Scenario {
    let mut s = base(
        "rolls",
        "take off, climb to 25 m, three autonomous aileron rolls from 8 m/s, recover, hold",
        260.0,
    );
    s.limits = Limits {
        rolls_min: Some(3.0),
        altitude_loss_max_m: Some(5.0),
        recovery_attitude_max_deg: Some(15.0),
        recovery_speed_max_mps: Some(3.0),
        att_err_rms_max_deg: Some(1.5),
        att_err_max_deg: Some(5.0),
        pos_err_rms_max_m: Some(2.5),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `demo`, the default of `heli sim`: take-off, hover, three rolls, return
/// and landing.
pub fn demo() -> Scenario {
    let mut s = base(
        "demo",
        "demonstration flight: take off, hover, three aileron rolls, fly home, land",
        320.0,
    );
    s.limits = Limits {
        rolls_min: Some(3.0),
        altitude_loss_max_m: Some(5.0),
        recovery_attitude_max_deg: Some(15.0),
        recovery_speed_max_mps: Some(3.0),
        att_err_max_deg: Some(5.0),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `rc-loss`: the pilot's transmitter is lost while the helicopter flies a
/// path; the computer must hover.
pub fn rc_loss() -> Scenario {
    let mut s = base(
        "rc-loss",
        "transmitter lost while flying a path at 3 m/s: hover within 2 s, drift under 3 m",
        160.0,
    );
    s.faults.transmitter_lost = vec![[110.0, 1000.0]];
    s.limits = Limits {
        rc_loss_hover_within_s: Some(2.0),
        rc_loss_drift_max_m: Some(3.0),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `gps-outage`: 10 s without GPS in hover.
pub fn gps_outage() -> Scenario {
    let mut s = hover();
    s.name = "gps-outage".into();
    s.description =
        "10 s without GPS while hovering: no divergence, position error under 5 m".into();
    s.faults.gps_outages = vec![[120.0, 130.0]];
    s.limits.gps_outage_pos_err_max_m = Some(5.0);
    // The GPS watchdog raises the silence; the filter reports its coasting.
    s.expect_events = vec!["gps silent".into(), "GPS lost".into(), "GPS back".into()];
    s.limits.hold_true_max_m = Some(6.0);
    s
}

/// Built-in scenario `manual-sweep`: the pilot takes over from an autonomous hover, hovers
/// by hand and flies a lateral-cyclic frequency sweep, as the thesis's identification flights
/// did; the computer damps yaw.
pub fn manual_sweep() -> Scenario {
    let mut s = base(
        "manual-sweep",
        "manual flight with computer yaw damping: a 0.3-3 Hz lateral-cyclic sweep from a hover",
        170.0,
    );
    s.pilot.auto_flipped = vec![[105.0, 155.0]];
    s.pilot.hovers_in_manual = true;
    s.pilot.inputs = vec![StickInput {
        channel: Channel::Aileron,
        shape: Shape::Sweep,
        start_s: 112.0,
        duration_s: 30.0,
        amplitude: 0.15,
        f0_hz: 0.3,
        f1_hz: 3.0,
    }];
    s.limits = Limits {
        manual_yaw_rate_max_dps: Some(30.0),
        manual_distance_max_m: Some(10.0),
        sweep_roll_rate_rms_min_dps: Some(10.0),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `augmented`: velocity-command augmentation; the pilot's scripted sticks
/// climb, fly forward, sideways and turn.
pub fn augmented() -> Scenario {
    let mut s = base(
        "augmented",
        "augmented velocity mode: scripted sticks climb, fly forward, sideways, turn; the computer tracks",
        140.0,
    );
    s.mode = FlightMode::Augmented(heli_types::AugmentedMode::Velocity);
    let step = |channel, start_s, duration_s, amplitude| StickInput {
        channel,
        shape: Shape::Step,
        start_s,
        duration_s,
        amplitude,
        f0_hz: 0.0,
        f1_hz: 0.0,
    };
    s.pilot.inputs = vec![
        step(Channel::Collective, 86.0, 10.0, 0.5),
        step(Channel::Elevator, 100.0, 10.0, -0.6),
        step(Channel::Aileron, 114.0, 8.0, 0.4),
        step(Channel::Rudder, 126.0, 3.0, 0.25),
    ];
    s.limits = Limits {
        velocity_tracking_max_mps: Some(0.6),
        yaw_rate_tracking_max_dps: Some(5.0),
        climb_min_m: Some(8.0),
        ..Limits::default()
    };
    s
}

/// All built-in scenarios, the default flight of `heli sim` first.
pub fn builtins() -> Vec<Scenario> {
    vec![
        demo(),
        hover(),
        rolls(),
        rc_loss(),
        gps_outage(),
        manual_sweep(),
        augmented(),
        crate::device_faults::uplink_silent(),
        crate::device_faults::imu_failure(),
        crate::device_faults::baro_failure(),
        crate::device_faults::compass_silent(),
        crate::device_faults::no_gps_takeoff(),
        crate::device_faults::roll_rc_loss(),
        crate::device_faults::brownout(),
        crate::device_faults::gps_lost(),
        crate::engine_failures::engine_failure_hover(),
        crate::engine_failures::engine_failure_low_hover(),
        crate::engine_failures::engine_failure_forward(),
        crate::engine_failures::engine_failure_roll(),
        crate::power_scenarios::battery_swap(),
        crate::power_scenarios::weak_battery(),
        crate::power_scenarios::battery_drain(),
    ]
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
    unset_limits(&mut merged)?;
    non_finite("", &toml::Value::Table(merged.clone())).map_or(Ok(()), |key| {
        Err(ScenarioError::Invalid(format!(
            "{key}: must be a finite number (nan and inf are refused)"
        )))
    })?;
    let scenario: Scenario = toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| ScenarioError::Invalid(e.to_string()))?;
    crate::validate::scenario(&scenario).map_err(ScenarioError::Invalid)?;
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
