//! The safety rule on board (`mode_check`): the modes the pilot's switch asks for are refused,
//! with the failing conditions named, when the rule does not allow them.

use heli_control::safety::Condition;

use super::tests::{core_with_gps, fly_for, gps_fix, settled, uplink};
use super::*;

const RATE: FlightMode = FlightMode::Augmented(AugmentedMode::Rate);

fn refusals(out: &[Action]) -> Vec<ModeRefusal> {
    out.iter()
        .filter_map(|a| match a {
            Action::Event(e) => match e.value {
                CoreEvent::ModeRefused(r) => Some(r),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

#[test]
fn the_switch_on_during_calibration_is_refused_once_naming_the_calibration() {
    for mode in [FlightMode::Autonomous, RATE] {
        let (_, out) = core_with_gps(mode, Some(8), 3);
        let refused = refusals(&out);
        assert_eq!(refused.len(), 1, "{mode:?}: raised once: {refused:?}");
        assert_eq!(refused[0].mode, mode);
        assert!(
            refused[0]
                .verdict
                .wanted_true
                .contains(Condition::Calibrated)
        );
        assert!(
            refused[0].text().contains("still calibrating"),
            "{}",
            refused[0].text()
        );
    }
}

#[test]
fn augmented_flight_waits_on_the_ground_for_five_satellites() {
    let (mut core, mut out) = core_with_gps(RATE, Some(4), 3);
    assert_eq!(core.phase(), Phase::Manual, "refused: the pilot flies");
    let refused = refusals(&out);
    let last = refused.last().copied().unwrap();
    assert!(last.verdict.wanted_true.contains(Condition::Satellites));
    assert!(
        last.text().contains("fewer than 5 satellites"),
        "{}",
        last.text()
    );
    // On the ground the mode is entered as soon as the rule allows it.
    out.clear();
    let mut t = 3_000_000;
    for _ in 0..4 {
        t = fly_for(
            &mut core,
            &mut out,
            t,
            500_000,
            true,
            Some(uplink(true, false)),
        );
        core.handle(Input::Gps(gps_fix(9)), t, &mut out);
    }
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
}

#[test]
fn in_the_air_a_refusal_stands_until_the_switch_goes_off() {
    // Hovering by hand at 8 m with no GPS at all: the augmented mode needs satellites.
    let mut core_out = settled(8.0, uplink(false, false));
    core_out.0.params.mode = RATE;
    let (mut core, mut out, t) = core_out;
    out.clear();
    let t = fly_for(
        &mut core,
        &mut out,
        t,
        200_000,
        true,
        Some(uplink(true, false)),
    );
    assert_eq!(core.phase(), Phase::Manual);
    let refused = refusals(&out);
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert!(core.mode_refusal().is_some());
    // Satellites come while the switch stays on: still refused (no surprise engagement).
    let mut t = t;
    for _ in 0..3 {
        core.handle(Input::Gps(gps_fix(9)), t, &mut out);
        t = fly_for(
            &mut core,
            &mut out,
            t,
            500_000,
            true,
            Some(uplink(true, false)),
        );
    }
    assert_eq!(core.phase(), Phase::Manual);
    // Off, then on again: judged afresh, and allowed.
    let t = fly_for(
        &mut core,
        &mut out,
        t,
        100_000,
        true,
        Some(uplink(false, false)),
    );
    assert!(core.mode_refusal().is_none());
    core.handle(Input::Gps(gps_fix(9)), t, &mut out);
    fly_for(
        &mut core,
        &mut out,
        t,
        100_000,
        true,
        Some(uplink(true, false)),
    );
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
}

#[test]
fn the_facts_the_core_does_not_observe_are_not_judged_on_board() {
    let (core, _) = core_with_gps(FlightMode::Autonomous, Some(8), 3);
    let facts = core.safety_facts();
    assert_eq!(facts.get(Condition::Battery), None);
    assert_eq!(facts.get(Condition::Link), None);
    assert_eq!(facts.get(Condition::Imu), Some(true));
    assert_eq!(facts.get(Condition::Satellites), Some(true));
    assert_eq!(facts.get(Condition::Bypass), Some(false));
}
