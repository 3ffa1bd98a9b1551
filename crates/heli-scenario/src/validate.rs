//! Scenario and airframe values checked where they enter: every number finite and in a
//! physical range, every time window ordered. An error names the key (`plan[1].alt_m`,
//! `faults.gps_outages[0]`) and the allowed range, so a mistyped file is fixed at once
//! instead of panicking the simulator or being flown silently.

use serde_json::Value;

use crate::scenario::Scenario;
use heli_model::params::Airframe;

/// Longest scenario (s): a day.
pub const MAX_DURATION_S: f64 = 86_400.0;

/// What is wrong with a scenario or an airframe: each problem names its key and the
/// allowed range.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Invalid {
    /// The problems, in the order of the keys.
    pub problems: Vec<String>,
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.problems.join("; "))
    }
}

impl std::error::Error for Invalid {}

/// `Ok` without problems, the problems otherwise.
fn verdict(problems: Vec<String>) -> Result<(), Invalid> {
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Invalid { problems })
    }
}

/// What is wrong with a value.
fn out_of_range(key: &str, value: f64, min: f64, max: f64) -> String {
    format!("{key} = {value}: must be from {min} to {max}")
}

/// The allowed range of a scenario key (by its last name and, where names repeat, its
/// place), if it has one beyond being finite.
fn range_of(path: &str, name: &str) -> Option<(f64, f64)> {
    let in_plan = path.starts_with("plan[");
    Some(match name {
        "duration_s" if path == "duration_s" => (1e-3, MAX_DURATION_S),
        "duration_s" => (1e-3, MAX_DURATION_S),
        "wind_ned_mps" => (-30.0, 30.0),
        "turbulence_sigma_mps" => (0.0, 10.0),
        "wind_shear_mps_per_m" => (-1.0, 1.0),
        "density_kgpm3" => (0.3, 1.6),
        "gravity_mps2" => (9.0, 10.5),
        "ground_pressure_mbar" => (300.0, 1100.0),
        "temperature_c" => (-60.0, 60.0),
        "imu_drop_rate" => (0.0, 1.0),
        "aileron" | "elevator" | "rudder" | "collective" => (-1.0, 1.0),
        "throttle" => (0.0, 1.0),
        "amplitude" => (-1.0, 1.0),
        "start_s" => (0.0, MAX_DURATION_S),
        "f0_hz" | "f1_hz" => (0.0, 50.0),
        "alt_m" if in_plan => (0.5, 500.0),
        "north_m" | "east_m" => (-10_000.0, 10_000.0),
        "speed_mps" if in_plan => (0.1, 30.0),
        "seconds" => (0.0, MAX_DURATION_S),
        "count" => (1.0, 10.0),
        "satellites" => (0.0, 32.0),
        "rate" => (0.0, 1.0),
        "duty" => (0.0, 1.0),
        "period_s" => (0.0, MAX_DURATION_S),
        "power" => (0.0, 1.0),
        "capacity_ah" => (0.01, 100.0),
        "charge" => (0.0, 1.0),
        "load_a" => (0.0, 100.0),
        "cycles" => (0.0, 10_000.0),
        "health" => (0.01, 1.5),
        "extra_a" => (0.0, 100.0),
        "ground_until_s" => (0.0, MAX_DURATION_S),
        "told_temperature_c" => (-60.0, 60.0),
        "factor" => (0.0, 1.0),
        "end_s" => (0.0, MAX_DURATION_S),
        // Limits: non-negative, finite.
        _ if path.starts_with("limits.") => (0.0, 1e9),
        _ => return None,
    })
}

/// Checks a scenario; the error names the key and the allowed range.
pub fn scenario(s: &Scenario) -> Result<(), Invalid> {
    let value = serde_json::to_value(s).map_err(|e| Invalid {
        problems: vec![e.to_string()],
    })?;
    let mut errors = Vec::new();
    if let Value::Object(map) = &value {
        for (key, v) in map {
            if key == "airframe" {
                continue;
            }
            walk(key, key, v, &mut errors);
        }
    }
    for (name, windows) in [
        ("faults.gps_outages", &s.faults.gps_outages),
        ("faults.transmitter_lost", &s.faults.transmitter_lost),
        ("faults.uplink_silent", &s.faults.uplink_silent),
        ("faults.imu_silent", &s.faults.imu_silent),
        ("faults.baro_silent", &s.faults.baro_silent),
        ("faults.compass_silent", &s.faults.compass_silent),
        ("faults.imu_stuck", &s.faults.imu_stuck),
        ("faults.brownouts", &s.faults.brownouts),
        ("pilot.auto_flipped", &s.pilot.auto_flipped),
        ("pilot.bypass", &s.pilot.bypass),
    ] {
        for (i, [start, end]) in windows.iter().enumerate() {
            if !(start.is_finite() && end.is_finite() && *start >= 0.0 && start < end) {
                errors.push(format!(
                    "{name}[{i}] = [{start}, {end}]: a window is [start, end) in seconds with 0 <= start < end"
                ));
            }
        }
    }
    let f = &s.faults;
    if let Some(phase) = &f.timed_from
        && !crate::fault_timing::PHASES.contains(&phase.as_str())
    {
        errors.push(format!(
            "faults.timed_from = {phase:?}: not a phase of the flight software (one of {})",
            crate::fault_timing::PHASES.join(", ")
        ));
    }
    let spans = f
        .gps_glitches
        .iter()
        .map(|g| ("faults.gps_glitches", g.start_s, g.end_s))
        .chain(
            f.gps_satellites
                .iter()
                .map(|g| ("faults.gps_satellites", g.start_s, g.end_s)),
        )
        .chain(
            f.byte_loss
                .iter()
                .map(|g| ("faults.byte_loss", g.start_s, g.end_s)),
        )
        .chain(
            f.devices
                .iter()
                .map(|g| ("faults.devices", g.start_s, g.end_s)),
        )
        .chain(
            f.servos
                .iter()
                .map(|g| ("faults.servos", g.start_s, g.end_s)),
        )
        .chain(
            f.engine
                .iter()
                .map(|g| ("faults.engine", g.start_s, g.end_s)),
        )
        .chain(
            f.battery_drains
                .iter()
                .map(|g| ("faults.battery_drains", g.start_s, g.end_s)),
        )
        .chain(
            f.rc_frozen
                .iter()
                .map(|g| ("faults.rc_frozen", g.start_s, g.end_s)),
        )
        .chain(
            f.switch_flicker
                .iter()
                .map(|g| ("faults.switch_flicker", g.start_s, g.end_s)),
        );
    for (name, start, end) in spans {
        if !(start.is_finite() && end.is_finite() && start >= 0.0 && start < end) {
            errors.push(format!(
                "{name}: start_s = {start}, end_s = {end}: need 0 <= start_s < end_s"
            ));
        }
    }
    for (i, b) in f.byte_loss.iter().enumerate() {
        if heli_types::Port::from_name(&b.port).is_none() {
            errors.push(format!(
                "faults.byte_loss[{i}].port = '{}': must be imu, scb, gps or baro",
                b.port
            ));
        }
    }
    device_faults(&f.devices, &mut errors);
    for (i, w) in s.wind_changes.iter().enumerate() {
        let timed = w.shape != crate::faults::WindShape::Step;
        if timed && w.start_s >= w.end_s {
            errors.push(format!(
                "wind_changes[{i}]: start_s = {}, end_s = {}: a gust or ramp needs start_s < end_s",
                w.start_s, w.end_s
            ));
        }
    }
    for (i, servo) in f.servos.iter().enumerate() {
        if servo.kind == crate::faults::ServoFaultKind::Slow
            && !(servo.factor > 0.0 && servo.factor < 1.0)
        {
            errors.push(format!(
                "faults.servos[{i}].factor = {}: a slowed servo needs 0 < factor < 1",
                servo.factor
            ));
        }
    }
    for (i, flicker) in f.switch_flicker.iter().enumerate() {
        if flicker.period_s.is_nan() || flicker.period_s <= 0.0 {
            errors.push(format!(
                "faults.switch_flicker[{i}].period_s = {}: must be above 0",
                flicker.period_s
            ));
        }
    }
    if let Err(e) = airframe(&s.airframe) {
        errors.extend(e.problems);
    }
    verdict(errors)
}

/// Each device fault's amount, by kind: an error names the fault, the key and the range.
fn device_faults(faults: &[crate::faults::DeviceFault], errors: &mut Vec<String>) {
    use crate::faults::{Device, DeviceFaultKind as K};
    for (i, f) in faults.iter().enumerate() {
        let key = |name: &str| {
            format!(
                "faults.devices[{i}].{name} ({} {})",
                f.device.name(),
                f.kind.name()
            )
        };
        let adc = matches!(f.device, Device::Compass | Device::Battery);
        let (name, value, min, max) = match f.kind {
            K::Off | K::Stuck => continue,
            K::Garbage => ("rate", f.rate, 1e-9, 1.0),
            K::Bias => ("value", f.value, -1e4, 1e4),
            K::Scale => ("value", f.value, 0.0, 10.0),
            K::Spikes => {
                if !(f.rate > 0.0 && f.rate <= 1.0) {
                    errors.push(out_of_range(&key("rate"), f.rate, 1e-9, 1.0));
                }
                ("value", f.value, 1e-9, 1e4)
            }
            K::Slow => ("value", f.value, 2.0, 1000.0),
            K::Delayed if adc => {
                errors.push(format!(
                    "{}: an ADC channel is read when the computer asks; it cannot arrive late",
                    key("kind")
                ));
                continue;
            }
            K::Delayed => ("value", f.value, 1e-3, 10.0),
        };
        if !(value >= min && value <= max) {
            errors.push(out_of_range(&key(name), value, min, max));
        }
        if f.period_s > 0.0 && !(f.duty > 0.0 && f.duty <= 1.0) {
            errors.push(out_of_range(&key("duty"), f.duty, 1e-9, 1.0));
        }
    }
}

/// Keys left unset on purpose: the temperature told to the flight software (then the
/// flight pack's).
fn unset_allowed(path: &str) -> bool {
    path == "power.told_temperature_c" || path == "faults.timed_from"
}

/// Walks a value: every number must be finite and within its key's range.
fn walk(path: &str, name: &str, v: &Value, errors: &mut Vec<String>) {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            match range_of(path, name) {
                Some((min, max)) if !(x >= min && x <= max) => {
                    errors.push(out_of_range(path, x, min, max));
                }
                _ => {}
            }
        }
        // serde_json writes a non-finite f64 as null: a NaN or an infinity in the file.
        Value::Null
            if !path.starts_with("limits.")
                && !path.ends_with("target")
                && !unset_allowed(path) =>
        {
            errors.push(format!("{path}: must be a finite number"));
        }
        Value::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                walk(&format!("{path}[{i}]"), name, item, errors);
            }
        }
        Value::Object(map) => {
            for (k, item) in map {
                walk(&format!("{path}.{k}"), k, item, errors);
            }
        }
        _ => {}
    }
}

/// Where a skid point may be (m, body axes from the centre of gravity: x forward, y right,
/// z down): below the centre of gravity, within a helicopter's reach of it. The X-Cell 60's
/// are 0.2-0.25 m fore and aft, 0.22 m to the sides, 0.35 m below.
const SKID_RANGES_M: [(f64, f64); 3] = [(-1.0, 1.0), (-0.6, 0.6), (0.1, 1.0)];

/// The skid points: each coordinate in its range, and a footprint the helicopter can stand
/// on (the centre of gravity between the front and rear points and between the left and
/// right ones).
fn skids(points: &[[f64; 3]; 4]) -> Vec<String> {
    let mut errors = Vec::new();
    for (i, point) in points.iter().enumerate() {
        for (axis, (&x, &(min, max))) in point.iter().zip(&SKID_RANGES_M).enumerate() {
            if !(x >= min && x <= max) {
                let path = format!("airframe.skid_points_m[{i}][{axis}]");
                let why = match axis {
                    2 => "below the centre of gravity (z down), at most 1 m",
                    _ => "within reach of the centre of gravity",
                };
                errors.push(format!("{} ({why})", out_of_range(&path, x, min, max)));
            }
        }
    }
    if errors.is_empty() {
        for (axis, name) in [(0, "fore and aft"), (1, "left and right")] {
            let lo = points.iter().map(|p| p[axis]).fold(f64::INFINITY, f64::min);
            let hi = points
                .iter()
                .map(|p| p[axis])
                .fold(f64::NEG_INFINITY, f64::max);
            if !(lo < 0.0 && hi > 0.0) {
                errors.push(format!(
                    "airframe.skid_points_m: the skids must reach {name} of the centre of gravity \
                     (from {lo} to {hi} m), or the helicopter cannot stand on them"
                ));
            }
        }
    }
    errors
}

/// Checks an airframe: every parameter finite, with the sign of the X-Cell 60's, and within
/// a tenth to ten times its value (a parameter the X-Cell has at 0 may be up to 1 either
/// way); the skid points within their physical ranges ([`SKID_RANGES_M`]).
pub fn airframe(a: &Airframe) -> Result<(), Invalid> {
    let problem = |e: serde_json::Error| Invalid {
        problems: vec![e.to_string()],
    };
    let given = serde_json::to_value(a).map_err(problem)?;
    let reference = serde_json::to_value(Airframe::default()).map_err(problem)?;
    let (Value::Object(given), Value::Object(reference)) = (given, reference) else {
        return Ok(());
    };
    let mut errors = skids(&a.skid_points_m);
    for (key, v) in &given {
        let path = format!("airframe.{key}");
        let Some(x) = v.as_f64() else {
            if v.is_null() {
                errors.push(format!("{path}: must be a finite number"));
            }
            continue;
        };
        let Some(d) = reference.get(key).and_then(Value::as_f64) else {
            continue;
        };
        let (min, max) = if d == 0.0 {
            (-1.0, 1.0)
        } else if d > 0.0 {
            (d / 10.0, d * 10.0)
        } else {
            (d * 10.0, d / 10.0)
        };
        if !(x >= min && x <= max) {
            errors.push(format!(
                "{} (the X-Cell 60 has {d}: a tenth to ten times that, same sign)",
                out_of_range(&path, x, min, max)
            ));
        }
    }
    verdict(errors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{builtins, from_toml};

    #[test]
    fn every_builtin_scenario_is_valid() {
        for s in builtins() {
            assert_eq!(scenario(&s), Ok(()), "{}", s.name);
        }
    }

    #[test]
    fn bad_values_name_their_key_and_range() {
        let cases = [
            ("duration_s = -5.0", "duration_s = -5"),
            ("wind_ned_mps = [1e9, 0.0, 0.0]", "wind_ned_mps[0]"),
            ("wind_ned_mps = [nan, 0.0, 0.0]", "wind_ned_mps[0]"),
            ("[faults]\nimu_drop_rate = 2.0", "faults.imu_drop_rate = 2"),
            (
                "[faults]\ngps_outages = [[130.0, 120.0]]",
                "faults.gps_outages[0]",
            ),
            ("[pilot]\ncollective = 5.0", "pilot.collective = 5"),
            (
                "[atmosphere]\ndensity_kgpm3 = -1.0",
                "atmosphere.density_kgpm3",
            ),
            ("[airframe]\nmass_kg = 0.0", "airframe.mass_kg = 0"),
            (
                "[airframe]\nskid_points_m = [[0.25, -0.22, 3.5], [0.25, 0.22, 0.35], [-0.2, -0.22, 0.35], [-0.2, 0.22, 0.35]]",
                "airframe.skid_points_m[0][2] = 3.5",
            ),
            (
                "[airframe]\nskid_points_m = [[1e300, -0.22, 0.35], [0.25, 0.22, 0.35], [-0.2, -0.22, 0.35], [-0.2, 0.22, 0.35]]",
                "airframe.skid_points_m[0][0]",
            ),
            (
                "[airframe]\nskid_points_m = [[0.25, -0.22, -0.35], [0.25, 0.22, -0.35], [-0.2, -0.22, -0.35], [-0.2, 0.22, -0.35]]",
                "below the centre of gravity",
            ),
            (
                "[airframe]\nskid_points_m = [[0.25, 0.1, 0.35], [0.25, 0.22, 0.35], [-0.2, 0.1, 0.35], [-0.2, 0.22, 0.35]]",
                "left and right of the centre of gravity",
            ),
            ("[airframe]\nmass_kg = nan", "airframe.mass_kg"),
            ("[[plan]]\nleg = \"takeoff\"\nalt_m = -3.0", "plan[0].alt_m"),
            ("[limits]\nhold_min_s = -1.0", "limits.hold_min_s"),
            (
                "[[faults.devices]]\ndevice = \"imu\"\nkind = \"slow\"\nstart_s = 1.0\nend_s = 2.0\nvalue = 1.0",
                "faults.devices[0].value (imu slow) = 1: must be from 2 to 1000",
            ),
            (
                "[[faults.devices]]\ndevice = \"compass\"\nkind = \"delayed\"\nstart_s = 1.0\nend_s = 2.0\nvalue = 0.1",
                "cannot arrive late",
            ),
            (
                "[[faults.devices]]\ndevice = \"gps\"\nkind = \"spikes\"\nstart_s = 1.0\nend_s = 2.0\nvalue = 5.0",
                "faults.devices[0].rate (gps spikes)",
            ),
            (
                "[[faults.devices]]\ndevice = \"gps\"\nkind = \"off\"\nstart_s = 1.0\nend_s = 2.0\nduty = 1.5",
                "faults.devices[0].duty",
            ),
            (
                "[[faults.devices]]\ndevice = \"sonar\"\nkind = \"off\"\nstart_s = 1.0\nend_s = 2.0",
                "sonar",
            ),
            (
                "[[faults.servos]]\nchannel = \"aileron\"\nkind = \"slow\"\nstart_s = 1.0\nend_s = 2.0\nfactor = 0.0",
                "faults.servos[0].factor",
            ),
            (
                "[[faults.engine]]\nstart_s = 1.0\nend_s = 2.0\npower = 1.5",
                "faults.engine[0].power",
            ),
            ("[faults]\nbrownouts = [[5.0, 2.0]]", "faults.brownouts[0]"),
            (
                "[[wind_changes]]\nshape = \"ramp\"\nstart_s = 5.0\nend_s = 5.0\nwind_ned_mps = [1.0, 0.0, 0.0]",
                "wind_changes[0]",
            ),
            (
                "[[wind_changes]]\nshape = \"gust\"\nstart_s = 5.0\nend_s = 6.0\nwind_ned_mps = [100.0, 0.0, 0.0]",
                "wind_changes[0].wind_ned_mps[0]",
            ),
            (
                "wind_shear_mps_per_m = [3.0, 0.0, 0.0]",
                "wind_shear_mps_per_m[0]",
            ),
            (
                "[[faults.switch_flicker]]\nswitch = \"auto\"\nstart_s = 1.0\nend_s = 2.0\nperiod_s = 0.0",
                "faults.switch_flicker[0].period_s",
            ),
        ];
        for (text, key) in cases {
            let e = from_toml(text).map(|_| ()).unwrap_err().to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
    }
}
