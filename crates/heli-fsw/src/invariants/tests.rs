//! Tests of the invariants' checker: a real core keeps them, and each broken one is
//! reported as what it is.

use super::*;
use crate::core::{CoreConfig, FlightParams, Input};
use crate::phase::Phase;
use crate::streams::{ImuRecord, Stamped};
use heli_proto::imu::ImuRepr;

fn still() -> ImuRepr {
    ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
}

/// A started core after `samples` IMU packets 10 ms apart, its checker, and the
/// actions of the last packet (a control step when `samples` is even).
fn stepped(samples: u64) -> (FlightCore, Invariants, Vec<Action>, u64) {
    let config = CoreConfig {
        imu_warm_up_s: 0.1,
        calibration_s: 1.0,
        ..CoreConfig::default()
    };
    let mut core = FlightCore::new(config, FlightParams::default());
    core.start(0);
    let mut checker = Invariants::new(&core, config.watchdog_us);
    let mut out = Vec::new();
    let mut t = 0;
    for k in 1..=samples {
        t = k * 10_000;
        out.clear();
        core.handle(Input::Imu(still()), t, &mut out);
        if k < samples {
            checker.check(&core, t, &out).unwrap();
        }
    }
    (core, checker, out, t)
}

#[test]
fn a_real_run_keeps_them() {
    let (core, mut checker, out, t) = stepped(200);
    assert_eq!(checker.check(&core, t, &out), Ok(()));
    assert_eq!(checker.checked(), 200);
}

#[test]
fn a_servo_command_out_of_range_breaks_them() {
    let (core, mut checker, mut out, t) = stepped(200);
    for a in &mut out {
        if let Action::Servo(s) = a {
            s.value.collective = 1.2;
        }
    }
    assert!(matches!(
        checker.check(&core, t, &out),
        Err(Violation::ServoOutOfRange(_))
    ));
    let (core, mut checker, mut out, t) = stepped(200);
    for a in &mut out {
        if let Action::Servo(s) = a {
            s.value.throttle = f64::NAN;
        }
    }
    assert!(checker.check(&core, t, &out).is_err());
}

#[test]
fn a_missing_or_extra_servo_command_breaks_them() {
    let (core, mut checker, mut out, t) = stepped(200);
    out.retain(|a| !matches!(a, Action::Servo(_)));
    assert_eq!(
        checker.check(&core, t, &out),
        Err(Violation::ServoWithoutStep {
            servos: 0,
            steps: 1
        })
    );
}

#[test]
fn an_action_stamped_at_another_time_breaks_them() {
    let (core, mut checker, out, t) = stepped(200);
    assert_eq!(
        checker.check(&core, t + 1, &out),
        Err(Violation::ActionTime {
            input_us: t + 1,
            action_us: t
        })
    );
}

#[test]
fn a_stream_going_back_breaks_them() {
    let (core, mut checker, mut out, t) = stepped(199);
    out.push(Action::Publish(Record::Imu(Stamped::new(
        t - 5_000,
        ImuRecord {
            imu: still(),
            repeated: false,
        },
    ))));
    assert!(matches!(
        checker.check(&core, t, &out),
        Err(Violation::StreamWentBack { stream: "imu", .. })
    ));
}

#[test]
fn two_records_of_one_stream_at_the_same_time_keep_them() {
    // Two fixes in one microsecond (two packets in one read) are two records, not time
    // going back.
    let (core, mut checker, mut out, t) = stepped(199);
    let record = Action::Publish(Record::Imu(Stamped::new(
        t,
        ImuRecord {
            imu: still(),
            repeated: false,
        },
    )));
    out.push(record);
    out.push(record);
    assert_eq!(checker.check(&core, t, &out), Ok(()));
}

fn has_phase_event(actions: &[Action]) -> bool {
    actions
        .iter()
        .any(|a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::PhaseChanged(_))))
}

#[test]
fn a_phase_change_without_its_event_breaks_them() {
    // The calibration ends about 1.1 s in, and the phase goes to manual with its event.
    let n = (100..=130)
        .find(|n| has_phase_event(&stepped(*n).2))
        .expect("the calibration ends within 1.3 s");
    let (core, mut checker, out, t) = stepped(n);
    assert_eq!(checker.check(&core, t, &out), Ok(()));
    let (core, mut checker, mut out, t) = stepped(n);
    out.retain(|a| !matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::PhaseChanged(_))));
    assert!(matches!(
        checker.check(&core, t, &out),
        Err(Violation::PhaseEventMismatch { .. })
    ));
    // An event for a phase not taken breaks them too.
    let (core, mut checker, mut out, t) = stepped(n + 2);
    out.push(Action::Event(Stamped::new(
        t,
        CoreEvent::PhaseChanged(Phase::Landed),
    )));
    assert!(matches!(
        checker.check(&core, t, &out),
        Err(Violation::PhaseEventMismatch { .. })
    ));
}

#[test]
fn a_watchdog_deadline_too_far_or_disarmed_breaks_them() {
    let config = CoreConfig::default();
    let new = || FlightCore::new(config, FlightParams::default());
    // Armed a period after a time the checker is shown: further than one period.
    let mut core = new();
    let mut checker = Invariants::new(&core, config.watchdog_us);
    core.start(1_000_000);
    assert!(matches!(
        checker.check(&core, 500_000, &[]),
        Err(Violation::WatchdogUnbounded { .. })
    ));
    // Armed, then shown a core whose watchdog is not.
    let mut core = new();
    core.start(0);
    let mut checker = Invariants::new(&core, config.watchdog_us);
    assert_eq!(checker.check(&core, 1_000, &[]), Ok(()));
    assert!(matches!(
        checker.check(&new(), 2_000, &[]),
        Err(Violation::WatchdogUnbounded {
            poll_at_us: None,
            ..
        })
    ));
}

#[test]
fn a_bad_estimate_breaks_them() {
    let (core, _, _, _) = stepped(200);
    let nav = core.navigator();
    let state = *nav.state().expect("calibrated");
    let p = *nav.covariance();
    assert_eq!(check_state(&state, &p), Ok(()));
    let mut bad = state;
    bad.att =
        nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.1, 0.0, 0.0));
    assert!(matches!(
        check_state(&bad, &p),
        Err(Violation::QuaternionNorm(_))
    ));
    for norm in [f64::NAN, f64::INFINITY, 1.0 + 2e-6, 1.0 - 2e-6] {
        assert!(!unit_norm(norm), "{norm}");
    }
    assert!(unit_norm(1.0 + 5e-7));
    let mut bad = state;
    bad.gyro_bias_rps.y = f64::INFINITY;
    assert_eq!(check_state(&bad, &p), Err(Violation::EstimateNotFinite));
    let mut asymmetric = p;
    asymmetric[(2, 5)] += 1e-3 * p[(2, 2)].max(p[(5, 5)]);
    assert_eq!(
        check_state(&state, &asymmetric),
        Err(Violation::Covariance { row: 2, col: 5 })
    );
    let mut negative = p;
    negative[(7, 7)] = -1e-6;
    assert_eq!(
        check_state(&state, &negative),
        Err(Violation::Covariance { row: 7, col: 7 })
    );
    let mut correlated = p;
    let c = 2.0 * (p[(0, 0)] * p[(1, 1)]).sqrt();
    correlated[(0, 1)] = c;
    correlated[(1, 0)] = c;
    assert_eq!(
        check_state(&state, &correlated),
        Err(Violation::Covariance { row: 0, col: 1 })
    );
}

/// A covariance with variances 4 and 9 on the first two axes, correlated by `p01`.
fn covariance(p01: f64) -> Covariance {
    let mut p = Covariance::identity();
    p[(0, 0)] = 4.0;
    p[(1, 1)] = 9.0;
    p[(0, 1)] = p01;
    p[(1, 0)] = p01;
    p
}

#[test]
fn variances_are_positive_and_correlations_at_most_one() {
    let (core, _, _, _) = stepped(200);
    let state = *core.navigator().state().expect("calibrated");
    // Correlation 5.9 / 6 and exactly 1 (a singular but valid covariance).
    assert_eq!(check_state(&state, &covariance(5.9)), Ok(()));
    assert_eq!(check_state(&state, &covariance(6.0)), Ok(()));
    assert_eq!(
        check_state(&state, &covariance(6.1)),
        Err(Violation::Covariance { row: 0, col: 1 })
    );
    let mut zero = covariance(0.0);
    zero[(4, 4)] = 0.0;
    assert_eq!(
        check_state(&state, &zero),
        Err(Violation::Covariance { row: 4, col: 4 })
    );
    let mut nan = covariance(0.0);
    nan[(3, 2)] = f64::NAN;
    nan[(2, 3)] = f64::NAN;
    assert!(check_state(&state, &nan).is_err());
}

#[test]
fn an_estimate_with_values_that_are_not_numbers_breaks_them() {
    let mut nav = Navigator::new(heli_nav::NavConfig::default());
    assert_eq!(
        check_estimate(&nav),
        Ok(()),
        "no estimate yet: nothing to check"
    );
    nav.initialise(
        0,
        &heli_nav::ImuBiases {
            gyro_rps: nalgebra::Vector3::new(f64::NAN, 0.0, 0.0),
            mean_accel_mps2: nalgebra::Vector3::new(0.0, 0.0, -9.81),
            samples: 100,
        },
    );
    assert!(check_estimate(&nav).is_err());
}

#[test]
fn a_counter_going_down_breaks_them() {
    let (_, mut checker, _, _) = stepped(200);
    let mut fresh = FlightCore::new(CoreConfig::default(), FlightParams::default());
    fresh.start(2_000_000);
    assert_eq!(
        checker.check(&fresh, 2_000_000, &[]),
        Err(Violation::CounterWentDown("imu_samples"))
    );
    let before = CoreStats::default();
    for (name, after) in [
        (
            "watchdog_fires",
            CoreStats {
                watchdog_fires: 1,
                ..before
            },
        ),
        (
            "rolls_completed",
            CoreStats {
                rolls_completed: 1,
                ..before
            },
        ),
        (
            "gps_implausible",
            CoreStats {
                gps_implausible: 1,
                ..before
            },
        ),
    ] {
        assert_eq!(counters_went_down(&after, &before), Some(name));
        assert_eq!(counters_went_down(&before, &after), None);
    }
}

#[test]
fn a_change_of_roll_stage_or_of_pilot_mode_is_a_change_of_phase() {
    let target = heli_control::Target::hold(nalgebra::Vector3::zeros(), 0.0);
    let maneuver = |stage| Phase::Maneuver {
        target,
        stage,
        rolls_done: 0,
    };
    let accelerate = maneuver(crate::phase::RollStage::Accelerate { since_us: 0 });
    let pull_up = maneuver(crate::phase::RollStage::PullUp { since_us: 0 });
    assert_eq!(
        check_phase_events(&accelerate, &pull_up, &[pull_up]),
        Ok(())
    );
    assert!(check_phase_events(&accelerate, &pull_up, &[]).is_err());
    assert_eq!(check_phase_events(&accelerate, &accelerate, &[]), Ok(()));
    assert!(check_phase_events(&accelerate, &accelerate, &[accelerate]).is_err());
    let augmented = Phase::Augmented(heli_types::AugmentedMode::Rate);
    assert!(check_phase_events(&augmented, &Phase::Manual, &[]).is_err());
    assert!(
        check_phase_events(
            &Phase::Manual,
            &Phase::Landed,
            &[Phase::Landed, Phase::Landed]
        )
        .is_err()
    );
}

#[test]
fn a_report_counts_and_keeps_the_first() {
    let mut report = InvariantReport::default();
    report.record(10, Ok(()));
    report.record(20, Err(Violation::EstimateRevived));
    report.record(30, Err(Violation::EstimateNotFinite));
    assert_eq!(report.checked, 3);
    assert_eq!(report.violations, 2);
    assert_eq!(report.first, Some((20, Violation::EstimateRevived)));
    let mut later = InvariantReport::default();
    later.record(40, Err(Violation::QuaternionNorm(2.0)));
    let mut total = later;
    total.merge(&report);
    assert_eq!(total.checked, 4);
    assert_eq!(total.violations, 3);
    assert_eq!(total.first, Some((40, Violation::QuaternionNorm(2.0))));
    let mut clean = InvariantReport::default();
    clean.merge(&report);
    assert_eq!(clean.first, Some((20, Violation::EstimateRevived)));
}

#[test]
fn violations_say_what_broke() {
    let texts = [
        (
            Violation::ServoOutOfRange(Controls::default()),
            "servo command out of range",
        ),
        (
            Violation::ActionTime {
                input_us: 5,
                action_us: 4,
            },
            "action stamped 4 µs for an input at 5 µs",
        ),
        (
            Violation::StreamWentBack {
                stream: "gps",
                last_us: 9,
                now_us: 8,
            },
            "gps stream went back from 9 µs to 8 µs",
        ),
        (
            Violation::ServoWithoutStep {
                servos: 2,
                steps: 1,
            },
            "2 servo commands for 1 control steps",
        ),
        (
            Violation::CounterWentDown("uplinks"),
            "counter uplinks went down",
        ),
        (Violation::QuaternionNorm(1.5), "quaternion of norm 1.5"),
        (Violation::EstimateNotFinite, "not finite"),
        (Violation::Covariance { row: 1, col: 2 }, "at (1, 2)"),
        (
            Violation::WatchdogUnbounded {
                now_us: 7,
                poll_at_us: None,
            },
            "at 7 µs the next watchdog deadline is None",
        ),
        (Violation::EstimateRevived, "became valid again"),
        (
            Violation::PhaseEventMismatch {
                before: "hold",
                after: "fly",
            },
            "phase hold -> fly without",
        ),
        (
            Violation::IllegalTransition {
                from: "landed",
                to: "roll",
            },
            "illegal phase transition landed -> roll",
        ),
    ];
    for (v, text) in texts {
        assert!(v.to_string().contains(text), "{v}");
    }
}

#[test]
fn the_transition_rules() {
    use Kind::*;
    assert!(!legal(Pilot, Calibrating, false, false));
    assert!(legal(Calibrating, Pilot, false, false));
    assert!(legal(Holding, Maneuver, false, false));
    assert!(!legal(Pilot, Maneuver, false, false));
    assert!(!legal(Landed, Maneuver, false, false));
    assert!(legal(PreflightCheck, TakeoffRefused, false, false));
    assert!(!legal(Pilot, TakeoffRefused, false, false));
    assert!(legal(Landing, Landed, false, false));
    assert!(!legal(Holding, Landed, false, false));
    assert!(!legal(Flying, Autorotation, false, false));
    assert!(legal(Flying, Autorotation, true, false));
    assert!(!legal(Autorotation, Holding, true, false));
    assert!(!legal(Landed, TakingOff, false, false));
    assert!(legal(PreflightCheck, TakingOff, false, false));
    assert!(!legal(Pilot, TakingOff, true, false));
    assert!(legal(Maneuver, Maneuver, true, false));
    // A refused take-off standing: it returns from the ground failsafe that interrupted
    // it, and is neither checked again nor taken off from.
    assert!(!legal(GroundFailsafe, TakeoffRefused, false, false));
    assert!(legal(GroundFailsafe, TakeoffRefused, false, true));
    assert!(!legal(GroundFailsafe, PreflightCheck, false, true));
    assert!(!legal(GroundFailsafe, TakingOff, false, true));
    assert!(legal(GroundFailsafe, TakingOff, false, false));
    assert!(legal(TakeoffRefused, Pilot, false, true));
}
