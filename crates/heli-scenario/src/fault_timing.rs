//! Fault times counted from a phase of the flight: `faults.timed_from = "accelerate"` puts a
//! fault at a moment *of the manoeuvre* (its run-up, pull-up, roll, recovery) wherever the
//! manoeuvre falls in the run. In wind, or after a slower calibration, the rolls begin
//! seconds later than in calm air, and a fault placed at an absolute time meant for the
//! middle of a roll can fall before the rolls begin, judging a flight that never rolled.
//!
//! The simulation holds every timed fault back (shifted past any run's end) until the
//! flight software first enters the named phase at `t0`, then acts on the faults shifted by
//! `t0` ([`Faults::shifted`]). The IMU's drop rate has no time and acts from the start.

use crate::faults::Faults;

/// The phases a scenario's faults can be timed from: any of the flight software's.
pub use heli_types::phases::PHASES;

/// Far beyond any run's end (s): where timed faults wait until their phase begins.
pub const NOT_YET_S: f64 = 1.0e9;

impl Faults {
    /// The same faults with every start and end moved `dt_s` later (windows, glitches,
    /// forced satellites, byte losses, device, servo and engine faults, drains, brown-outs,
    /// frozen channels, flickering switches). Durations, periods, rates and values stay.
    #[must_use]
    pub fn shifted(&self, dt_s: f64) -> Faults {
        let windows = |w: &[[f64; 2]]| -> Vec<[f64; 2]> {
            w.iter().map(|[a, b]| [a + dt_s, b + dt_s]).collect()
        };
        let mut f = self.clone();
        for w in [
            &mut f.gps_outages,
            &mut f.transmitter_lost,
            &mut f.uplink_silent,
            &mut f.imu_silent,
            &mut f.baro_silent,
            &mut f.compass_silent,
            &mut f.imu_stuck,
            &mut f.brownouts,
        ] {
            *w = windows(w);
        }
        let mut spans: Vec<(&mut f64, &mut f64)> = Vec::new();
        spans.extend(
            f.gps_glitches
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        spans.extend(
            f.gps_satellites
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        spans.extend(
            f.byte_loss
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        spans.extend(f.devices.iter_mut().map(|x| (&mut x.start_s, &mut x.end_s)));
        spans.extend(f.servos.iter_mut().map(|x| (&mut x.start_s, &mut x.end_s)));
        spans.extend(f.engine.iter_mut().map(|x| (&mut x.start_s, &mut x.end_s)));
        spans.extend(
            f.battery_drains
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        spans.extend(
            f.rc_frozen
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        spans.extend(
            f.switch_flicker
                .iter_mut()
                .map(|x| (&mut x.start_s, &mut x.end_s)),
        );
        for (start, end) in spans {
            *start += dt_s;
            *end += dt_s;
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use serde_json::Value;

    /// Every number of `before` and `after`, by its path, side by side.
    fn numbers(path: &str, before: &Value, after: &Value, out: &mut Vec<(String, f64, f64)>) {
        match (before, after) {
            (Value::Object(a), Value::Object(b)) => {
                for (k, v) in a {
                    numbers(&format!("{path}.{k}"), v, &b[k], out);
                }
            }
            (Value::Array(a), Value::Array(b)) => {
                for (i, (x, y)) in a.iter().zip(b).enumerate() {
                    numbers(&format!("{path}[{i}]"), x, y, out);
                }
            }
            (Value::Number(a), Value::Number(b)) => {
                out.push((path.to_string(), a.as_f64().unwrap(), b.as_f64().unwrap()));
            }
            _ => {}
        }
    }

    #[test]
    fn every_start_and_end_moves_and_nothing_else_does() {
        // One fault of every kind the catalog has, from the scenario files' own syntax.
        let s = crate::from_toml(
            r#"
            base = "hover"
            [faults]
            imu_drop_rate = 0.01
            gps_outages = [[10.0, 12.0]]
            transmitter_lost = [[11.0, 13.0]]
            uplink_silent = [[12.0, 14.0]]
            imu_silent = [[13.0, 14.0]]
            baro_silent = [[14.0, 15.0]]
            compass_silent = [[15.0, 16.0]]
            imu_stuck = [[16.0, 17.0]]
            brownouts = [[17.0, 18.0]]
            gps_glitches = [{ start_s = 20.0, end_s = 24.0, north_m = 5.0, east_m = 6.0 }]
            gps_satellites = [{ start_s = 21.0, end_s = 25.0, satellites = 3 }]
            byte_loss = [{ port = "imu", start_s = 22.0, end_s = 26.0, rate = 0.2 }]
            devices = [{ device = "imu", kind = "spikes", start_s = 23.0, end_s = 27.0, value = 3.0, rate = 0.5, period_s = 2.0, duty = 0.5 }]
            servos = [{ channel = "rudder", kind = "slow", start_s = 24.0, end_s = 28.0, factor = 0.3 }]
            engine = [{ start_s = 25.0, end_s = 29.0, power = 0.2 }]
            battery_drains = [{ battery = "flight", start_s = 26.0, end_s = 30.0, extra_a = 4.0 }]
            rc_frozen = [{ channel = "collective", start_s = 27.0, end_s = 31.0 }]
            switch_flicker = [{ switch = "auto", start_s = 28.0, end_s = 32.0, period_s = 1.0 }]
            "#,
        )
        .unwrap();
        assert!(
            crate::from_toml("base = \"hover\"\n[faults]\ntimed_from = \"rolls\"")
                .is_err_and(|e| e.to_string().contains("not a phase")),
            "an unknown phase is refused"
        );
        let before = serde_json::to_value(&s.faults).unwrap();
        let after = serde_json::to_value(s.faults.shifted(100.0)).unwrap();
        let mut all = Vec::new();
        numbers("faults", &before, &after, &mut all);
        // Every kind is in the file (a kind added to the catalog must be added here and to
        // `shifted`): each of the catalog's fields but the drop rate holds a time.
        let kinds = before.as_object().unwrap();
        for (kind, v) in kinds {
            let present = v.is_number() || v.as_array().is_some_and(|a| !a.is_empty());
            assert!(
                present || kind == "timed_from",
                "faults.{kind} is not in the test's file"
            );
        }
        let mut moved = 0;
        for (path, a, b) in &all {
            let time = path.ends_with(".start_s")
                || path.ends_with(".end_s")
                || (path.ends_with("[0]") || path.ends_with("[1]"))
                    && !path.contains("devices")
                    && !path.contains("byte_loss");
            if time {
                assert_eq!(*b, a + 100.0, "{path} did not move");
                moved += 1;
            } else {
                assert_eq!(a, b, "{path} moved");
            }
        }
        assert_eq!(moved, 2 * 17, "{all:?}");
    }
}
