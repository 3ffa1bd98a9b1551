//! The vehicle's parameters (set over the link's parameter protocol, docs/link.md): the
//! hover and augmented loops' gains and limits, the sticks' full-scale values, and device
//! settings. The bootstrap keeps them in `<log-dir>/params` (written whole, atomically, at
//! each change); a flight process reads them when it starts, so a value set during a flight
//! applies from the next Start Logging. Each flight's log records the values it flew with,
//! and its replay applies them again.

use std::path::{Path, PathBuf};

use crate::error::VehicleError;
use heli_fsw::core::CoreConfig;
use heli_link::params::{ParamSpec, ParamTable};

/// The parameters, with their ranges and defaults (the defaults are `CoreConfig`'s).
pub const SPECS: [ParamSpec; 16] = [
    spec("HOV_POS_P", "position to velocity (1/s)", 0.05, 2.0, 0.5),
    spec(
        "HOV_MAX_SPEED",
        "largest correction speed (m/s)",
        0.2,
        10.0,
        2.0,
    ),
    spec("HOV_VEL_P", "velocity to acceleration (1/s)", 0.1, 5.0, 1.4),
    spec("HOV_VEL_I", "velocity integrator (1/s^2)", 0.0, 1.0, 0.15),
    spec(
        "HOV_MAX_ACC",
        "largest correction acceleration (m/s^2)",
        0.5,
        8.0,
        3.0,
    ),
    spec("HOV_MAX_TRIM", "largest wind trim (m/s^2)", 0.0, 8.0, 4.5),
    spec("HOV_MAX_TILT_RAD", "tilt limit (rad)", 0.09, 0.79, 0.52),
    spec("HOV_MAX_CLIMB", "largest climb rate (m/s)", 0.2, 3.0, 1.5),
    spec("HOV_MAX_DESC", "largest descent rate (m/s)", 0.2, 2.0, 1.0),
    spec("HOV_HDG_P", "heading to yaw rate (1/s)", 0.0, 5.0, 2.0),
    spec(
        "YAW_RATE_P",
        "tail per rad/s of yaw-rate error",
        0.0,
        0.4,
        0.3,
    ),
    spec(
        "YAW_RATE_I",
        "tail per rad of integrated yaw-rate error",
        0.0,
        1.0,
        0.15,
    ),
    spec(
        "AUG_HDG_LOCK",
        "augmented heading lock (1/s)",
        0.0,
        20.0,
        8.0,
    ),
    spec(
        "STK_SPEED",
        "velocity mode: speed at full stick (m/s)",
        0.5,
        10.0,
        5.0,
    ),
    spec(
        "STK_YAW_RATE_RPS",
        "yaw rate at full rudder (rad/s)",
        0.2,
        6.0,
        2.0,
    ),
    spec(
        "BARO_RATE_HZ",
        "altimeter readings per second",
        1.0,
        10.0,
        5.0,
    ),
];

const fn spec(
    name: &'static str,
    what: &'static str,
    min: f32,
    max: f32,
    default: f32,
) -> ParamSpec {
    ParamSpec {
        name,
        what,
        min,
        max,
        default,
    }
}

/// The table at its defaults.
pub fn defaults() -> ParamTable {
    ParamTable::new(&SPECS)
}

/// The parameter file of a log directory.
pub fn path_in(log_dir: &Path) -> PathBuf {
    log_dir.join("params")
}

/// The table of `log_dir`: the defaults with the file's values (no file: the defaults).
pub fn load(log_dir: &Path) -> Result<ParamTable, VehicleError> {
    let path = path_in(log_dir);
    let mut table = defaults();
    match std::fs::read_to_string(&path) {
        Ok(text) => table
            .load_text(&text)
            .map_err(|e| VehicleError::invalid(path.display().to_string(), e))?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(VehicleError::file(path, e)),
    }
    Ok(table)
}

/// The table of the parameter file `path`: the defaults with its values. Unlike [`load`],
/// a missing file is an error: it was named.
pub fn load_file(path: &Path) -> Result<ParamTable, VehicleError> {
    let text = std::fs::read_to_string(path).map_err(|e| VehicleError::file(path, e))?;
    let mut table = defaults();
    table
        .load_text(&text)
        .map_err(|e| VehicleError::invalid(path.display().to_string(), e))?;
    Ok(table)
}

/// Writes the table's text to `log_dir`'s file, whole (a temporary file, synced, renamed
/// over it: a parameter the operator set survives a power loss). Saved, the file may still
/// have something to say: a directory that could not be synced.
pub fn save(log_dir: &Path, text: &str) -> Result<Option<String>, VehicleError> {
    let path = path_in(log_dir);
    heli_log::replace::replace_file(&path, &log_dir.join(".params.tmp"), text.as_bytes())
        .map(|replaced| {
            replaced
                .warning()
                .map(|w| format!("{}: {w}", path.display()))
        })
        .map_err(|e| VehicleError::file(path, e))
}

/// The values of `table` in `config` (a name the table lacks keeps the config's value).
pub fn apply(table: &ParamTable, config: &mut CoreConfig) {
    let get = |name: &str, current: f64| table.get(name).map_or(current, f64::from);
    let h = &mut config.hover;
    h.pos_to_vel = get("HOV_POS_P", h.pos_to_vel);
    h.max_horizontal_speed_mps = get("HOV_MAX_SPEED", h.max_horizontal_speed_mps);
    h.vel_to_accel = get("HOV_VEL_P", h.vel_to_accel);
    h.vel_integral = get("HOV_VEL_I", h.vel_integral);
    h.max_accel_mps2 = get("HOV_MAX_ACC", h.max_accel_mps2);
    h.max_trim_accel_mps2 = get("HOV_MAX_TRIM", h.max_trim_accel_mps2);
    h.max_tilt_rad = get("HOV_MAX_TILT_RAD", h.max_tilt_rad);
    h.max_climb_mps = get("HOV_MAX_CLIMB", h.max_climb_mps);
    h.max_descent_mps = get("HOV_MAX_DESC", h.max_descent_mps);
    h.heading_to_rate = get("HOV_HDG_P", h.heading_to_rate);
    h.yaw_rate_feedback = get("YAW_RATE_P", h.yaw_rate_feedback);
    h.yaw_integral = get("YAW_RATE_I", h.yaw_integral);
    h.heading_lock_to_rate = get("AUG_HDG_LOCK", h.heading_lock_to_rate);
    let s = &mut config.sticks;
    s.speed_mps = get("STK_SPEED", s.speed_mps);
    s.yaw_rate_rps = get("STK_YAW_RATE_RPS", s.yaw_rate_rps);
}

/// The altimeter rate of `table` (readings per second).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub fn baro_rate_hz(table: &ParamTable) -> Option<u8> {
    table
        .get("BARO_RATE_HZ")
        .map(|v| v.round().clamp(1.0, 10.0) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_flight_softwares() {
        let mut config = CoreConfig::default();
        let before = config;
        apply(&defaults(), &mut config);
        // Single precision goes round: equal to 1e-6.
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6 * b.abs().max(1.0);
        assert!(close(config.hover.max_tilt_rad, before.hover.max_tilt_rad));
        assert!(close(
            config.hover.yaw_rate_feedback,
            before.hover.yaw_rate_feedback
        ));
        assert!(close(
            config.hover.heading_lock_to_rate,
            before.hover.heading_lock_to_rate
        ));
        assert!(close(
            config.sticks.yaw_rate_rps,
            before.sticks.yaw_rate_rps
        ));
        assert!(close(config.hover.vel_integral, before.hover.vel_integral));
    }

    #[test]
    fn a_value_set_reaches_the_config_and_the_file_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let mut table = load(dir.path()).unwrap();
        table.set("HOV_MAX_TILT_RAD", 0.35).unwrap();
        save(dir.path(), &table.to_text()).unwrap();
        let back = load(dir.path()).unwrap();
        let mut config = CoreConfig::default();
        apply(&back, &mut config);
        assert!((config.hover.max_tilt_rad - 0.35).abs() < 1e-6);
        std::fs::write(path_in(dir.path()), "HOV_MAX_TILT_RAD = 1.5\n").unwrap();
        let err = load(dir.path()).unwrap_err().to_string();
        assert!(err.contains("line 1") && err.contains("range"), "{err}");
    }

    #[test]
    fn a_directory_without_a_file_has_the_defaults_and_an_unreadable_one_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let table = load(dir.path()).unwrap();
        assert_eq!(table.get("HOV_MAX_SPEED"), defaults().get("HOV_MAX_SPEED"));
        std::fs::create_dir(path_in(dir.path())).unwrap();
        let e = load(dir.path()).unwrap_err().to_string();
        assert!(
            e.starts_with(&path_in(dir.path()).display().to_string()),
            "{e}"
        );
    }

    #[test]
    fn the_altimeters_rate_is_rounded_into_its_range() {
        let mut table = defaults();
        for (set, rate) in [(5.0, 5), (7.4, 7), (0.2, 1), (30.0, 10)] {
            if table.set("BARO_RATE_HZ", set).is_ok() {
                assert_eq!(baro_rate_hz(&table), Some(rate), "{set}");
            }
        }
        table.set("BARO_RATE_HZ", 7.6).unwrap();
        assert_eq!(baro_rate_hz(&table), Some(8));
    }
}
