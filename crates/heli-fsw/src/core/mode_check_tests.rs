//! The safety rule on board (`mode_check`): the modes the pilot's switch asks for are refused,
//! with the failing conditions named, when the rule does not allow them.

use heli_control::safety::Condition;

use super::tests::{core_with_gps, fly_for, gps_fix, settled, uplink};
use super::*;
use heli_power::PowerSource;

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

/// Flies for `duration_us` with the IMU and the pilot's auto switch `on`; returns the time
/// reached.
fn switched(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    t: u64,
    duration_us: u64,
    on: bool,
) -> u64 {
    fly_for(core, out, t, duration_us, true, Some(uplink(on, false)))
}

/// Flies with the auto switch on and a GPS fix of `satellites` every half second until
/// `until_us`; returns the time reached.
fn switch_on_with_fixes(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    mut t: u64,
    until_us: u64,
    satellites: u8,
) -> u64 {
    while t < until_us {
        t = switched(core, out, t, 500_000, true);
        core.handle(Input::Gps(gps_fix(satellites)), t, out);
    }
    t
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
    // Raised during the calibration, and again at its end with what still fails.
    assert_eq!(refused.len(), 2, "{refused:?}");
    let last = refused.last().copied().unwrap();
    assert!(last.verdict.wanted_true.contains(Condition::Satellites));
    assert!(
        !last.verdict.wanted_true.contains(Condition::Calibrated),
        "{}",
        last.text()
    );
    assert!(
        last.text().contains("fewer than 5 satellites"),
        "{}",
        last.text()
    );
    // On the ground the mode is entered as soon as the rule allows it.
    out.clear();
    switch_on_with_fixes(&mut core, &mut out, 3_000_000, 5_000_000, 9);
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
}

#[test]
fn in_the_air_a_refusal_stands_until_the_switch_goes_off() {
    // Hovering by hand at 8 m with no GPS at all: the augmented mode needs satellites.
    let mut core_out = settled(8.0, uplink(false, false));
    core_out.0.seq.params.mode = RATE;
    let (mut core, mut out, t) = core_out;
    out.clear();
    let t = switched(&mut core, &mut out, t, 200_000, true);
    assert_eq!(core.phase(), Phase::Manual);
    let refused = refusals(&out);
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert!(core.mode_refusal().is_some());
    // Satellites come while the switch stays on: still refused (no surprise engagement).
    let mut t = t;
    for _ in 0..3 {
        core.handle(Input::Gps(gps_fix(9)), t, &mut out);
        t = switched(&mut core, &mut out, t, 500_000, true);
    }
    assert_eq!(core.phase(), Phase::Manual);
    // Off, then on again: judged afresh, and allowed.
    let t = switched(&mut core, &mut out, t, 100_000, false);
    assert!(core.mode_refusal().is_none());
    core.handle(Input::Gps(gps_fix(9)), t, &mut out);
    switched(&mut core, &mut out, t, 100_000, true);
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
}

#[test]
fn the_link_is_not_judged_until_heard_of_and_the_batteries_once_one_is_read() {
    let core = super::tests::core_with(FlightMode::Autonomous);
    assert_eq!(core.safety_facts().get(Condition::Battery), None);
    // The servo board's packs come with its uplink.
    let (core, _) = core_with_gps(FlightMode::Autonomous, Some(8), 3);
    let facts = core.safety_facts();
    assert_eq!(facts.get(Condition::Battery), Some(true));
    assert_eq!(facts.get(Condition::Link), None);
    assert_eq!(facts.get(Condition::Imu), Some(true));
    assert_eq!(facts.get(Condition::Satellites), Some(true));
    assert_eq!(facts.get(Condition::Bypass), Some(false));
}

#[test]
fn a_battery_down_to_a_third_refuses_augmented_flight_on_board() {
    let (mut core, mut out) = core_with_gps(RATE, Some(8), 1);
    // 11.4 V on the 10-cell pack: below a third of its life.
    core.handle(Input::Battery { volts: 11.4 }, 1_000_000, &mut out);
    out.clear();
    let mut t = 1_000_000;
    t = switch_on_with_fixes(&mut core, &mut out, t, t + 4 * 500_000, 8);
    assert_eq!(core.phase(), Phase::Manual);
    let last = refusals(&out).last().copied().unwrap();
    assert!(
        last.verdict.wanted_true.contains(Condition::Battery),
        "{last:?}"
    );
    assert!(
        last.text().contains("battery down to a third"),
        "{}",
        last.text()
    );
    // A reading that bounces back does not withdraw the warning.
    core.handle(Input::Battery { volts: 12.6 }, t, &mut out);
    let t = switched(&mut core, &mut out, t, 100_000, false);
    let t = switched(&mut core, &mut out, t, 100_000, true);
    assert_eq!(core.phase(), Phase::Manual);
    // A charged pack swapped in through the hot-swap: gauged afresh, the mode is entered.
    let t = switched(&mut core, &mut out, t, 100_000, false);
    core.handle(Input::PowerSource(PowerSource::Ground), t, &mut out);
    core.handle(Input::PowerSource(PowerSource::Flight), t, &mut out);
    core.handle(Input::Battery { volts: 12.6 }, t, &mut out);
    switch_on_with_fixes(&mut core, &mut out, t, t + 4 * 500_000, 8);
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
}

#[test]
fn without_a_ground_heard_the_autonomous_take_off_is_refused_naming_the_link() {
    let mut core = super::tests::core_with(FlightMode::Autonomous);
    let mut out = Vec::new();
    core.start(0);
    core.handle(Input::GroundLink { fresh: false }, 0, &mut out);
    switch_on_with_fixes(&mut core, &mut out, 0, 40_000_000, 8);
    assert_eq!(core.phase(), Phase::TakeoffRefused);
    let refused = out.iter().find_map(|a| match a {
        Action::Event(e) => match e.value {
            CoreEvent::TakeoffRefused(r) => Some(r),
            _ => None,
        },
        _ => None,
    });
    let Some(Refusal::Unsafe(verdict)) = refused else {
        panic!("{refused:?}");
    };
    assert!(verdict.wanted_true.contains(Condition::Link), "{verdict:?}");
    assert!(
        Refusal::Unsafe(verdict)
            .text()
            .contains("ground link not fresh")
    );
}

#[test]
fn with_a_ground_heard_the_same_take_off_goes() {
    let mut core = super::tests::core_with(FlightMode::Autonomous);
    let mut out = Vec::new();
    core.start(0);
    core.handle(Input::GroundLink { fresh: true }, 0, &mut out);
    core.handle(Input::Battery { volts: 12.6 }, 0, &mut out);
    switch_on_with_fixes(&mut core, &mut out, 0, 5_000_000, 8);
    assert!(
        matches!(core.phase(), Phase::TakingOff { .. }),
        "{:?}",
        core.phase()
    );
    assert_eq!(core.safety_facts().get(Condition::Link), Some(true));
    assert_eq!(core.safety_facts().get(Condition::Battery), Some(true));
}

#[test]
fn a_refusal_in_the_air_outlasts_a_transmitter_loss_with_the_switch_still_on() {
    let (mut core, mut out, t) = settled(8.0, uplink(false, false));
    core.seq.params.mode = RATE;
    let t = switched(&mut core, &mut out, t, 200_000, true);
    assert!(core.mode_refusal().is_some(), "no satellites: refused");
    // The transmitter is lost (the failsafe hover), then comes back with the switch on.
    let t = fly_for(
        &mut core,
        &mut out,
        t,
        1_000_000,
        true,
        Some(uplink(true, true)),
    );
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    out.clear();
    switched(&mut core, &mut out, t, 500_000, true);
    assert_eq!(
        core.phase(),
        Phase::Manual,
        "the refused mode does not come in"
    );
    assert!(
        refusals(&out).is_empty(),
        "already raised: {:?}",
        refusals(&out)
    );
}

#[test]
fn a_condition_that_comes_and_goes_on_the_ground_is_raised_once() {
    let (mut core, mut out) = core_with_gps(RATE, Some(4), 3);
    let before = refusals(&out).len();
    let mut t = 3_000_000;
    for k in 0..10 {
        t = switched(&mut core, &mut out, t, 500_000, true);
        // The satellites flicker between 4 and 3: never enough.
        core.handle(Input::Gps(gps_fix(3 + (k % 2))), t, &mut out);
    }
    assert_eq!(core.phase(), Phase::Manual);
    assert_eq!(refusals(&out).len(), before, "{:?}", refusals(&out));
    // A new reason is raised: the battery drops below its third.
    core.handle(Input::Battery { volts: 11.3 }, t, &mut out);
    switched(&mut core, &mut out, t, 100_000, true);
    let last = refusals(&out).last().copied().unwrap();
    assert!(
        last.verdict.wanted_true.contains(Condition::Battery),
        "{last:?}"
    );
}
