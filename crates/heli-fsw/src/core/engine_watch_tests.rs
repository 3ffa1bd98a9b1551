//! The engine watch's rules at their exact limits: [`Engine::watch`] fed rotor speeds and
//! commanded collectives directly, each rule alone (the others' limits set out of reach).

use heli_nav::seconds_between;

use super::Action;
use super::engine::{Engine, EngineWatch};

/// A watch with only the unloaded rule: below 800 rpm (half of 1600), a fall faster than
/// `rpm_per_s` under a collective of at most 0.5.
fn unloaded_only(rpm_per_s: f64) -> EngineWatch {
    EngineWatch {
        falling_fraction: 0.0,
        failure_fraction: 0.0,
        unloaded_fraction: 0.5,
        unloaded_collective: 0.5,
        unloaded_falling_rpm_per_s: rpm_per_s,
        ..EngineWatch::default()
    }
}

/// The second reading's time (µs): over the watch's 0.1 s (exactly 0.1 s is 0.0999… in
/// floating point, under it).
const LATER_US: u64 = 120_000;

/// Whether the watch calls a failure for the rotor going from `from` to `to` rpm in 0.12 s
/// under `collective`.
fn called(w: &EngineWatch, from: f64, to: f64, collective: f64) -> bool {
    let mut engine = Engine::default();
    let mut out: Vec<Action> = Vec::new();
    engine.commanded(collective);
    engine.watch(w, Some(from), true, 0, &mut out);
    engine.commanded(collective);
    engine.watch(w, Some(to), true, LATER_US, &mut out);
    engine.failed()
}

/// The fall the watch computes for `from` → `to` in 0.12 s (rpm/s), to set a limit exactly.
fn fall(from: f64, to: f64) -> f64 {
    (from - to) / seconds_between(0, LATER_US).max(1e-3)
}

#[test]
fn the_unloaded_rule_calls_a_fall_below_its_fraction_not_at_it() {
    let w = unloaded_only(400.0);
    assert!(!called(&w, 900.0, 800.0, 0.0), "exactly at 800 rpm");
    assert!(called(&w, 900.0, 799.0, 0.0), "below it");
}

#[test]
fn the_unloaded_rule_calls_a_fall_faster_than_its_limit_not_at_it() {
    let w = unloaded_only(fall(790.0, 750.0));
    assert!(!called(&w, 790.0, 750.0, 0.0), "exactly at the limit");
    assert!(called(&w, 790.0, 749.0, 0.0), "beyond it");
    // Under a collective above 0.5 it is the load; at 0.5 exactly it is not.
    assert!(!called(&w, 790.0, 740.0, 0.51));
    assert!(called(&w, 790.0, 740.0, 0.5));
}

#[test]
fn the_first_rule_calls_a_fall_faster_than_its_limit_not_at_it() {
    let w = EngineWatch {
        falling_fraction: 1.0,
        falling_rpm_per_s: fall(1500.0, 1440.0),
        failure_fraction: 0.0,
        unloaded_fraction: 0.0,
        ..EngineWatch::default()
    };
    // Whatever the collective.
    assert!(!called(&w, 1500.0, 1440.0, 0.9), "exactly at the limit");
    assert!(called(&w, 1500.0, 1439.0, 0.9), "beyond it");
}

#[test]
fn a_collective_never_commanded_counts_as_heavy() {
    let w = unloaded_only(400.0);
    let mut engine = Engine::default();
    let mut out: Vec<Action> = Vec::new();
    engine.watch(&w, Some(790.0), true, 0, &mut out);
    engine.watch(&w, Some(700.0), true, LATER_US, &mut out);
    assert!(!engine.failed());
}

#[test]
fn the_heaviest_collective_of_the_sixteen_steps_kept_judges_the_fall() {
    // Twenty steps 1 ms apart: the watch keeps the first sixteen (its bound), all light, and
    // judges the fall from the last of them; a heavy collective in the seventeenth, not
    // kept, does not excuse it.
    let w = unloaded_only(400.0);
    let mut engine = Engine::default();
    let mut out: Vec<Action> = Vec::new();
    for k in 0..20u64 {
        engine.commanded(if k == 16 { 0.9 } else { 0.0 });
        engine.watch(&w, Some(790.0), true, k * 1_000, &mut out);
    }
    engine.commanded(0.0);
    engine.watch(&w, Some(700.0), true, LATER_US, &mut out);
    assert!(engine.failed());
}
