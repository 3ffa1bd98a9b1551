//! `heli log replay FILE`: the flight's recorded device inputs fed to a fresh flight
//! computer; reports whether its servo commands and state estimates match the log bit for
//! bit, and where the first difference is.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow, bail};
use heli_fsw::core::{CoreConfig, FlightParams};
use heli_log::LogContents;
use heli_sim::lockstep::Simulation;
use heli_types::FlightMode;
use heli_vehicle::replay::{self, ReplaySetup};

/// How the logged flight's computer was set up, from the log's `flight` metadata: a lockstep
/// flight records its whole scenario, a vehicle flight its parameters and configuration.
pub(crate) fn setup_of(contents: &LogContents) -> Result<ReplaySetup> {
    let entries = contents
        .metadata
        .iter()
        .find(|m| m.name == heli_log::metadata::FLIGHT)
        .map(|m| &m.entries)
        .context("the log has no 'flight' metadata, so its flight computer's setup is unknown")?;
    let get = |key: &str| {
        entries
            .get(key)
            .with_context(|| format!("the flight metadata has no '{key}'"))
    };
    if let Some(toml_text) = entries.get("scenario_toml") {
        let scenario: heli_sim::Scenario =
            toml::from_str(toml_text).context("the logged scenario does not parse")?;
        let (config, params) = Simulation::new(scenario)?.flight_software_setup();
        return Ok(ReplaySetup {
            config,
            params,
            baro_rate_hz: heli_proto::baro::DEFAULT_RATE_HZ,
            restart_from: None,
        });
    }
    let number = |key: &str| -> Result<f64> {
        get(key)?
            .parse::<f64>()
            .with_context(|| format!("flight metadata '{key}' is not a number"))
    };
    let triple = |key: &str| -> Result<[f64; 3]> {
        let text = get(key)?;
        let v: Vec<f64> = serde_json::from_str(text)
            .with_context(|| format!("flight metadata '{key}' is not [x, y, z]"))?;
        <[f64; 3]>::try_from(v).map_err(|_| anyhow!("flight metadata '{key}' is not [x, y, z]"))
    };
    let mode_name = get("mode")?;
    let mode = FlightMode::from_name(mode_name)
        .with_context(|| format!("unknown mode '{mode_name}' in the flight metadata"))?;
    let plan_name = get("plan")?;
    // The legs themselves are in the log; older logs name a plan to look up.
    let legs: Vec<heli_types::Leg> = match entries.get("plan_legs_json") {
        Some(json) => serde_json::from_str(json).context("the logged plan's legs do not parse")?,
        None => heli_types::library::plan(plan_name)
            .with_context(|| format!("the logged flight plan '{plan_name}' is not in the library"))?
            .legs
            .to_vec(),
    };
    let plan = heli_types::Plan::new(&legs)
        .with_context(|| format!("the logged flight plan '{plan_name}'"))?;
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
        table
            .load_text(text)
            .map_err(|e| anyhow!("flight metadata 'params': {e}"))?;
        heli_vehicle::params::apply(&table, &mut config);
    }
    let baro_rate_hz = get("baro_rate_hz")?
        .parse::<u8>()
        .context("flight metadata 'baro_rate_hz' is not a rate")?;
    // A process started again in the air resumed from a record: so does its replay.
    let restart_from = match entries.get("warm_start").map(String::as_str) {
        None | Some("") => None,
        Some(text) => Some(
            heli_vehicle::warm::WarmFile::parse(text)
                .map_err(|e| anyhow!("flight metadata 'warm_start': {e}"))?
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

/// Replays a log; exit 0 on an exact match, 1 on a difference.
pub fn replay(file: &Path, contents: &LogContents) -> Result<ExitCode> {
    let setup = setup_of(contents).with_context(|| format!("{}", file.display()))?;
    let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
    let logged = contents
        .metadata
        .iter()
        .find_map(|m| m.entries.get("software"))
        .map(String::as_str);
    if logged.is_some_and(|l| l != software) {
        eprintln!(
            "heli log replay: the log was written by {}, this is {software}: a difference may be the software's",
            logged.unwrap_or("?")
        );
    }
    let outcome = replay::replay(&setup, contents)
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("{}", file.display()))?;
    println!("{}", file.display());
    println!("  device inputs fed  {}", outcome.inputs);
    for (channel, n) in &outcome.compared {
        println!("  {channel:<8} {n} messages compared");
    }
    match &outcome.first_difference {
        None if outcome.exact() => {
            println!("  EXACT MATCH: servo commands and state estimates identical bit for bit");
            Ok(ExitCode::SUCCESS)
        }
        None => bail!("nothing to compare: the log has no servo or state messages"),
        Some(d) => {
            let t = d.logged_t_us.or(d.replayed_t_us).unwrap_or(0) as f64 * 1e-6;
            println!(
                "  FIRST DIFFERENCE  {} message {} at t={t:.6} s",
                d.channel, d.index
            );
            for f in &d.fields {
                println!("    {f}");
            }
            Ok(ExitCode::FAILURE)
        }
    }
}
