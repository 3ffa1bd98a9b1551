//! Scenario files are checked where they enter: whatever a file says, loading it and flying
//! it never panics; a bad value is an error naming its key.

use heli_scenario::from_toml;
use heli_sim::lockstep::{RunOptions, Simulation};
use proptest::prelude::*;

/// Keys a scenario file may set, with how to write a value for each.
const KEYS: &[&str] = &[
    "duration_s",
    "wind_ned_mps",
    "turbulence_sigma_mps",
    "atmosphere.density_kgpm3",
    "atmosphere.gravity_mps2",
    "atmosphere.ground_pressure_mbar",
    "atmosphere.temperature_c",
    "airframe.mass_kg",
    "airframe.mr_radius_m",
    "airframe.skid_points_m",
    "wind_shear_mps_per_m",
    "faults.imu_drop_rate",
    "faults.gps_outages",
    "pilot.collective",
    "pilot.throttle",
    "limits.hold_min_s",
];

fn number() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(-f64::INFINITY),
        Just(0.0),
        Just(-1.0),
        Just(1e300),
        -1e3..1e3f64,
        -2.0..2.0f64,
    ]
}

fn toml_number(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{x:?}")
    }
}

fn file() -> impl Strategy<Value = String> {
    prop::collection::vec((0..KEYS.len(), number(), number()), 1..5).prop_map(|sets| {
        let mut top = String::new();
        let mut tables: std::collections::BTreeMap<&str, String> = Default::default();
        for (k, a, b) in sets {
            let key = KEYS[k];
            let value = match key {
                "wind_ned_mps" => format!("[{}, {}, 0.0]", toml_number(a), toml_number(b)),
                "faults.gps_outages" => format!("[[{}, {}]]", toml_number(a), toml_number(b)),
                "wind_shear_mps_per_m" => format!("[{}, 0.0, {}]", toml_number(a), toml_number(b)),
                // One point's fore-aft place and the depth of another, anything at all.
                "airframe.skid_points_m" => format!(
                    "[[{}, -0.22, 0.35], [0.25, 0.22, {}], [-0.2, -0.22, 0.35], [-0.2, 0.22, 0.35]]",
                    toml_number(a),
                    toml_number(b)
                ),
                _ => toml_number(a),
            };
            match key.split_once('.') {
                Some((table, name)) => {
                    let t = tables.entry(table).or_default();
                    if !t.contains(&format!("{name} =")) {
                        t.push_str(&format!("{name} = {value}\n"));
                    }
                }
                None if !top.contains(&format!("{key} =")) => {
                    top.push_str(&format!("{key} = {value}\n"))
                }
                None => {}
            }
        }
        for (table, body) in tables {
            top.push_str(&format!("[{table}]\n{body}"));
        }
        top
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn any_scenario_file_loads_or_says_why_and_never_panics(text in file()) {
        match from_toml(&text) {
            Ok(s) => {
                // Accepted: it must fly (briefly) without a panic.
                let sim = Simulation::new(s);
                prop_assert!(sim.is_ok(), "{text}");
                if let Ok(sim) = sim {
                    let options = RunOptions { realtime: false, duration_s: Some(1.0) };
                    let summary = sim.run(options, |_, _| {});
                    prop_assert!(summary.sim_time_s <= 1.01);
                }
            }
            Err(e) => {
                let e = e.to_string();
                prop_assert!(!e.is_empty(), "{text}");
            }
        }
    }
}

#[test]
fn the_edges_of_every_range_fly_without_a_panic() {
    // Accepted values at the ends of their ranges: the model must take them.
    for text in [
        "wind_ned_mps = [30.0, -30.0, 30.0]\nturbulence_sigma_mps = 10.0",
        "[airframe]\nmass_kg = 0.82",
        "[airframe]\nmass_kg = 82.0",
        "[atmosphere]\ndensity_kgpm3 = 0.3\ntemperature_c = -60.0",
        "[atmosphere]\ndensity_kgpm3 = 1.6\nground_pressure_mbar = 300.0",
        "[faults]\nimu_drop_rate = 1.0",
        "[pilot]\ncollective = 1.0\nthrottle = 1.0",
        "duration_s = 0.001",
        "[airframe]\nskid_points_m = [[1.0, -0.6, 1.0], [1.0, 0.6, 1.0], [-1.0, -0.6, 1.0], [-1.0, 0.6, 1.0]]",
        "[airframe]\nskid_points_m = [[0.05, -0.05, 0.1], [0.05, 0.05, 0.1], [-0.05, -0.05, 0.1], [-0.05, 0.05, 0.1]]",
    ] {
        let s = from_toml(text).unwrap_or_else(|e| panic!("{text}: {e}"));
        let sim = Simulation::new(s).unwrap_or_else(|e| panic!("{text}: {e}"));
        let options = RunOptions {
            realtime: false,
            duration_s: Some(3.0),
        };
        let summary = sim.run(options, |_, _| {});
        assert!(summary.sim_time_s <= 3.01, "{text}");
    }
}
