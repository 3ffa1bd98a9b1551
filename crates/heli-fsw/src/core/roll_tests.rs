//! Component tests of the roll maneuver's stage machine (`roll.rs`): the machine is driven
//! directly, a step at a time, from a constructed estimate, and judged on the phase and the
//! events it emits.

use super::*;
use nalgebra::UnitQuaternion;
use roll::{BLIND_STOP_BEFORE_RAD, BlindRoll, blind_step};

const S: u64 = 1_000_000;

/// A core flying leg 1 of take-off, two rolls at 5 m/s, hold, land.
fn rolling_core() -> FlightCore {
    let plan = Plan::new(&[
        Leg::Takeoff { alt_m: 20.0 },
        Leg::Rolls {
            count: 2,
            speed_mps: 5.0,
        },
        Leg::Hold { seconds: 5.0 },
        Leg::Land,
    ])
    .unwrap();
    let mut core = FlightCore::new(
        CoreConfig::default(),
        FlightParams {
            mode: FlightMode::Autonomous,
            plan,
        },
    );
    core.seq.leg = 1;
    core
}

/// Level, heading north, at `vel` (m/s NED), rolling at `p_rps`.
fn est(vel: Vector3<f64>, p_rps: f64) -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::identity(),
        vel_ned_mps: vel,
        pos_ned_m: Vector3::new(10.0, 5.0, -20.0),
        rate_body_rps: Vector3::new(p_rps, 0.0, 0.0),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

/// The trajectory's point, moving north at the trim speed of 5 m/s.
fn target() -> Target {
    Target {
        pos_ned_m: Vector3::new(1.0, 2.0, -20.0),
        vel_ned_mps: Vector3::new(5.0, 0.0, 0.0),
        yaw_rad: 0.0,
    }
}

fn step(
    core: &mut FlightCore,
    e: &NavState,
    now_us: u64,
    stage: RollStage,
    done: u32,
) -> (Phase, Vec<Action>) {
    let mut out = Vec::new();
    let phase = core.maneuver(e, now_us, 0.02, target(), stage, done, &mut out);
    (phase, out)
}

fn stage_of(phase: Phase) -> RollStage {
    match phase {
        Phase::Maneuver { stage, .. } => stage,
        other => panic!("not a maneuver: {other:?}"),
    }
}

#[test]
fn it_accelerates_until_settled_on_the_trim_speed_for_six_seconds() {
    let mut core = rolling_core();
    let trim = est(Vector3::new(5.0, 0.0, 0.0), 0.0);
    let accelerate = RollStage::Accelerate { since_us: 0 };
    let (phase, _) = step(&mut core, &trim, 6 * S, accelerate, 0);
    assert_eq!(
        stage_of(phase),
        accelerate,
        "six seconds is not more than six"
    );
    let (phase, _) = step(&mut core, &trim, 6 * S + 1, accelerate, 0);
    assert_eq!(
        stage_of(phase),
        RollStage::PullUp {
            since_us: 6 * S + 1
        }
    );
    // 0.9 m/s off the trim is settled; 1.0 is not.
    let near = est(Vector3::new(5.0, 0.9, 0.0), 0.0);
    assert!(matches!(
        stage_of(step(&mut core, &near, 7 * S, accelerate, 0).0),
        RollStage::PullUp { .. }
    ));
    let off = est(Vector3::new(5.0, 1.0, 0.0), 0.0);
    assert_eq!(
        stage_of(step(&mut core, &off, 7 * S, accelerate, 0).0),
        accelerate
    );
    // While accelerating the trajectory is carried along at its velocity, which speeds up
    // toward the trim at the run-up's rate, and is the trim's once that close.
    let slower = Target {
        vel_ned_mps: Vector3::new(4.0, 0.0, 0.0),
        ..target()
    };
    let ramp = |core: &mut FlightCore, e: &NavState, t: Target| {
        let Phase::Maneuver { target, stage, .. } =
            core.maneuver(e, 7 * S, 0.02, t, accelerate, 0, &mut Vec::new())
        else {
            unreachable!()
        };
        (target, stage)
    };
    let (t, _) = ramp(&mut core, &off, slower);
    assert!((t.pos_ned_m - Vector3::new(1.0 + 4.0 * 0.02, 2.0, -20.0)).norm() < 1e-12);
    let sped_up = 4.0 + roll::RUN_UP_ACCEL_MPS2 * 0.02;
    assert!((t.vel_ned_mps - Vector3::new(sped_up, 0.0, 0.0)).norm() < 1e-12);
    let nearly = Target {
        vel_ned_mps: Vector3::new(5.0 - 0.5 * roll::RUN_UP_ACCEL_MPS2 * 0.02, 0.0, 0.0),
        ..target()
    };
    assert_eq!(
        ramp(&mut core, &off, nearly).0.vel_ned_mps,
        Vector3::new(5.0, 0.0, 0.0)
    );
    // Settled, but the trajectory still short of the trim speed: no pull-up yet.
    let (_, stage) = ramp(&mut core, &near, slower);
    assert_eq!(stage, accelerate);
    let (_, stage) = ramp(&mut core, &near, nearly);
    assert!(matches!(stage, RollStage::PullUp { .. }), "{stage:?}");
}

#[test]
fn a_run_up_begun_in_motion_starts_at_the_helicopters_speed_along_the_heading() {
    let leg = Some(Leg::Rolls {
        count: 1,
        speed_mps: 8.0,
    });
    let begun = |vel: Vector3<f64>| {
        let phase = Phase::Maneuver {
            target: Target {
                vel_ned_mps: Vector3::zeros(),
                yaw_rad: 0.0,
                ..target()
            },
            stage: RollStage::Accelerate { since_us: 0 },
            rolls_done: 0,
        };
        match roll::run_up_from(phase, leg, &est(vel, 0.0)) {
            Phase::Maneuver { target, .. } => target.vel_ned_mps,
            other => panic!("{other:?}"),
        }
    };
    // 6 m/s north and 2 east, the heading north: 6 north.
    assert_eq!(
        begun(Vector3::new(6.0, 2.0, 0.5)),
        Vector3::new(6.0, 0.0, 0.0)
    );
    // Backwards: from rest; past the trim: at the trim.
    assert_eq!(begun(Vector3::new(-3.0, 0.0, 0.0)), Vector3::zeros());
    assert_eq!(
        begun(Vector3::new(11.0, 0.0, 0.0)),
        Vector3::new(8.0, 0.0, 0.0)
    );
    assert_eq!(begun(Vector3::new(f64::NAN, 0.0, 0.0)), Vector3::zeros());
    // Any other phase, or another leg, is left as it is.
    let hold = Phase::Holding {
        target: target(),
        since_us: 0,
    };
    assert_eq!(
        roll::run_up_from(hold, leg, &est(Vector3::new(6.0, 0.0, 0.0), 0.0)),
        hold
    );
}

#[test]
fn a_faster_trim_is_run_up_to_for_longer_then_settled_on() {
    // 15 m/s at 2 m/s²: 7.5 s of speeding up and 3 s at the trim before the pull-up.
    let mut core = rolling_core();
    core.seq.params.plan = Plan::new(&[
        Leg::Takeoff { alt_m: 20.0 },
        Leg::Rolls {
            count: 1,
            speed_mps: 15.0,
        },
    ])
    .unwrap();
    let trim = est(Vector3::new(15.0, 0.0, 0.0), 0.0);
    let accelerate = RollStage::Accelerate { since_us: 0 };
    let run_up_us = ((15.0 / roll::RUN_UP_ACCEL_MPS2 + roll::RUN_UP_SETTLE_S) * 1e6) as u64;
    let at_trim = Target {
        vel_ned_mps: Vector3::new(15.0, 0.0, 0.0),
        ..target()
    };
    let mut at = |now_us| {
        stage_of(core.maneuver(&trim, now_us, 0.02, at_trim, accelerate, 0, &mut Vec::new()))
    };
    assert_eq!(at(run_up_us), accelerate);
    assert!(matches!(at(run_up_us + 1), RollStage::PullUp { .. }));
}

#[test]
fn never_settled_it_gives_up_the_rolls_after_the_timeout() {
    let mut core = rolling_core();
    let off = est(Vector3::new(2.0, 0.0, 0.0), 0.0);
    let accelerate = RollStage::Accelerate { since_us: 0 };
    // Counted from the end of the trajectory's ramp (5 m/s at 2 m/s²: 2.5 s).
    let at = ((ACCELERATE_TIMEOUT_S + 5.0 / roll::RUN_UP_ACCEL_MPS2) * 1e6) as u64;
    assert_eq!(
        stage_of(step(&mut core, &off, at, accelerate, 0).0),
        accelerate
    );
    let (phase, _) = step(&mut core, &off, at + 1, accelerate, 0);
    assert!(matches!(phase, Phase::Holding { .. }), "{phase:?}");
    assert_eq!(core.seq.leg, 2);
}

#[test]
fn the_pull_up_climbs_for_its_time_then_the_roll_begins() {
    let mut core = rolling_core();
    let g = core.config.roll;
    let trim = est(Vector3::new(5.0, 0.0, 0.0), 0.0);
    let pull_up = RollStage::PullUp { since_us: S };
    let before = S + (g.pull_up_s * 1e6) as u64 - 1;
    let (phase, _) = step(&mut core, &trim, before, pull_up, 0);
    let Phase::Maneuver {
        target: t, stage, ..
    } = phase
    else {
        unreachable!()
    };
    assert_eq!(stage, pull_up);
    assert_eq!(t.vel_ned_mps, Vector3::new(5.0, 0.0, -g.pull_up_climb_mps));
    let (phase, _) = step(&mut core, &trim, before + 1, pull_up, 0);
    assert_eq!(
        stage_of(phase),
        RollStage::Rolling {
            angle_rad: 0.0,
            since_us: before + 1
        }
    );
}

#[test]
fn the_roll_counts_its_angle_and_ends_at_the_exit_lead() {
    let mut core = rolling_core();
    let g = core.config.roll;
    let e = est(Vector3::new(5.0, 0.0, 0.0), 3.0);
    let exit = 2.0 * core::f64::consts::PI - g.exit_lead_rad;
    // 3 rad/s for 0.02 s: 0.06 rad more.
    let rolling = RollStage::Rolling {
        angle_rad: 1.0,
        since_us: S,
    };
    let (phase, out) = step(&mut core, &e, 2 * S, rolling, 0);
    let Phase::Maneuver {
        target: t, stage, ..
    } = phase
    else {
        unreachable!()
    };
    match stage {
        RollStage::Rolling {
            angle_rad,
            since_us,
        } => {
            assert!((angle_rad - 1.06).abs() < 1e-12, "{angle_rad}");
            assert_eq!(since_us, S);
        }
        other => panic!("{other:?}"),
    }
    assert!(out.is_empty());
    // While rolling the trajectory keeps up with the helicopter.
    assert_eq!(t.pos_ned_m, e.pos_ned_m);
    // Reaching the exit angle completes it: counted, raised, recovering at this height.
    let last = RollStage::Rolling {
        angle_rad: exit - 0.06,
        since_us: S,
    };
    let (phase, out) = step(&mut core, &e, 2 * S, last, 0);
    match phase {
        Phase::Maneuver {
            target: t,
            stage: RollStage::Recover { since_us },
            rolls_done: 1,
        } => {
            assert_eq!(since_us, 2 * S);
            assert_eq!(t.pos_ned_m, e.pos_ned_m);
            assert_eq!(t.vel_ned_mps, Vector3::new(5.0, 0.0, 0.0));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(core.stats().rolls_completed, 1);
    assert!(
        out.iter()
            .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::RollCompleted(1)))
    );
    // Just short of it, still rolling.
    let short = RollStage::Rolling {
        angle_rad: exit - 0.07,
        since_us: S,
    };
    assert!(matches!(
        stage_of(step(&mut core, &e, 2 * S, short, 0).0),
        RollStage::Rolling { .. }
    ));
}

#[test]
fn a_roll_taking_twice_its_time_is_abandoned() {
    let mut core = rolling_core();
    let g = core.config.roll;
    let e = est(Vector3::new(5.0, 0.0, 0.0), 0.0);
    let nominal_s = 2.0 * core::f64::consts::PI / g.rate_cmd_rps;
    let rolling = RollStage::Rolling {
        angle_rad: 1.0,
        since_us: 0,
    };
    let limit_us = (2.0 * nominal_s * 1e6) as u64;
    assert!(matches!(
        stage_of(step(&mut core, &e, limit_us - 1000, rolling, 0).0),
        RollStage::Rolling { .. }
    ));
    let (phase, out) = step(&mut core, &e, limit_us + 1000, rolling, 0);
    assert!(matches!(stage_of(phase), RollStage::Recover { .. }));
    assert!(
        out.iter()
            .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::RollAbandoned))
    );
    assert_eq!(core.stats().rolls_completed, 0);
}

#[test]
fn recovering_the_trajectory_s_point_is_kept_within_its_lead_of_the_helicopter() {
    let mut core = rolling_core();
    let lead_m = core.config.roll.recover_lead_m;
    assert!(lead_m > 0.5 && lead_m < 5.0, "{lead_m}");
    // The line flown is east (yaw 90 deg) at the trim's 5 m/s; the helicopter came out of
    // its roll 6 m behind the trajectory's point, 3 m downwind of the line and 1.5 m low.
    let line = Target {
        pos_ned_m: Vector3::new(4.0, 20.0, -20.0),
        vel_ned_mps: Vector3::new(0.0, 5.0, 0.0),
        yaw_rad: core::f64::consts::FRAC_PI_2,
    };
    let mut e = est(Vector3::new(2.0, 3.0, 0.0), 0.0);
    e.pos_ned_m = Vector3::new(7.0, 14.0, -18.5);
    let fly = |core: &mut FlightCore, e: &NavState, stage: RollStage| {
        let mut out = Vec::new();
        match core.maneuver(e, S, 0.02, line, stage, 1, &mut out) {
            Phase::Maneuver { target, .. } => target,
            other => panic!("{other:?}"),
        }
    };
    // Recovering: the point (carried on to 4, 20.1) is brought back towards the helicopter
    // to within the lead, on the line between them, not raced back to; the height is the
    // trajectory's, the velocity the trim's.
    let t = fly(&mut core, &e, RollStage::Recover { since_us: 0 });
    let ahead = Vector3::new(-3.0, 6.1, 0.0_f64);
    let kept: Vector3<f64> = Vector3::new(7.0, 14.0, -20.0) + ahead * (lead_m / ahead.norm());
    assert!((t.pos_ned_m - kept).norm() < 1e-9, "{t:?} not {kept:?}");
    assert!(
        (t.vel_ned_mps - Vector3::new(0.0, 5.0, 0.0)).norm() < 1e-9,
        "{t:?}"
    );
    // Within the lead, the trajectory is flown as it is, carried at the trim speed (0.1 m
    // in 0.02 s); so is the pull-up into the next roll, however far behind.
    let mut near = e;
    near.pos_ned_m = Vector3::new(4.5, 19.0, -18.5);
    let t = fly(&mut core, &near, RollStage::Recover { since_us: 0 });
    assert!(
        (t.pos_ned_m - Vector3::new(4.0, 20.1, -20.0)).norm() < 1e-9,
        "{t:?}"
    );
    let t = fly(&mut core, &e, RollStage::PullUp { since_us: S });
    assert!(
        (t.pos_ned_m - Vector3::new(4.0, 20.1, -20.0)).norm() < 1e-9,
        "{t:?}"
    );
    // A position that is not a number leaves the point as it was carried: never a NaN
    // point, which the next steps would carry on after the estimate came back.
    let mut lost = e;
    lost.pos_ned_m = Vector3::new(f64::NAN, 14.0, -18.5);
    let t = fly(&mut core, &lost, RollStage::Recover { since_us: 0 });
    assert!(
        (t.pos_ned_m - Vector3::new(4.0, 20.1, -20.0)).norm() < 1e-9,
        "{t:?}"
    );
}

#[test]
fn after_recovering_it_rolls_again_until_the_count_then_flies_the_next_leg() {
    let mut core = rolling_core();
    let g = core.config.roll;
    let e = est(Vector3::new(5.0, 0.0, 0.0), 0.0);
    let recover = RollStage::Recover { since_us: 0 };
    let end = (g.recover_s * 1e6) as u64;
    assert_eq!(
        stage_of(step(&mut core, &e, end - 1, recover, 1).0),
        recover
    );
    assert_eq!(
        stage_of(step(&mut core, &e, end, recover, 1).0),
        RollStage::PullUp { since_us: end }
    );
    let (phase, _) = step(&mut core, &e, end, recover, 2);
    assert!(matches!(phase, Phase::Holding { .. }), "{phase:?}");
    assert_eq!(core.seq.leg, 2);
}

#[test]
fn a_blind_roll_goes_on_at_the_gyro_or_the_commanded_rate_and_ends_round_or_stopped() {
    let g = RollGains::default();
    let at = |angle_rad: f64| RollStage::Rolling {
        angle_rad,
        since_us: 0,
    };
    let angle = |r: BlindRoll| match r {
        BlindRoll::Rolling(RollStage::Rolling { angle_rad, .. }) => angle_rad,
        other => panic!("{other:?}"),
    };
    // Silent: the commanded rate.
    let a = angle(blind_step(&g, at(2.0), None, S, 0.1));
    assert!((a - (2.0 + 0.1 * g.rate_cmd_rps)).abs() < 1e-12, "{a}");
    // A real sample: the gyro's rate, in the roll's direction.
    let a = angle(blind_step(&g, at(2.0), Some(1.0), S, 0.1));
    assert!((a - 2.1).abs() < 1e-12, "{a}");
    let left = RollGains {
        rate_cmd_rps: -3.0,
        ..g
    };
    let a = angle(blind_step(&left, at(2.0), Some(-1.0), S, 0.1));
    assert!((a - 2.1).abs() < 1e-12, "{a}");
    // Before a quarter turn: stopped where it is.
    assert_eq!(
        blind_step(&g, at(BLIND_STOP_BEFORE_RAD - 0.01), None, S, 0.02),
        BlindRoll::Stopped
    );
    assert!(matches!(
        blind_step(&g, at(BLIND_STOP_BEFORE_RAD), None, S, 0.0),
        BlindRoll::Rolling(_)
    ));
    // Round, less the exit lead: finished.
    let end = 2.0 * std::f64::consts::PI - g.exit_lead_rad;
    assert_eq!(
        blind_step(&g, at(end), Some(0.0), S, 0.02),
        BlindRoll::Finished
    );
    assert!(matches!(
        blind_step(&g, at(end - 0.01), Some(0.0), S, 0.02),
        BlindRoll::Rolling(_)
    ));
    // Twice its nominal time: given up.
    let nominal_us = (2.0 * std::f64::consts::PI / g.rate_cmd_rps * 1e6) as u64;
    assert!(matches!(
        blind_step(&g, at(3.0), Some(0.0), 2 * nominal_us - 1_000, 0.02),
        BlindRoll::Rolling(_)
    ));
    assert_eq!(
        blind_step(&g, at(3.0), Some(0.0), 2 * nominal_us + 1_000, 0.02),
        BlindRoll::Finished
    );
    // Not rolling at all: nothing to finish.
    assert_eq!(
        blind_step(&g, RollStage::Recover { since_us: 0 }, None, S, 0.02),
        BlindRoll::Stopped
    );
}
