//! How a logged flight's computer was set up, read back from the log's `flight` metadata: a
//! lockstep flight records its whole scenario, a vehicle flight its parameters and
//! configuration (`heli_vehicle::flight_process` writes them).

use heli_fsw::core::{CoreConfig, FlightParams};
use heli_log::LogContents;
use heli_types::{FlightMode, Leg, Plan};

use super::log::ReplaySetup;
use crate::lockstep::Simulation;

/// Why a log's setup cannot be read back.
#[derive(Debug)]
pub enum SetupError {
    /// The log has no `flight` metadata.
    NoMetadata,
    /// A key the setup needs is missing.
    Missing(&'static str),
    /// A value cannot be read; what it should be.
    Bad {
        /// The metadata key.
        key: &'static str,
        /// What is wrong.
        why: String,
    },
}

impl std::fmt::Display for SetupError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SetupError::NoMetadata => write!(
                f,
                "the log has no 'flight' metadata, so its flight computer's setup is unknown"
            ),
            SetupError::Missing(key) => write!(f, "the flight metadata has no '{key}'"),
            SetupError::Bad { key, why } => write!(f, "flight metadata '{key}': {why}"),
        }
    }
}

impl std::error::Error for SetupError {}

fn bad(key: &'static str, why: impl std::fmt::Display) -> SetupError {
    SetupError::Bad {
        key,
        why: why.to_string(),
    }
}

/// The setup of the flight `contents` records.
pub fn setup_of(contents: &LogContents) -> Result<ReplaySetup, SetupError> {
    let entries = contents
        .metadata
        .iter()
        .find(|m| m.name == heli_log::metadata::FLIGHT)
        .map(|m| &m.entries)
        .ok_or(SetupError::NoMetadata)?;
    let get = |key: &'static str| entries.get(key).ok_or(SetupError::Missing(key));
    if let Some(toml_text) = entries.get("scenario_toml") {
        let scenario: heli_scenario::Scenario =
            toml::from_str(toml_text).map_err(|e| bad("scenario_toml", e))?;
        let (config, params) = Simulation::new(scenario)
            .map_err(|e| bad("scenario_toml", e))?
            .flight_software_setup();
        return Ok(ReplaySetup {
            config,
            params,
            baro_rate_hz: heli_proto::baro::DEFAULT_RATE_HZ,
            restart_from: None,
        });
    }
    let number = |key: &'static str| -> Result<f64, SetupError> {
        get(key)?
            .parse::<f64>()
            .map_err(|_| bad(key, "not a number"))
    };
    let triple = |key: &'static str| -> Result<[f64; 3], SetupError> {
        let v: Vec<f64> = serde_json::from_str(get(key)?).map_err(|_| bad(key, "not [x, y, z]"))?;
        <[f64; 3]>::try_from(v).map_err(|_| bad(key, "not [x, y, z]"))
    };
    let mode_name = get("mode")?;
    let mode = FlightMode::from_name(mode_name)
        .ok_or_else(|| bad("mode", format!("unknown mode '{mode_name}'")))?;
    let plan_name = get("plan")?;
    // The legs themselves are in the log; older logs name a plan of the library.
    let legs: Vec<Leg> = match entries.get("plan_legs_json") {
        Some(json) => serde_json::from_str(json).map_err(|e| bad("plan_legs_json", e))?,
        None => heli_types::library::plan(plan_name)
            .ok_or_else(|| bad("plan", format!("'{plan_name}' is not in the plan library")))?
            .legs
            .to_vec(),
    };
    let plan = Plan::new(&legs).map_err(|e| bad("plan", format!("'{plan_name}': {e}")))?;
    let mut config = CoreConfig {
        calibration_s: number("calibration_s")?,
        imu_warm_up_s: number("warm_up_s")?,
        compass: heli_proto::compass::CompassCalibration {
            bias_gauss: triple("compass_bias_gauss")?,
            scale: triple("compass_scale")?,
        },
        ..CoreConfig::default()
    };
    // The parameters the flight flew with (logs before the link's parameters have none).
    if let Some(text) = entries.get("params").filter(|t| !t.is_empty()) {
        let mut table = heli_vehicle::params::defaults();
        table.load_text(text).map_err(|e| bad("params", e))?;
        heli_vehicle::params::apply(&table, &mut config);
    }
    let baro_rate_hz = get("baro_rate_hz")?
        .parse::<u8>()
        .map_err(|_| bad("baro_rate_hz", "not a rate"))?;
    // A process started again in the air resumed from a record: so does its replay.
    let restart_from = match entries.get("warm_start").map(String::as_str) {
        None | Some("") => None,
        Some(text) => Some(
            heli_vehicle::warm::WarmFile::parse(text)
                .map_err(|e| bad("warm_start", e))?
                .warm,
        ),
    };
    Ok(ReplaySetup {
        config,
        params: FlightParams { mode, plan },
        baro_rate_hz,
        restart_from,
    })
}
