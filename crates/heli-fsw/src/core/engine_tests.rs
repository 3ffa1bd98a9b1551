//! Component tests of the engine watch and the autorotation's place among the phases: the
//! core driven by its inputs (IMU, the board's uplink with the rotor speed, the altimeter),
//! judged on the events and phases it emits.

use super::tests::{core_with, gps_fix, raised, still, uplink};
use super::*;

/// Feeds `core` for `seconds`: IMU every 10 ms, the pilot's packet with `rpm` every 20 ms,
/// the altimeter at `height_m` every 50 ms and a GPS fix at that height every 200 ms.
pub(super) fn fly(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    t: &mut u64,
    seconds: f64,
    pilot: PilotUplink,
    height_m: f64,
) {
    let end = *t + (seconds * 1e6) as u64;
    while *t < end {
        *t += 10_000;
        core.handle(Input::Imu(still()), *t, out);
        if t.is_multiple_of(20_000) {
            core.handle(Input::Uplink(pilot), *t, out);
        }
        if t.is_multiple_of(50_000) {
            let pressure_mbar = heli_proto::baro::pressure_at_altitude_mbar(height_m, 1013.25);
            core.handle(Input::Baro { pressure_mbar }, *t, out);
        }
        if t.is_multiple_of(200_000) {
            let fix = GpsNav {
                alt_m: gps_fix(8).alt_m + height_m,
                ..gps_fix(8)
            };
            core.handle(Input::Gps(fix), *t, out);
        }
    }
}

fn with_rpm(pilot: PilotUplink, rotor_rpm: u16) -> PilotUplink {
    PilotUplink { rotor_rpm, ..pilot }
}

/// Climbs or descends from `from_m` to `to_m` at 0.5 m/s (as the altimeter and the GPS say),
/// then holds there for a second.
#[allow(clippy::too_many_arguments)]
fn climb(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    t: &mut u64,
    from_m: f64,
    to_m: f64,
    pilot: PilotUplink,
) {
    let steps = ((to_m - from_m).abs() / 0.1).ceil() as u32;
    for k in 1..=steps {
        let h = from_m + (to_m - from_m) * f64::from(k) / f64::from(steps);
        fly(core, out, t, 0.2, pilot, h);
    }
    fly(core, out, t, 1.0, pilot, to_m);
}

/// A calibrated core flying `mode`, the pilot's switch off, hovering by hand `height_m` up.
pub(super) fn hovering(mode: FlightMode, height_m: f64) -> (FlightCore, Vec<Action>, u64) {
    let mut core = core_with(mode);
    let mut out = Vec::new();
    let mut t = 0;
    core.start(0);
    fly(&mut core, &mut out, &mut t, 2.0, uplink(false, false), 0.0);
    assert!(core.navigator().state().is_some(), "calibrated");
    climb(
        &mut core,
        &mut out,
        &mut t,
        0.0,
        height_m,
        uplink(false, false),
    );
    let height = core
        .navigator()
        .state()
        .map_or(0.0, |s| core.height_above_home(s));
    assert!((height - height_m).abs() < 1.0, "{height} m up");
    out.clear();
    (core, out, t)
}

fn failures(out: &[Action]) -> usize {
    out.iter()
        .filter(
            |a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::EngineFailure { .. })),
        )
        .count()
}

/// Brings the rotor from `from` to `to` rpm by 10 rpm every 0.1 s (100 rpm/s: a governor's
/// droop, not an engine's failure).
fn ramp(core: &mut FlightCore, out: &mut Vec<Action>, t: &mut u64, from: u16, to: u16, auto: bool) {
    let mut rpm = from;
    while rpm > to {
        rpm = rpm.saturating_sub(10).max(to);
        fly(core, out, t, 0.1, with_rpm(uplink(auto, false), rpm), 8.0);
    }
}

#[test]
fn a_rotor_held_low_in_the_air_is_an_engine_failure_raised_once() {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    fly(&mut core, &mut out, &mut t, 1.0, uplink(false, false), 8.0);
    assert_eq!(failures(&out), 0, "1600 rpm is the governed speed");
    // 1370 rpm is 85.6 %: low, but above the 85 % failure fraction.
    ramp(&mut core, &mut out, &mut t, 1600, 1370, false);
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        with_rpm(uplink(false, false), 1370),
        8.0,
    );
    assert_eq!(failures(&out), 0);
    // 1350 rpm (84 %): confirmed after 0.1 s.
    fly(
        &mut core,
        &mut out,
        &mut t,
        0.06,
        with_rpm(uplink(false, false), 1350),
        8.0,
    );
    assert_eq!(failures(&out), 0);
    assert!(!core.engine.failed());
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        with_rpm(uplink(false, false), 1350),
        8.0,
    );
    assert_eq!(failures(&out), 1);
    assert!(core.engine.failed(), "the failure is kept");
    assert!(out.iter().any(|a| matches!(
        a,
        Action::Event(e) if e.value == CoreEvent::EngineFailure { rotor_rpm: 1350 }
    )));
    // A pilot flying by hand is told and keeps flying.
    assert_eq!(core.phase(), Phase::Manual);
}

#[test]
fn a_rotor_falling_fast_is_an_engine_failure_at_once() {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    // 1600 → 1500 rpm in 0.1 s: 94 % and falling at 1000 rpm/s.
    fly(
        &mut core,
        &mut out,
        &mut t,
        0.1,
        with_rpm(uplink(false, false), 1600),
        8.0,
    );
    fly(
        &mut core,
        &mut out,
        &mut t,
        0.06,
        with_rpm(uplink(false, false), 1500),
        8.0,
    );
    assert_eq!(failures(&out), 1);
    // The same 1500 rpm reached slowly is the governor's droop.
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    ramp(&mut core, &mut out, &mut t, 1600, 1500, false);
    // A fast fall that stays above 95 % (1530 rpm, at 700 rpm/s) under a heavy collective
    // (0.8: a roll's pull-up) is the roll's load; under a light one the rotor asked for
    // little power and still fell: the engine quit.
    for (collective, failed) in [(0.8, 0), (0.5, 1), (0.0, 1)] {
        let (mut fast, mut fast_out, mut ft) = hovering(FlightMode::Autonomous, 8.0);
        let pilot = PilotUplink {
            pulses: heli_proto::scb::Pulses::from_controls(&Controls {
                collective,
                throttle: 0.8,
                ..Controls::default()
            }),
            ..uplink(false, false)
        };
        fly(&mut fast, &mut fast_out, &mut ft, 0.1, pilot, 8.0);
        fly(
            &mut fast,
            &mut fast_out,
            &mut ft,
            0.06,
            with_rpm(pilot, 1530),
            8.0,
        );
        assert_eq!(failures(&fast_out), failed, "collective {collective}");
    }
    // Falling as fast from an overspeed to above 99 % (1700 → 1630 rpm) under no collective
    // is the governor taking the rotor back.
    let (mut over, mut over_out, mut ot) = hovering(FlightMode::Autonomous, 8.0);
    let pilot = uplink(false, false);
    fly(
        &mut over,
        &mut over_out,
        &mut ot,
        0.1,
        with_rpm(pilot, 1700),
        8.0,
    );
    fly(
        &mut over,
        &mut over_out,
        &mut ot,
        0.06,
        with_rpm(pilot, 1630),
        8.0,
    );
    assert_eq!(failures(&over_out), 0);
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        with_rpm(uplink(false, false), 1500),
        8.0,
    );
    assert_eq!(failures(&out), 0);
}

#[test]
fn on_the_ground_a_slow_rotor_is_no_engine_failure() {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 0.0);
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        with_rpm(uplink(false, false), 900),
        0.0,
    );
    assert_eq!(failures(&out), 0);
}

/// An autonomous hold `height_m` up, then the rotor held at 1200 rpm for 0.5 s: the
/// engine has failed.
fn engine_fails_in_a_hold(height_m: f64) -> (FlightCore, Vec<Action>, u64) {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, height_m);
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        uplink(true, false),
        height_m,
    );
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    fly(
        &mut core,
        &mut out,
        &mut t,
        0.5,
        with_rpm(uplink(true, false), 1200),
        height_m,
    );
    (core, out, t)
}

#[test]
fn in_autonomous_flight_an_engine_failure_is_an_autorotation() {
    let (mut core, mut out, mut t) = engine_fails_in_a_hold(8.0);
    assert_eq!(failures(&out), 1);
    assert!(matches!(core.phase(), Phase::Autorotation { .. }));
    assert!(raised(
        &out,
        CoreEvent::PhaseChanged(Phase::Autorotation {
            settled_since_us: None
        })
    ));
    // Settled on the ground: landed.
    climb(
        &mut core,
        &mut out,
        &mut t,
        8.0,
        0.0,
        with_rpm(uplink(true, false), 1200),
    );
    fly(
        &mut core,
        &mut out,
        &mut t,
        5.0,
        with_rpm(uplink(true, false), 1200),
        0.0,
    );
    assert_eq!(core.phase(), Phase::Landed);
}

#[test]
fn close_to_the_ground_the_autorotation_is_a_hovering_one() {
    // The engine quits in an autonomous hover: 2 m up a hovering autorotation, 8 m up the
    // glide's (the height is the one the failure is detected at).
    for (height_m, hovering_expected) in [(2.0, true), (8.0, false)] {
        let (core, out, _) = engine_fails_in_a_hold(height_m);
        assert_eq!(failures(&out), 1, "{height_m} m");
        let autorotation = core.engine.autorotation.as_ref().map(|a| a.hovering());
        assert_eq!(autorotation, Some(hovering_expected), "{height_m} m");
    }
}

#[test]
fn after_an_engine_failure_the_engine_is_not_flown_again() {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    fly(
        &mut core,
        &mut out,
        &mut t,
        0.5,
        with_rpm(uplink(false, false), 1200),
        8.0,
    );
    assert_eq!(failures(&out), 1);
    // The pilot lands it, then puts the auto switch on: no pre-flight check, no take-off.
    climb(
        &mut core,
        &mut out,
        &mut t,
        8.0,
        0.0,
        with_rpm(uplink(false, false), 1200),
    );
    assert_eq!(core.phase(), Phase::Manual);
    fly(
        &mut core,
        &mut out,
        &mut t,
        1.0,
        with_rpm(uplink(true, false), 1600),
        0.0,
    );
    assert_eq!(core.phase(), Phase::Landed);
    // The transmitter lost on the ground idles.
    fly(&mut core, &mut out, &mut t, 0.2, uplink(true, true), 0.0);
    assert_eq!(core.phase(), Phase::GroundFailsafe);
    // In the air again (the estimate climbs), the computer autorotates.
    climb(
        &mut core,
        &mut out,
        &mut t,
        0.0,
        6.0,
        with_rpm(uplink(true, false), 1600),
    );
    assert!(
        matches!(core.phase(), Phase::Autorotation { .. }),
        "{:?}",
        core.phase()
    );
    assert_eq!(failures(&out), 1, "raised once for the flight");
}

/// Level, `height_m` up, sinking at `sink_mps`.
fn at(height_m: f64, sink_mps: f64) -> NavState {
    NavState {
        t_us: 0,
        att: nalgebra::UnitQuaternion::identity(),
        vel_ned_mps: Vector3::new(0.0, 0.0, sink_mps),
        pos_ned_m: Vector3::new(0.0, 0.0, -height_m),
        rate_body_rps: Vector3::zeros(),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

fn failed_in(phase: Phase) -> FlightCore {
    let mut core = core_with(FlightMode::Autonomous);
    core.seq.home_ned_m = Some(Vector3::zeros());
    core.engine.failed = true;
    core.seq.phase = phase;
    core
}

#[test]
fn an_autorotation_is_landed_after_half_a_second_still_on_the_ground() {
    let s = 1_000_000;
    let mut core = failed_in(Phase::Autorotation {
        settled_since_us: None,
    });
    // Still sinking: not settled.
    assert_eq!(
        core.autorotate(&at(0.2, 0.5), true, false, s),
        Some(Phase::Autorotation {
            settled_since_us: None
        })
    );
    // Down and still: settling from now.
    let settling = core.autorotate(&at(0.2, 0.1), true, false, s);
    assert_eq!(
        settling,
        Some(Phase::Autorotation {
            settled_since_us: Some(s)
        })
    );
    core.seq.phase = settling.unwrap();
    assert_eq!(
        core.autorotate(&at(0.2, 0.1), true, false, s + 400_000),
        core.seq.phase.into()
    );
    assert_eq!(
        core.autorotate(&at(0.2, 0.1), true, false, s + 500_000),
        Some(Phase::Landed)
    );
    assert!(core.engine.autorotation.is_none());
    // Settled above the landed height is no landing.
    let mut core = failed_in(Phase::Autorotation {
        settled_since_us: Some(0),
    });
    assert_eq!(
        core.autorotate(&at(0.6, 0.0), false, false, s),
        Some(Phase::Autorotation {
            settled_since_us: None
        })
    );
}

#[test]
fn after_an_engine_failure_the_idle_phases_stay_on_the_ground() {
    for phase in [Phase::TakeoffRefused, Phase::GroundFailsafe] {
        let mut core = failed_in(phase);
        assert_eq!(core.autorotate(&at(0.0, 0.0), true, false, 0), Some(phase));
        // In the air (the estimate says so), it autorotates.
        let mut core = failed_in(phase);
        assert!(matches!(
            core.autorotate(&at(5.0, 1.0), false, false, 0),
            Some(Phase::Autorotation { .. })
        ));
    }
    let mut core = failed_in(Phase::Manual);
    assert_eq!(
        core.autorotate(&at(0.0, 0.0), true, true, 0),
        Some(Phase::GroundFailsafe)
    );
    assert_eq!(
        core.autorotate(&at(0.0, 0.0), true, false, 0),
        Some(Phase::Landed)
    );
    // A good engine leaves the choice to the other rules.
    let mut core = failed_in(Phase::Manual);
    core.engine.failed = false;
    assert_eq!(core.autorotate(&at(5.0, 0.0), false, false, 0), None);
}
