//! Unit tests of campaigns: loading and its errors, sampling and shards here; running,
//! reports, merge and plots in [`run`].

use std::collections::BTreeSet;
use std::path::Path;

use super::*;

mod run;

/// A campaign of flights two simulated seconds long on the ground (milliseconds each).
pub(super) const SHORT: &str = r#"
name = "unit"
base = "no-gps-takeoff"
seed = 11
samples = 4
[scenario]
duration_s = 2.0
mode = "manual"
expect_events = []
[scenario.pilot]
auto = false
hovers_in_manual = false
[[vary]]
key = "wind_ned_mps.0"
uniform = [-5.0, 5.0]
[[vary]]
key = "airframe.mass_kg"
normal = { mean = 8.2, sigma = 0.5, min = 7.5, max = 9.0 }
[[vary]]
key = "turbulence_sigma_mps"
grid = [0.0, 1.0, 2.0]
[[vary]]
key = "mode"
choice = ["manual", "rate"]
[[vary]]
key = "pilot.collective"
grid = [0.0, 0.5]
"#;

fn load(text: &str) -> Result<Campaign, CampaignError> {
    Campaign::from_toml(text, "unit.toml", Path::new("."))
}

pub(super) fn campaign(text: &str) -> Campaign {
    load(text).unwrap_or_else(|e| panic!("{e}"))
}

fn error_of(text: &str) -> String {
    match load(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn flight(c: &Campaign, i: u64) -> Flight {
    c.flight(i).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn grids_times_samples_and_the_last_grid_fastest() {
    let c = campaign(SHORT);
    assert_eq!(c.grid_points(), 6);
    assert_eq!(c.flights_total(), 24);
    let mut points = BTreeSet::new();
    for i in 0..24 {
        let f = flight(&c, i);
        let turbulence = f.values["turbulence_sigma_mps"].as_f64().unwrap_or(-1.0);
        let collective = f.values["pilot.collective"].as_f64().unwrap_or(-1.0);
        // Flights 0-3 at point 0, 4-7 at point 1, ...; collective (the last grid) fastest.
        let point = i / 4;
        assert_eq!(
            turbulence,
            [0.0, 1.0, 2.0][(point / 2) as usize],
            "flight {i}"
        );
        assert_eq!(collective, [0.0, 0.5][(point % 2) as usize], "flight {i}");
        points.insert((turbulence.to_bits(), collective.to_bits()));
    }
    assert_eq!(points.len(), 6, "every grid point flown");
    assert!(c.flight(24).is_err(), "no flight 24");
}

#[test]
fn sampling_is_a_function_of_the_file_and_the_index() {
    let a = campaign(SHORT);
    let b = campaign(SHORT);
    let forwards: Vec<Flight> = (0..24).map(|i| flight(&a, i)).collect();
    let backwards: Vec<Flight> = (0..24).rev().map(|i| flight(&b, i)).collect();
    for (f, g) in forwards.iter().zip(backwards.iter().rev()) {
        assert_eq!(f, g, "flight {} drawn twice differs", f.index);
    }
    // Shards draw the same flights as the whole campaign.
    for shard in ["0/3", "1/3", "2/3"] {
        let s: Shard = shard.parse().unwrap_or(Shard::ALL);
        for i in (0..24).filter(|i| s.contains(*i)) {
            assert_eq!(flight(&a, i), forwards[i as usize]);
        }
    }
    // Draws differ between flights and stay in their ranges.
    let seeds: BTreeSet<u64> = forwards.iter().map(|f| f.seed).collect();
    assert_eq!(seeds.len(), 24, "each flight its own seed");
    let winds: BTreeSet<u64> = forwards
        .iter()
        .map(|f| {
            f.values["wind_ned_mps.0"]
                .as_f64()
                .unwrap_or(99.0)
                .to_bits()
        })
        .collect();
    assert_eq!(winds.len(), 24);
    let modes: BTreeSet<String> = forwards
        .iter()
        .map(|f| f.values["mode"].as_str().unwrap_or("?").to_string())
        .collect();
    assert_eq!(modes.len(), 2, "both choices drawn: {modes:?}");
    for f in &forwards {
        assert!(f.seed < 1 << 63);
        let wind = f.values["wind_ned_mps.0"].as_f64().unwrap_or(99.0);
        assert!((-5.0..5.0).contains(&wind), "{wind}");
        let mass = f.values["airframe.mass_kg"].as_f64().unwrap_or(0.0);
        assert!((7.5..=9.0).contains(&mass), "{mass}");
        // The values reach the scenario, through the scenario file's path.
        let s = f.scenario().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.wind_ned_mps[0], wind);
        assert_eq!(s.airframe.mass_kg, mass);
        assert_eq!(s.seed, f.seed);
        assert_eq!(s.name, format!("unit-{}", f.index));
        assert_eq!(s.duration_s, 2.0, "[scenario] applied");
    }
    // Another campaign seed draws other flights.
    let other = campaign(&SHORT.replace("seed = 11", "seed = 12"));
    assert_ne!(flight(&other, 0).values, forwards[0].values);
}

#[test]
fn windows_seeds_and_integers() {
    let c = campaign(
        r#"
name = "w"
base = "rolls"
samples = 5
[scenario]
faults.gps_outages = [[100.0, 110.0]]
limits.pos_err_rms_max_m = "unset"
[[vary]]
key = "faults.gps_outages[0]"
uniform = [90.0, 150.0]
length_s = 5.0
[[vary]]
key = "plan.2.count"
uniform = [1.0, 3.0]
[[vary]]
key = "seed"
grid = [7, 8]
"#,
    );
    assert_eq!(c.flights_total(), 10);
    for i in 0..10 {
        let f = flight(&c, i);
        let s = f.scenario().unwrap_or_else(|e| panic!("{e}"));
        let start = f.values["faults.gps_outages[0]"].as_f64().unwrap_or(0.0);
        assert!((90.0..150.0).contains(&start));
        assert_eq!(s.faults.gps_outages, vec![[start, start + 5.0]]);
        assert_eq!(
            s.seed,
            [7, 8][(i / 5) as usize],
            "a varied seed is the seed"
        );
        assert_eq!(f.seed, s.seed);
        let count = f.values["plan.2.count"].as_i64().unwrap_or(0);
        assert!((1..=3).contains(&count), "{count}");
        assert!(
            matches!(s.plan[2], heli_scenario::Leg::Rolls { count: n, .. } if i64::from(n) == count)
        );
        // What --write-scenario writes flies the same scenario, limits of the base included.
        let text = f
            .scenario_file_text(&c.root_base(), "# test\n")
            .unwrap_or_else(|e| panic!("{e}"));
        let again = heli_scenario::from_toml(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(again, s);
        let mut limits = heli_scenario::rolls().limits;
        limits.pos_err_rms_max_m = None;
        assert_eq!(again.limits, limits, "an unset limit stays unset");
    }
}

#[test]
fn load_errors_name_the_key_and_the_range() {
    let base = "name = \"e\"\nbase = \"hover\"\n";
    let cases: &[(&str, &[&str])] = &[
        (
            "[[vary]]\nkey = \"wind_ned_mps.0\"\nuniform = [nan, 1.0]\n",
            &["vary[0]", "wind_ned_mps.0", "finite"],
        ),
        (
            "[[vary]]\nkey = \"wind_ned_mps.0\"\nuniform = [5.0, 1.0]\n",
            &["wind_ned_mps.0", "[5, 1]", "min < max"],
        ),
        (
            "[[vary]]\nkey = \"wind_ned_mps.0\"\nuniform = [0.0, 40.0]\n",
            &["wind_ned_mps.0", "uniform max", "-30 to 30"],
        ),
        (
            "[[vary]]\nkey = \"airframe.mass_kilos\"\nuniform = [1.0, 2.0]\n",
            &["airframe.mass_kilos", "no field \"mass_kilos\"", "mass_kg"],
        ),
        (
            "[[vary]]\nkey = \"faults.gps_outages.0\"\nuniform = [1.0, 2.0]\nlength_s = 1.0\n",
            &["faults.gps_outages.0", "0 entries"],
        ),
        ("samples = 0\n", &["samples = 0", "from 1"]),
        (
            "[[vary]]\nkey = \"turbulence_sigma_mps\"\nnormal = { mean = 1.0, sigma = 0.0 }\n",
            &["turbulence_sigma_mps", "sigma = 0", "more than 0"],
        ),
        (
            "[[vary]]\nkey = \"turbulence_sigma_mps\"\nnormal = { mean = 1.0, sigma = 0.5 }\n",
            &["turbulence_sigma_mps", "4 sigma", "normal.min", "0 to 10"],
        ),
        (
            "[[vary]]\nkey = \"mode\"\nuniform = [0.0, 1.0]\n",
            &["mode", "only grid or choice"],
        ),
        (
            "[[vary]]\nkey = \"mode\"\nchoice = [\"autonomous\", \"loop\"]\n",
            &["mode", "value 1", "loop"],
        ),
        (
            "[[vary]]\nkey = \"wind_ned_mps.1\"\nunifrom = [0.0, 1.0]\n",
            &["unifrom"],
        ),
        (
            "[[vary]]\nkey = \"duration_s\"\ngrid = [10.0]\n[[vary]]\nkey = \"duration_s\"\ngrid = [20.0]\n",
            &["vary[1]", "twice"],
        ),
        (
            "[[vary]]\nkey = \"duration_s\"\ngrid = []\n",
            &["duration_s", "0 values"],
        ),
        (
            "[[vary]]\nkey = \"wind_ned_mps\"\nuniform = [0.0, 1.0]\n",
            &["wind_ned_mps", "is a list"],
        ),
        ("[scenario]\nseed = 3\n", &["scenario.seed", "vary it"]),
        (
            "[scenario]\nwind_ned_mps = [99.0, 0.0, 0.0]\n",
            &["[scenario]", "wind_ned_mps[0] = 99"],
        ),
        ("base = \"nowhere.toml\"\n", &["nowhere.toml", "built-in"]),
    ];
    for (tail, needles) in cases {
        let text = if tail.starts_with("base") {
            format!("name = \"e\"\n{tail}")
        } else {
            format!("{base}{tail}")
        };
        let e = error_of(&text);
        assert!(e.starts_with("unit.toml: "), "names the file: {e}");
        for needle in *needles {
            assert!(e.contains(needle), "'{needle}' not in: {e}");
        }
    }
}

#[test]
fn shards_parse_zero_based() {
    assert_eq!(
        "1/2".parse::<Shard>().ok(),
        Some(Shard { index: 1, count: 2 })
    );
    assert_eq!("0/1".parse::<Shard>().ok(), Some(Shard::ALL));
    for bad in ["3/2", "2/2", "0/0", "1", "a/2", "-1/2"] {
        let e = bad
            .parse::<Shard>()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(bad) && e.contains("0-based"), "{bad}: {e}");
    }
    let e = "3/2"
        .parse::<Shard>()
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("from 0 to 1"), "{e}");
}
