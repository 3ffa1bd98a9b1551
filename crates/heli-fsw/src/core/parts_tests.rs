//! Component tests of the core's small parts: names the ground and the logs read, the phase's
//! kind and target, the degraded-estimate landing, the pre-flight check, the refusal while
//! calibrating.

use super::tests::{gps_fix, uplink};
use super::*;
use heli_control::safety::Condition;
use nalgebra::UnitQuaternion;

const S: u64 = 1_000_000;

#[test]
fn names_round_trip() {
    for s in Severity::ALL {
        assert_eq!(Severity::from_name(s.name()), Some(s));
    }
    assert_eq!(Severity::Fatal.name(), "fatal");
    assert_eq!(Severity::from_name("loud"), None);
    assert_eq!(RollStage::PullUp { since_us: 0 }.name(), "pull-up");
    assert_eq!(
        heli_types::PlanError::BadValue("speed").to_string(),
        "bad plan value: speed"
    );
    assert!(
        heli_types::PlanError::TooManyLegs
            .to_string()
            .contains("at most")
    );
}

#[test]
fn phases_with_a_target_say_so_and_a_roll_stage_is_a_kind_of_its_own() {
    let target = Target::hold(Vector3::new(1.0, 2.0, -3.0), 0.5);
    assert_eq!(
        Phase::Holding {
            target,
            since_us: 0
        }
        .target(),
        Some(target)
    );
    assert_eq!(Phase::Manual.target(), None);
    let stage = |stage| Phase::Maneuver {
        target,
        stage,
        rolls_done: 0,
    };
    let pull_up = stage(RollStage::PullUp { since_us: 0 });
    assert!(pull_up.same_kind(&stage(RollStage::PullUp { since_us: 9 })));
    assert!(!pull_up.same_kind(&stage(RollStage::Recover { since_us: 0 })));
    assert!(Phase::Landed.same_kind(&Phase::Landed));
    assert!(!Phase::Landed.same_kind(&Phase::Manual));
}

fn est(height_m: f64) -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.4),
        vel_ned_mps: Vector3::zeros(),
        pos_ned_m: Vector3::new(5.0, 6.0, -height_m),
        rate_body_rps: Vector3::zeros(),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

/// A core whose filter fused GPS fixes, the last at [`FIX_US`].
fn core_with_a_fix() -> FlightCore {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    core.nav.initialise(
        0,
        &heli_nav::ImuBiases {
            gyro_rps: Vector3::zeros(),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
            samples: 100,
        },
    );
    core.nav.fuse_gps(0, &gps_fix(8));
    core.nav.fuse_gps(FIX_US, &gps_fix(8));
    assert_eq!(core.nav.stats().last_gps_fused_us, FIX_US);
    core
}

/// When the filter last fused a fix (µs).
const FIX_US: u64 = 100_000;

#[test]
fn a_degraded_estimate_lands_an_autonomous_flight_after_twenty_seconds_without_gps() {
    let hold = Phase::Holding {
        target: Target::hold(Vector3::new(5.0, 6.0, -10.0), 0.4),
        since_us: 0,
    };
    let limit_us = FIX_US + (degraded::GPS_LOSS_LAND_AFTER_S * 1e6) as u64;
    let mut out = Vec::new();
    let mut core = core_with_a_fix();
    core.seq.airborne_once = true;
    core.seq.phase = hold;
    assert_eq!(core.land_if_degraded(&est(10.0), limit_us, &mut out), None);
    let landing = core.land_if_degraded(&est(10.0), limit_us + 1, &mut out);
    assert_eq!(landing, Some(degraded::land_where_it_is(&est(10.0))));
    assert!(core.seq.plan_abandoned);
    assert!(matches!(
        out.last(),
        Some(Action::Event(e)) if matches!(e.value, CoreEvent::EstimateDegraded { .. })
    ));
    // Not flown yet, or the pilot flying, or no fix ever: not this rule's to land.
    for (airborne, phase) in [(false, hold), (true, Phase::Manual)] {
        let mut core = core_with_a_fix();
        core.seq.airborne_once = airborne;
        core.seq.phase = phase;
        assert_eq!(core.land_if_degraded(&est(10.0), 60 * S, &mut out), None);
    }
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    core.seq.airborne_once = true;
    core.seq.phase = hold;
    assert_eq!(core.land_if_degraded(&est(10.0), 60 * S, &mut out), None);
    // The landing itself: slowly down where it is, on its heading.
    match degraded::land_where_it_is(&est(10.0)) {
        Phase::Landing {
            target,
            settled_since_us: None,
        } => {
            assert_eq!(target.pos_ned_m, est(10.0).pos_ned_m);
            assert_eq!(target.vel_ned_mps, Vector3::new(0.0, 0.0, 0.5));
            assert!((target.yaw_rad - 0.4).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_pre_flight_check_wants_a_fresh_fix_from_enough_satellites() {
    let mut core = core_with_a_fix();
    assert_eq!(core.preflight(0), Some(preflight::Refusal::ImuNotHealthy));
    for device in Device::ALL {
        core.devices.health.monitor_mut(device).sample(0);
    }
    core.aiding.last_good_fix = Some((0, gps_fix(8)));
    let fresh_us = FIX_US + (preflight::GPS_FRESH_S * 1e6) as u64;
    assert!(
        !matches!(core.preflight(fresh_us), Some(preflight::Refusal::GpsStale)),
        "{:?}",
        core.preflight(fresh_us)
    );
    assert_eq!(
        core.preflight(fresh_us + 1),
        Some(preflight::Refusal::GpsStale)
    );
    core.aiding.last_good_fix = Some((0, gps_fix(preflight::MIN_SATELLITES - 1)));
    assert_eq!(
        core.preflight(0),
        Some(preflight::Refusal::TooFewSatellites(
            preflight::MIN_SATELLITES - 1
        ))
    );
    core.aiding.last_good_fix = Some((0, gps_fix(preflight::MIN_SATELLITES)));
    assert!(!matches!(
        core.preflight(0),
        Some(preflight::Refusal::TooFewSatellites(_))
    ));
    let no_fix = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let mut no_fix = no_fix;
    for device in Device::ALL {
        no_fix.devices.health.monitor_mut(device).sample(0);
    }
    assert_eq!(no_fix.preflight(0), Some(preflight::Refusal::NoGpsFix));
}

#[test]
fn while_calibrating_the_switch_on_is_refused_once_and_forgotten_when_off() {
    let mut core = FlightCore::new(
        CoreConfig::default(),
        FlightParams {
            mode: FlightMode::Autonomous,
            plan: Plan::hover(10.0, 60.0),
        },
    );
    let mut out = Vec::new();
    // Switch off, or no pilot: nothing.
    core.refuse_while_calibrating(0, &mut out);
    core.devices.pilot = Some(uplink(false, false));
    core.refuse_while_calibrating(0, &mut out);
    assert!(out.is_empty());
    // Switch on: refused, naming the calibration; once.
    core.devices.pilot = Some(uplink(true, false));
    core.refuse_while_calibrating(1, &mut out);
    core.refuse_while_calibrating(2, &mut out);
    let refused: Vec<_> = out
        .iter()
        .filter_map(|a| match a {
            Action::Event(e) => match e.value {
                CoreEvent::ModeRefused(r) => Some(r),
                _ => None,
            },
            _ => None,
        })
        .collect();
    assert_eq!(refused.len(), 1);
    assert!(
        refused[0]
            .verdict
            .wanted_true
            .contains(Condition::Calibrated)
    );
    // A lost signal or the bypass asks for nothing: the refusal is forgotten.
    for pilot in [
        uplink(true, true),
        PilotUplink {
            bypass: true,
            ..uplink(true, false)
        },
    ] {
        core.devices.pilot = Some(pilot);
        core.refuse_while_calibrating(3, &mut out);
        assert_eq!(core.modes.refusal_raised, None);
        core.devices.pilot = Some(uplink(true, false));
        core.refuse_while_calibrating(4, &mut out);
        assert!(core.modes.refusal_raised.is_some());
    }
    // The manual mode asks for nothing to refuse.
    let mut manual = FlightCore::new(CoreConfig::default(), FlightParams::default());
    manual.devices.pilot = Some(uplink(true, false));
    let mut out = Vec::new();
    manual.refuse_while_calibrating(0, &mut out);
    assert!(out.is_empty());
}

#[test]
fn the_uplink_condition_is_a_healthy_board_that_is_not_lost() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    core.devices.health.monitor_mut(Device::Uplink).sample(0);
    assert_eq!(core.safety_facts().get(Condition::Uplink), Some(true));
    core.devices.uplink_lost = true;
    assert_eq!(core.safety_facts().get(Condition::Uplink), Some(false));
}

#[test]
fn an_input_with_any_value_that_is_not_a_number_is_refused() {
    let imu = ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 20.0,
    };
    assert!(input_is_finite(&Input::Imu(imu)));
    for i in 0..3 {
        let mut bad = imu;
        bad.rate_rps[i] = f64::NAN;
        assert!(!input_is_finite(&Input::Imu(bad)));
        let mut bad = imu;
        bad.accel_mps2[i] = f64::INFINITY;
        assert!(!input_is_finite(&Input::Imu(bad)));
    }
    let fix = gps_fix(8);
    assert!(input_is_finite(&Input::Gps(fix)));
    for bad in [
        GpsNav {
            lat_deg: f64::NAN,
            ..fix
        },
        GpsNav {
            lon_deg: f64::NAN,
            ..fix
        },
        GpsNav {
            alt_m: f64::NAN,
            ..fix
        },
        GpsNav {
            vel_ned_mps: [0.0, f64::NAN, 0.0],
            ..fix
        },
    ] {
        assert!(!input_is_finite(&Input::Gps(bad)), "{bad:?}");
    }
    assert!(input_is_finite(&Input::Baro {
        pressure_mbar: 1000.0
    }));
    assert!(!input_is_finite(&Input::Baro { pressure_mbar: 0.0 }));
    assert!(!input_is_finite(&Input::Baro {
        pressure_mbar: f64::NAN
    }));
    let pilot = uplink(false, false);
    assert!(input_is_finite(&Input::Uplink(pilot)));
    assert!(!input_is_finite(&Input::Uplink(PilotUplink {
        receiver_batt_v: f64::NAN,
        ..pilot
    })));
    assert!(!input_is_finite(&Input::Uplink(PilotUplink {
        servo_batt_v: f64::NAN,
        ..pilot
    })));
    assert!(!input_is_finite(&Input::Battery { volts: f64::NAN }));
    assert!(input_is_finite(&Input::Battery { volts: 11.0 }));
}

#[test]
fn the_pilots_signal_lost_is_raised_when_it_goes() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let mut out = Vec::new();
    core.handle(Input::Uplink(uplink(false, false)), 10, &mut out);
    assert!(!super::tests::raised(&out, CoreEvent::PilotSignalLost));
    core.handle(Input::Uplink(uplink(false, true)), 20, &mut out);
    assert!(super::tests::raised(&out, CoreEvent::PilotSignalLost));
    out.clear();
    core.handle(Input::Uplink(uplink(false, true)), 30, &mut out);
    assert!(
        !super::tests::raised(&out, CoreEvent::PilotSignalLost),
        "raised once"
    );
}

#[test]
fn each_event_has_the_severity_its_consequence_calls_for() {
    use heli_power::Level;
    let level = |level| CoreEvent::BatteryLevel {
        battery: power::Battery::Flight,
        level,
        percent: 30,
        minutes_left: 4,
    };
    let health = |device, state| CoreEvent::DeviceHealth { device, state };
    for (event, severity) in [
        (CoreEvent::PhaseChanged(Phase::Manual), Severity::ActivityLo),
        (CoreEvent::PlanComplete, Severity::ActivityHi),
        (CoreEvent::AlignedInAir { gps: true }, Severity::ActivityHi),
        (level(Level::Good), Severity::ActivityLo),
        (level(Level::Warning), Severity::WarningHi),
        (level(Level::Critical), Severity::Fatal),
        (CoreEvent::WatchdogFired, Severity::WarningLo),
        (CoreEvent::RollAbandoned, Severity::WarningLo),
        (CoreEvent::GpsLost, Severity::WarningHi),
        (CoreEvent::RestartedInAir, Severity::WarningHi),
        (health(Device::Gps, HealthState::Ok), Severity::ActivityLo),
        (health(Device::Gps, HealthState::Late), Severity::WarningLo),
        (
            health(Device::Gps, HealthState::Silent),
            Severity::WarningHi,
        ),
        (health(Device::Imu, HealthState::Failed), Severity::Fatal),
        (CoreEvent::EstimateInvalid, Severity::Fatal),
        (CoreEvent::EngineFailure { rotor_rpm: 900 }, Severity::Fatal),
    ] {
        assert_eq!(event.severity(), severity, "{event:?}");
    }
}

#[test]
fn a_plan_with_a_value_out_of_range_is_refused_naming_the_leg() {
    let refused = |leg| match Plan::new(&[leg]) {
        Err(heli_types::PlanError::BadValue(text)) => text,
        other => panic!("{other:?}"),
    };
    assert!(refused(Leg::Takeoff { alt_m: 0.5 }).contains("take-off"));
    assert!(refused(Leg::Hold { seconds: -1.0 }).contains("hold"));
    assert!(
        refused(Leg::Fly {
            north_m: 5000.0,
            east_m: 0.0,
            alt_m: 10.0,
            speed_mps: 3.0
        })
        .contains("fly")
    );
    assert!(
        refused(Leg::Rolls {
            count: 11,
            speed_mps: 5.0
        })
        .contains("rolls")
    );
    assert!(Plan::new(&[Leg::Land]).is_ok());
}

#[test]
fn the_pre_flight_refusals_say_what_is_missing() {
    use preflight::Refusal;
    assert_eq!(Refusal::NoGpsFix.text(), "no GPS fix");
    assert!(Refusal::GpsStale.text().contains("in the last 3 s"));
    assert_eq!(
        Refusal::TooFewSatellites(3).text(),
        "3 satellites, fewer than 5"
    );
    assert_eq!(Refusal::ImuNotHealthy.text(), "the IMU is not on time");
}

#[test]
fn motion_in_the_calibration_window_is_left_out_and_said() {
    let mut core = FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 10.0,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    );
    let mut out = Vec::new();
    let still = super::tests::still();
    // Still for three seconds, then turning for one and a half (each second of the window is
    // compared with the median of its seconds).
    for k in 0..300u64 {
        core.handle(Input::Imu(still), k * 10_000, &mut out);
    }
    let shaken = ImuRepr {
        rate_rps: [0.5, 0.0, 0.0],
        ..still
    };
    for k in 300..450u64 {
        core.handle(Input::Imu(shaken), k * 10_000, &mut out);
    }
    let left: Vec<_> = out
        .iter()
        .filter_map(|a| match a {
            Action::Event(e) => match e.value {
                CoreEvent::CalibrationLeftOut(l) => Some(l),
                _ => None,
            },
            _ => None,
        })
        .collect();
    assert_eq!(left.len(), 1, "{out:?}");
    assert!(left[0].motion.rate_rps > 0.4, "{left:?}");
    assert!(!restarted(&out));
    assert!(core.navigator().state().is_none());
}

#[test]
fn a_calibration_held_up_tells_the_operator_why_and_what_to_do() {
    let mut c = super::calibration::GroundCalibration::new(0.0, 60.0);
    let mut raised = Vec::new();
    let still = super::tests::still();
    let turning = |rate: f64| ImuRepr {
        rate_rps: [0.0, 0.0, rate],
        ..still
    };
    // Three seconds still, then swinging one way and back two seconds in three: seconds left
    // out until more moved than were still, then restarts.
    for k in 0..20_000u64 {
        let s = match (k / 100) % 3 {
            _ if k <= 300 => still,
            0 => still,
            1 => turning(0.3),
            _ => turning(-0.3),
        };
        c.push(&s, &mut |e| raised.push(e));
    }
    let held: Vec<(u32, u32)> = raised
        .iter()
        .filter_map(|e| match e {
            CoreEvent::CalibrationHeldUp {
                restarts,
                left_out_s,
            } => Some((*restarts, *left_out_s)),
            _ => None,
        })
        .collect();
    assert!(
        held.iter()
            .any(|(r, _)| *r == super::calibration::HELD_UP_RESTARTS),
        "{held:?} from {raised:?}"
    );
    assert!(
        held.iter()
            .all(|(r, s)| *r % super::calibration::HELD_UP_RESTARTS == 0
                || *s % super::calibration::HELD_UP_LEFT_OUT_S == 0),
        "{held:?}"
    );
    assert_eq!(
        CoreEvent::CalibrationHeldUp {
            restarts: 3,
            left_out_s: 0
        }
        .severity(),
        Severity::WarningHi
    );
}

#[test]
fn the_gauges_can_be_told_the_temperature() {
    let config = power::PowerConfig::default().at_temperature(-5.0);
    assert_eq!(config.flight.temperature_c, -5.0);
    assert_eq!(config.receiver.temperature_c, -5.0);
    assert_eq!(config.servo.temperature_c, -5.0);
}

/// A core in its calibration window (warm-up over), for the compass's watch.
fn accumulating() -> FlightCore {
    let mut core = FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 60.0,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    );
    let mut out = Vec::new();
    for k in 0..20u64 {
        core.handle(Input::Imu(super::tests::still()), k * 10_000, &mut out);
    }
    assert!(matches!(
        core.calibration.phase(),
        heli_nav::CalibrationPhase::Accumulating { .. }
    ));
    core
}

fn restarted(out: &[Action]) -> bool {
    out.iter().any(
        |a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::CalibrationRestarted(_))),
    )
}

fn compass_said(out: &[Action]) -> usize {
    out.iter()
        .filter(|a| {
            matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::CalibrationCompassMoved { .. }))
        })
        .count()
}

/// Two seconds of still IMU samples from `from_us` through `core`: the gyros' judgement.
fn still_seconds(core: &mut FlightCore, from_us: u64, out: &mut Vec<Action>) -> u64 {
    let mut t = from_us;
    for _ in 0..200 {
        t += 10_000;
        core.handle(Input::Imu(super::tests::still()), t, out);
    }
    t
}

#[test]
fn a_compass_heading_moving_five_degrees_is_said_once_and_restarts_nothing() {
    let mut core = accumulating();
    let mut out = Vec::new();
    for _ in 0..50 {
        core.watch_calibration_heading(1.0);
    }
    let t = still_seconds(&mut core, 200_000, &mut out);
    assert_eq!(compass_said(&out), 0, "a steady heading");
    assert_eq!(core.calibration.heading, Some((1.0, 1.0)));
    // Jumped to 1.3 rad: the average moves a twentieth of the way each reading, and passes
    // 0.087 rad from the reference on the seventh (0.3 × (1 − 0.95⁷) = 0.090).
    for _ in 0..6 {
        core.watch_calibration_heading(1.3);
    }
    let t = still_seconds(&mut core, t, &mut out);
    assert_eq!(compass_said(&out), 0);
    let (_, smoothed) = core.calibration.heading.unwrap();
    assert!(
        (smoothed - (1.3 - 0.3 * 0.95f64.powi(6))).abs() < 1e-9,
        "{smoothed}"
    );
    for _ in 0..20 {
        core.watch_calibration_heading(1.3);
    }
    assert_eq!(compass_said(&out), 0, "not before the gyros have judged");
    let t = still_seconds(&mut core, t, &mut out);
    assert_eq!(compass_said(&out), 1, "the gyros saw it still");
    for _ in 0..20 {
        core.watch_calibration_heading(1.6);
    }
    still_seconds(&mut core, t, &mut out);
    assert_eq!(compass_said(&out), 1, "once a window");
    assert!(!restarted(&out), "the compass never restarts the window");
    // Across north the move is measured the short way.
    let mut core = accumulating();
    let mut out = Vec::new();
    core.watch_calibration_heading(3.1);
    for _ in 0..6 {
        core.watch_calibration_heading(-3.1);
    }
    still_seconds(&mut core, 200_000, &mut out);
    assert_eq!(compass_said(&out), 0, "0.08 rad the short way round");
    // A reading that is not a number, or outside the window, forgets the reference.
    core.watch_calibration_heading(f64::NAN);
    assert_eq!(core.calibration.heading, None);
    let mut idle = FlightCore::new(CoreConfig::default(), FlightParams::default());
    idle.watch_calibration_heading(1.0);
    assert_eq!(idle.calibration.heading, None);
}

#[test]
fn a_refusal_is_raised_again_only_for_something_new() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let facts = |gps: bool, compass: bool| {
        heli_control::safety::Facts::none()
            .with(Condition::Gps, gps)
            .with(Condition::Compass, compass)
    };
    const RULE: &[heli_control::safety::Rule] = &[
        heli_control::safety::Rule::Is(Condition::Gps),
        heli_control::safety::Rule::Is(Condition::Compass),
    ];
    let refusal = |gps, compass| ModeRefusal {
        mode: FlightMode::Autonomous,
        verdict: heli_control::safety::Rule::All(RULE).judge(facts(gps, compass)),
    };
    let count = |out: &[Action]| {
        out.iter()
            .filter(
                |a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::ModeRefused(_))),
            )
            .count()
    };
    let mut out = Vec::new();
    core.raise_refusal(refusal(false, true), 1, &mut out);
    core.raise_refusal(refusal(false, true), 2, &mut out);
    assert_eq!(count(&out), 1, "the same reason once");
    core.raise_refusal(refusal(true, false), 3, &mut out);
    assert_eq!(count(&out), 2, "a new reason");
    // Both now known: either again raises nothing.
    core.raise_refusal(refusal(false, true), 4, &mut out);
    core.raise_refusal(refusal(false, false), 5, &mut out);
    assert_eq!(count(&out), 2);
    // Another mode is news.
    let mut other = refusal(false, true);
    other.mode = FlightMode::Augmented(AugmentedMode::Rate);
    core.raise_refusal(other, 6, &mut out);
    assert_eq!(count(&out), 3);
}

#[test]
fn a_failed_board_is_a_transmitter_loss_raised_once() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let mut out = Vec::new();
    core.handle(Input::DeviceFailed(Device::Uplink), 10, &mut out);
    core.handle(Input::DeviceFailed(Device::Uplink), 20, &mut out);
    let lost = out
        .iter()
        .filter(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::UplinkLost))
        .count();
    assert_eq!(lost, 1);
    assert!(core.devices.uplink_lost);
    // Another device failing is not the board.
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    core.handle(Input::DeviceFailed(Device::Gps), 10, &mut out);
    assert!(!core.devices.uplink_lost);
}
