//! Running campaigns: shards and merge, error and panic flights, scores, plots.

use super::super::report::{FailedCriterion, SCORE_CAP};
use super::super::*;
use super::{SHORT, campaign};

#[test]
fn shards_merge_into_the_whole_run() {
    let c = campaign(SHORT);
    let config = |shard: &str| RunConfig {
        jobs: Some(2),
        shard: shard.parse().unwrap_or(Shard::ALL),
    };
    let whole = run(&c, config("0/1"), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(whole.totals.flights, 24);
    assert_eq!(whole.shard, None);
    let again = run(
        &c,
        RunConfig {
            jobs: Some(1),
            ..config("0/1")
        },
        |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        again.without_wall(),
        whole.without_wall(),
        "deterministic, any jobs"
    );
    let parts: Vec<(String, Report)> = ["1/3", "0/3", "2/3"]
        .iter()
        .map(|s| {
            let r = run(&c, config(s), |_| {}).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(r.shard.map(|s| s.to_string()), Some(s.to_string()));
            assert_eq!(r.totals.flights, 8);
            // Through JSON, as merge reads them.
            let json = serde_json::to_string(&r).unwrap_or_default();
            let back: Report = serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}"));
            (format!("shard-{s}.json"), back)
        })
        .collect();
    let merged = merge(&parts).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(merged.without_wall(), whole.without_wall());

    let e = merge(&parts[..2])
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("8 of 24 flights are in no report") && e.contains("missing shard 2/3"),
        "{e}"
    );
    let mut overlapping = parts.clone();
    overlapping.push(("again.json".into(), parts[0].1.clone()));
    let e = merge(&overlapping)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("in both shard-1/3.json and again.json"), "{e}");
    let mut foreign = parts.clone();
    foreign[1].1.fingerprint = "0123456789abcdef".into();
    let e = merge(&foreign)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.starts_with("shard-0/3.json") && e.contains("different campaign files"),
        "{e}"
    );
}

#[test]
fn a_refused_scenario_is_an_error_flight_not_the_end() {
    // Each range is valid alone; together a start can fall after its end.
    let c = campaign(
        r#"
name = "clash"
base = "no-gps-takeoff"
samples = 30
[scenario]
duration_s = 1.0
faults.imu_silent = [[10.0, 30.0]]
[[vary]]
key = "faults.imu_silent.0.0"
uniform = [0.0, 29.0]
[[vary]]
key = "faults.imu_silent.0.1"
uniform = [11.0, 40.0]
"#,
    );
    let r = run(&c, RunConfig::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.totals.flights, 30);
    assert!(r.totals.error > 0 && r.totals.error < 30, "{:?}", r.totals);
    let e = r
        .flights
        .iter()
        .find(|f| f.outcome == FlightOutcome::Error)
        .and_then(|f| f.error.clone())
        .unwrap_or_default();
    assert!(
        e.contains("flight ") && e.contains("faults.imu_silent"),
        "{e}"
    );
    assert_eq!(
        r.worst[0].outcome,
        FlightOutcome::Error,
        "errors rank first"
    );
    assert!(
        r.worst[0]
            .reproduce
            .starts_with("heli campaign unit.toml --flight ")
    );
}

#[test]
fn a_panicking_flight_is_recorded_with_its_place() {
    let c = campaign(SHORT);
    let record = runner::fly_with(&c, 3, |_| panic!("boom in flight"));
    assert_eq!(record.outcome, FlightOutcome::Error);
    let e = record.error.unwrap_or_default();
    assert!(
        e.starts_with("panic: boom in flight at ") && e.contains("heli-campaign/src/tests/run.rs"),
        "{e}"
    );
    // Panics outside flights are not swallowed.
    assert!(std::panic::catch_unwind(|| panic!("outside")).is_err());
}

#[test]
fn scores_rank_failures_by_how_far_past_the_limit() {
    use heli_sim::summary::Criterion;
    let r = |c: Criterion| score::ratio(&c);
    assert_eq!(r(Criterion::at_most("a", 2.0, 4.0)), 0.5);
    assert_eq!(r(Criterion::at_most("a", 6.0, 4.0)), 1.5);
    assert_eq!(r(Criterion::at_least("b", 40.0, 60.0)), 1.5);
    assert_eq!(r(Criterion::at_least("b", 120.0, 60.0)), 0.5);
    assert_eq!(r(Criterion::at_least("plan_complete", 0.0, 1.0)), SCORE_CAP);
    assert_eq!(r(Criterion::at_most("c", None, 1.0)), SCORE_CAP);
    assert_eq!(r(Criterion::at_most("c", 1e9, 1.0)), SCORE_CAP);
    // Passing at-least criteria rank nothing; the worst of the others does.
    let criteria = [
        Criterion::at_least("plan_complete", 1.0, 1.0),
        Criterion::at_least("hold_duration_s", 60.01, 60.0),
        Criterion::at_most("hold_true_max_m", 1.5, 3.0),
        Criterion::at_most("hold_altitude_rms_m", 0.2, 0.5),
    ];
    assert_eq!(
        score::score(&criteria),
        (0.5, Some("hold_true_max_m".to_string()))
    );
    assert_eq!(score::score(&criteria[..2]), (0.0, None));
    assert_eq!(
        score::score(&[Criterion::at_least("rolls_completed", 2.0, 3.0)]),
        (1.5, Some("rolls_completed".to_string()))
    );
    let failed = FailedCriterion {
        name: "hold_true_max_m".into(),
        value: Some(3.5),
        limit: 3.0,
    };
    let mut f = FlightRecord::error(1, 1, Default::default(), String::new());
    f.error = None;
    f.outcome = FlightOutcome::Fail;
    f.failed = vec![failed];
    assert_eq!(f.why(), "failed hold_true_max_m 3.500 (limit 3)");
}

#[test]
fn the_plot_has_a_panel_per_key() {
    let c = campaign(SHORT);
    let r = run(
        &c,
        RunConfig {
            jobs: Some(2),
            shard: "0/4".parse().unwrap_or(Shard::ALL),
        },
        |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let dir = std::env::temp_dir().join(format!("heli-campaign-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_default();
    let svg = dir.join("outcomes.svg");
    plot::render(&r, crate::log_plot::ImageFormat::Svg, &svg).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(&svg).unwrap_or_default();
    for key in &r.keys {
        assert!(text.contains(key.as_str()), "panel {key}");
    }
    let png = dir.join("outcomes.png");
    plot::render(&r, crate::log_plot::ImageFormat::Png, &png).unwrap_or_else(|e| panic!("{e}"));
    assert!(std::fs::metadata(&png).map(|m| m.len()).unwrap_or(0) > 1000);
    std::fs::remove_dir_all(&dir).unwrap_or_default();
}
