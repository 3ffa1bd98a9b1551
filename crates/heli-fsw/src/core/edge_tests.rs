//! The flight core's rules at their exact thresholds, and the combinations of conditions
//! the whole-flight tests never separate: each rule's limit is on the side the code says
//! (a helicopter exactly at a limit is not past it), and each condition of a rule is needed.

use super::sequencer_tests::{core_in, est, next};
use super::tests::{raised, uplink};
use super::*;

const S: u64 = 1_000_000;

/// A core 10 m up in autonomous flight whose rotor the pilot's packets report.
fn watching(height_m: f64, airborne_once: bool) -> (FlightCore, NavState) {
    let mut core = core_in(
        Phase::Holding {
            target: Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3),
            since_us: 0,
        },
        FlightMode::Autonomous,
        true,
        S,
    );
    core.seq.airborne_once = airborne_once;
    (core, est(height_m, 0.0, Vector3::zeros()))
}

/// The rotor reported at `rpm` at each of `times_us`; whether the engine was found failed.
fn rotor(core: &mut FlightCore, e: &NavState, rpm: u16, times_us: &[u64]) -> bool {
    let mut out = Vec::new();
    for &t in times_us {
        core.devices.pilot = Some(PilotUplink {
            rotor_rpm: rpm,
            ..uplink(true, false)
        });
        core.watch_engine(e, t, &mut out);
    }
    out.iter().any(
        |a| matches!(a, Action::Event(ev) if matches!(ev.value, CoreEvent::EngineFailure { .. })),
    )
}

#[test]
fn a_rotor_exactly_at_85_percent_is_not_failing_and_one_rpm_below_is() {
    // 0.85 × 1600 is exactly 1360 in floating point.
    let (mut core, e) = watching(10.0, true);
    assert!(!rotor(
        &mut core,
        &e,
        1360,
        &[0, 60_000, 120_000, 180_000, 240_000]
    ));
    let (mut core, e) = watching(10.0, true);
    assert!(rotor(&mut core, &e, 1359, &[0, 60_000, 120_000, 180_000]));
}

#[test]
fn a_fast_fall_counts_only_below_95_percent() {
    // From 1600 to 1520 (exactly 95 %) in 0.12 s is 667 rpm/s, faster than the rule's 600,
    // but not below 95 %; to 1519 it is.
    for (to, failed) in [(1520, false), (1519, true)] {
        let (mut core, e) = watching(10.0, true);
        rotor(&mut core, &e, 1600, &[0, 60_000]);
        assert_eq!(rotor(&mut core, &e, to, &[120_000]), failed, "{to}");
    }
}

#[test]
fn only_a_helicopter_in_the_air_now_and_once_can_lose_its_engine() {
    // Flown and landed (the engine shut down on the ground), never flown, exactly at the
    // airborne height: no engine failure.
    for (height_m, airborne_once) in [(0.1, true), (10.0, false), (0.3, true)] {
        let (mut core, e) = watching(height_m, airborne_once);
        assert!(
            !rotor(&mut core, &e, 900, &[0, 100_000, 200_000, 300_000]),
            "{height_m} {airborne_once}"
        );
    }
}

#[test]
fn an_autorotation_is_landed_only_below_half_a_metre_and_sinking_under_0_3_mps() {
    let settling = |height_m: f64, sink_mps: f64| {
        let (mut core, _) = watching(height_m, true);
        core.engine.failed = true;
        core.seq.phase = Phase::Autorotation {
            settled_since_us: None,
        };
        let e = est(height_m, 0.0, Vector3::new(0.0, 0.0, sink_mps));
        core.autorotate(&e, true, false, 5 * S)
    };
    let settled = Some(Phase::Autorotation {
        settled_since_us: Some(5 * S),
    });
    let not = Some(Phase::Autorotation {
        settled_since_us: None,
    });
    assert_eq!(settling(0.4, 0.1), settled);
    assert_eq!(settling(0.5, 0.1), not, "exactly half a metre up");
    assert_eq!(settling(0.4, 0.3), not, "sinking exactly 0.3 m/s");
    assert_eq!(settling(0.4, -0.3), not, "bouncing up at 0.3 m/s");
}

#[test]
fn a_stop_under_way_ends_below_0_3_mps_not_at_it() {
    let (mut core, _) = watching(10.0, true);
    let moving = est(10.0, 0.0, Vector3::new(6.0, 0.0, 0.0));
    core.seq.braking = brake::Brake::begin(0, &moving);
    let hold = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    let at = |v: f64| est(10.0, 9.0, Vector3::new(v, 0.0, 0.0));
    core.braking_target(hold, 4 * S, &at(0.3));
    assert!(
        core.seq.braking.is_some(),
        "exactly 0.3 m/s: still stopping"
    );
    core.braking_target(hold, 4 * S, &at(0.299));
    assert!(core.seq.braking.is_none());
}

#[test]
fn the_climb_ends_inside_its_tolerance_not_on_it() {
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
    core.config.takeoff_tolerance_m = 0.25;
    let (phase, _) = next(&mut core, &est(9.75, 0.0, Vector3::zeros()), S);
    assert_eq!(phase, Phase::TakingOff { target }, "exactly 0.25 m short");
    let (phase, _) = next(&mut core, &est(9.875, 0.0, Vector3::zeros()), S);
    assert!(matches!(phase, Phase::Holding { .. }), "{phase:?}");
}

#[test]
fn a_path_is_arrived_inside_1_5_m_and_under_1_mps_not_on_them() {
    let to = Vector3::new(20.0, 0.0, -10.0);
    let stopped_at = Phase::Flying {
        target: Target {
            pos_ned_m: to,
            vel_ned_mps: Vector3::zeros(),
            yaw_rad: 0.0,
        },
        to_ned_m: to,
    };
    for (north, speed, arrived) in [(18.5, 0.5, false), (19.0, 1.0, false), (18.75, 0.75, true)] {
        let mut core = core_in(stopped_at, FlightMode::Autonomous, true, S);
        core.seq.leg = 2;
        let phase = next(
            &mut core,
            &est(10.0, north, Vector3::new(speed, 0.0, 0.0)),
            S,
        )
        .0;
        assert_eq!(
            matches!(phase, Phase::Landing { .. }),
            arrived,
            "{north} {speed}: {phase:?}"
        );
    }
}

fn landing(z: f64) -> Phase {
    Phase::Landing {
        target: Target {
            pos_ned_m: Vector3::new(20.0, 0.0, z),
            vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
            yaw_rad: 0.0,
        },
        settled_since_us: None,
    }
}

fn settles(core: &mut FlightCore, e: &NavState) -> bool {
    matches!(
        next(core, e, 2 * S).0,
        Phase::Landing {
            settled_since_us: Some(_),
            ..
        }
    )
}

#[test]
fn a_landing_settles_when_its_target_is_half_a_metre_below_the_skids_and_still() {
    // The helicopter 0.2 m up (the ground not quite where home was), the target 0.4 m
    // below home: 0.6 m below the skids.
    let mut core = core_in(landing(0.4), FlightMode::Autonomous, true, S);
    assert!(settles(
        &mut core,
        &est(0.2, 20.0, Vector3::new(0.0, 0.0, 0.1))
    ));
    // Exactly half a metre below (0.49 m and the step's 0.01 m of descent), or only
    // 0.4 m: still landing.
    let mut core = core_in(landing(0.49), FlightMode::Autonomous, true, S);
    assert!(!settles(
        &mut core,
        &est(0.0, 20.0, Vector3::new(0.0, 0.0, 0.1))
    ));
    let mut core = core_in(landing(0.2), FlightMode::Autonomous, true, S);
    assert!(!settles(
        &mut core,
        &est(0.2, 20.0, Vector3::new(0.0, 0.0, 0.1))
    ));
    // Sinking at exactly 0.3 m/s: not still.
    let mut core = core_in(landing(0.6), FlightMode::Autonomous, true, S);
    assert!(!settles(
        &mut core,
        &est(0.0, 20.0, Vector3::new(0.0, 0.0, 0.3))
    ));
}

#[test]
fn without_a_fresh_gps_fix_a_landing_judges_only_the_sink() {
    // Drifting 0.5 m/s sideways on the skids: with no GPS fused, the drift is the
    // estimate's and the landing settles on the sink alone; with a fix fused a moment ago,
    // the drift is real and it does not.
    let drifting = est(0.0, 20.0, Vector3::new(0.5, 0.0, 0.1));
    let mut core = core_in(landing(0.6), FlightMode::Autonomous, true, S);
    assert!(settles(&mut core, &drifting));
    let mut core = core_in(landing(0.6), FlightMode::Autonomous, true, S);
    let origin = heli_nav::GeoOrigin {
        lat_deg: 42.36,
        lon_deg: -71.09,
        alt_m: 10.0,
    };
    core.nav.set_origin(origin);
    level_estimate(&mut core, 0);
    let fix = heli_proto::gps::GpsNav {
        lat_deg: origin.lat_deg,
        lon_deg: origin.lon_deg,
        alt_m: origin.alt_m,
        ..super::tests::gps_fix(8)
    };
    core.nav.fuse_gps(S + 500_000, &fix);
    assert_eq!(core.nav.stats().gps_fused, 1);
    let mut stale = core.clone();
    assert!(!settles(&mut core, &drifting));
    // Fused exactly three seconds ago: no longer fresh.
    assert!(matches!(
        next(&mut stale, &drifting, 4 * S + 500_000).0,
        Phase::Landing {
            settled_since_us: Some(_),
            ..
        }
    ));
}

#[test]
fn exactly_at_the_airborne_height_the_helicopter_is_in_the_air() {
    // The auto switch put on in manual flight: in the air a hold, on the ground the
    // pre-flight check. At exactly the airborne height it is in the air.
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.config.airborne_height_m = 0.25;
    let (phase, _) = next(&mut core, &est(0.25, 0.0, Vector3::zeros()), S);
    assert!(matches!(phase, Phase::Holding { .. }), "{phase:?}");
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.config.airborne_height_m = 0.25;
    let (phase, _) = next(&mut core, &est(0.125, 0.0, Vector3::zeros()), S);
    assert!(matches!(phase, Phase::PreflightCheck { .. }), "{phase:?}");
}

#[test]
fn gps_lost_and_regained_are_raised_once_each_and_only_with_an_estimate() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let mut out = Vec::new();
    // No estimate yet: the outage is nobody's concern.
    core.control_step(still_imu(), still_imu(), false, 10 * S, &mut out);
    assert!(!raised(&out, CoreEvent::GpsLost));
    level_estimate(&mut core, 0);
    core.main_loop.estimate_valid = true;
    core.control_step(still_imu(), still_imu(), false, 10 * S + 20_000, &mut out);
    core.control_step(still_imu(), still_imu(), false, 10 * S + 40_000, &mut out);
    let lost = |out: &[Action]| {
        out.iter()
            .filter(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::GpsLost))
            .count()
    };
    assert_eq!(lost(&out), 1);
    assert!(!raised(&out, CoreEvent::GpsRegained));
}

fn still_imu() -> heli_proto::imu::ImuRepr {
    super::tests::still()
}

/// Starts `core`'s estimate at `t_us` from a calibration of a level, still helicopter.
fn level_estimate(core: &mut FlightCore, t_us: u64) {
    core.nav.initialise(
        t_us,
        &heli_nav::ImuBiases {
            gyro_rps: Vector3::zeros(),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -heli_nav::GRAVITY_MPS2),
            samples: 100,
        },
    );
}

#[test]
fn a_helicopter_exactly_at_the_airborne_height_has_not_yet_flown() {
    // A level estimate at the origin, exactly 0.25 m above a take-off point 0.25 m below it:
    // not above the airborne height, so not yet flown; a hair higher, flown.
    let level = heli_proto::imu::ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -heli_nav::GRAVITY_MPS2],
        temp_c: 30.0,
    };
    for (home_z, flown) in [(0.25, false), (0.2500001, true)] {
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        core.config.airborne_height_m = 0.25;
        level_estimate(&mut core, 0);
        core.main_loop.estimate_valid = true;
        core.seq.home_ned_m = Some(Vector3::new(0.0, 0.0, home_z));
        core.control_step(level, level, false, 20_000, &mut Vec::new());
        assert_eq!(core.nav.state().map(|s| s.pos_ned_m.z), Some(0.0));
        assert_eq!(core.seq.airborne_once, flown, "{home_z}");
    }
}

#[test]
fn the_hold_a_lost_transmitter_turns_a_path_into_unlearns_the_path_s_drag() {
    // 10 m up with an estimate, flying a path (or already holding); the transmitter goes.
    let step_with_signal_lost = |phase: Phase| {
        let mut core = core_in(phase, FlightMode::Autonomous, true, S);
        core.seq.home_ned_m = Some(Vector3::new(0.0, 0.0, 10.0));
        level_estimate(&mut core, S);
        core.main_loop.estimate_valid = true;
        core.devices.pilot = Some(uplink(true, true));
        let mut out = Vec::new();
        core.control_step(still_imu(), still_imu(), false, S + 20_000, &mut out);
        core
    };
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.0);
    let flown = step_with_signal_lost(Phase::Flying {
        target,
        to_ned_m: Vector3::new(50.0, 0.0, -10.0),
    });
    assert!(
        matches!(flown.seq.phase, Phase::Holding { .. }),
        "{:?}",
        flown.seq.phase
    );
    assert!(flown.hover.settling(), "the path's drag is to be unlearnt");
    // A hold that goes on is no hold after flight.
    let held = step_with_signal_lost(Phase::Holding {
        target,
        since_us: 0,
    });
    assert!(matches!(held.seq.phase, Phase::Holding { .. }));
    assert!(!held.hover.settling());
}
