use super::*;
use crate::*;

#[test]
fn file_overrides_its_base() {
    let s = from_toml("name = \"windy\"\nseed = 7\nwind_ned_mps = [3.0, 0.0, 0.0]\n[faults]\nimu_drop_rate = 0.01\n")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.name, "windy");
    assert_eq!(s.seed, 7);
    assert_eq!(s.wind_ned_mps, [3.0, 0.0, 0.0]);
    assert_eq!(s.faults.imu_drop_rate, 0.01);
    assert_eq!(s.plan, hover().plan, "inherited from hover");
    assert_eq!(s.limits, hover().limits);
}

#[test]
fn an_inherited_limit_can_be_unset() {
    let s = from_toml("[limits]\nhold_true_max_m = \"unset\"\nhold_min_s = 30.0\n")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.limits.hold_true_max_m, None);
    assert_eq!(s.limits.hold_min_s, Some(30.0));
    assert_eq!(s.limits.plan_complete, Some(true), "the rest inherited");
    let e = from_toml("[limits]\nhold_min_s = \"off\"\n")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("limits.hold_min_s"), "{e}");
}

#[test]
fn unknown_fields_and_bases_are_clear_errors() {
    let e = from_toml("wnd = 3")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("wnd"), "{e}");
    assert!(from_toml("base = \"loop-the-loop\"").is_err());
}

#[test]
fn every_built_in_scenario_flies_the_library_plan_of_its_name() {
    let scenarios = builtins();
    for s in &scenarios {
        let named = heli_types::library::plan(&s.name)
            .unwrap_or_else(|| panic!("the plan library has no plan '{}'", s.name));
        assert_eq!(s.plan, named.legs, "{}", s.name);
    }
    let names: Vec<_> = scenarios.iter().map(|s| s.name.as_str()).collect();
    let library: Vec<_> = heli_types::library::LIBRARY
        .iter()
        .map(|p| p.name)
        .collect();
    assert_eq!(
        names, library,
        "the library lists the built-in scenarios, in order"
    );
}
