//! Component tests of the mission sequencer (`sequencer.rs`): `next_phase` driven directly
//! from a constructed state (phase, pilot, plan, devices) and estimate, judged on the phase
//! it chooses and the events it raises.

use super::tests::{gps_fix, uplink};
use super::*;
use nalgebra::UnitQuaternion;

const S: u64 = 1_000_000;
const DT: f64 = 0.02;

fn plan() -> Plan {
    Plan::new(&[
        Leg::Takeoff { alt_m: 10.0 },
        Leg::Hold { seconds: 5.0 },
        Leg::Fly {
            north_m: 20.0,
            east_m: 0.0,
            alt_m: 10.0,
            speed_mps: 4.0,
        },
        Leg::Land,
    ])
    .unwrap()
}

/// A core flying `mode` with every device heard and a good GPS fix at `now_us`, calibrated
/// (the phase is `phase`), the pilot's switch `auto`.
pub(super) fn core_in(phase: Phase, mode: FlightMode, auto: bool, now_us: u64) -> FlightCore {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams { mode, plan: plan() });
    for device in Device::ALL {
        core.devices.health.monitor_mut(device).sample(now_us);
    }
    core.aiding.last_good_fix = Some((now_us, gps_fix(8)));
    core.seq.home_ned_m = Some(Vector3::zeros());
    core.devices.pilot = Some(uplink(auto, false));
    core.seq.phase = phase;
    core
}

/// Level at heading 0.3 rad, `height_m` up, at `vel`.
pub(super) fn est(height_m: f64, north_m: f64, vel: Vector3<f64>) -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3),
        vel_ned_mps: vel,
        pos_ned_m: Vector3::new(north_m, 0.0, -height_m),
        rate_body_rps: Vector3::zeros(),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

pub(super) fn next(core: &mut FlightCore, e: &NavState, now_us: u64) -> (Phase, Vec<Action>) {
    let mut out = Vec::new();
    let phase = core.next_phase(Some(e), now_us, DT, &mut out);
    (phase, out)
}

fn raised(out: &[Action], event: CoreEvent) -> bool {
    super::tests::raised(out, event)
}

#[test]
fn the_auto_switch_in_the_air_holds_where_the_helicopter_can_stop() {
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    let e = est(8.0, 0.0, Vector3::new(4.0, -2.0, 0.0));
    let (phase, _) = next(&mut core, &e, S);
    // v²/2a ahead along the velocity: 20 m²/s² over 4 m/s², 5 m along (4, -2)/√20.
    let v: Vector3<f64> = Vector3::new(4.0, -2.0, 0.0);
    let stop: Vector3<f64> = v * (5.0 / 20.0_f64.sqrt());
    match phase {
        Phase::Holding { target, since_us } => {
            assert!(
                (target.pos_ned_m - (e.pos_ned_m + stop)).norm() < 1e-9,
                "{target:?}"
            );
            assert!((target.yaw_rad - 0.3).abs() < 1e-9);
            assert_eq!(since_us, S);
        }
        other => panic!("{other:?}"),
    }
    assert!(core.seq.braking.is_some());
}

#[test]
fn the_auto_switch_on_the_ground_checks_then_takes_off_or_is_refused() {
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    // No GPS fix fused by the filter: the pre-flight check waits.
    let (phase, _) = next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S);
    assert_eq!(phase, Phase::PreflightCheck { since_us: S });
    core.seq.phase = phase;
    let wait = (preflight::CHECK_WAIT_S * 1e6) as u64;
    let (phase, out) = next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S + wait - 1);
    assert_eq!(phase, Phase::PreflightCheck { since_us: S });
    assert!(out.is_empty());
    let (phase, out) = next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S + wait);
    assert_eq!(phase, Phase::TakeoffRefused);
    assert!(raised(
        &out,
        CoreEvent::TakeoffRefused(preflight::Refusal::NoGpsFix)
    ));
    core.seq.phase = phase;
    // Refused stays refused while the switch stays on, and the pilot has it when it is off.
    assert_eq!(
        next(&mut core, &est(0.0, 0.0, Vector3::zeros()), 40 * S).0,
        Phase::TakeoffRefused
    );
    core.devices.pilot = Some(uplink(false, false));
    assert_eq!(
        next(&mut core, &est(0.0, 0.0, Vector3::zeros()), 41 * S).0,
        Phase::Manual
    );
}

#[test]
fn with_the_plan_done_the_auto_switch_on_the_ground_stays_landed() {
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.seq.plan_done = true;
    assert_eq!(
        next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S).0,
        Phase::Landed
    );
    core.seq.phase = Phase::Landed;
    assert_eq!(
        next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S).0,
        Phase::Landed
    );
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.seq.plan_abandoned = true;
    assert_eq!(
        next(&mut core, &est(0.2, 0.0, Vector3::zeros()), S).0,
        Phase::Landed
    );
}

#[test]
fn low_after_flying_with_nothing_left_to_fly_it_lands_rather_than_calls_itself_landed() {
    // A process started again over a landing (its plan abandoned) finds the helicopter 0.2 m
    // above home by its altimeter: within its error of the ground, and no touchdown. It
    // lands where it is; the landing's judge says when it is down.
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.seq.plan_abandoned = true;
    core.seq.airborne_once = true;
    let low = est(0.2, 0.0, Vector3::new(0.0, 0.0, 0.5));
    let (phase, _) = next(&mut core, &low, S);
    match phase {
        Phase::Landing {
            target,
            settled_since_us: None,
        } => {
            assert!((target.pos_ned_m - low.pos_ned_m).norm() < 1e-12);
            assert!(target.vel_ned_mps.z > 0.0, "it descends: {target:?}");
        }
        other => panic!("{other:?}"),
    }
    // The same with the plan done: landing, not landed.
    let mut core = core_in(Phase::Manual, FlightMode::Autonomous, true, S);
    core.seq.plan_done = true;
    core.seq.airborne_once = true;
    assert!(matches!(next(&mut core, &low, S).0, Phase::Landing { .. }));
}

#[test]
fn the_bypass_and_the_switch_off_give_the_pilot_the_helicopter() {
    let hold = Phase::Holding {
        target: Target::hold(Vector3::new(0.0, 0.0, -8.0), 0.3),
        since_us: 0,
    };
    let mut core = core_in(hold, FlightMode::Autonomous, true, S);
    core.devices.pilot = core
        .devices
        .pilot
        .map(|p| PilotUplink { bypass: true, ..p });
    assert_eq!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Manual
    );
    let mut core = core_in(hold, FlightMode::Autonomous, false, S);
    assert_eq!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Manual
    );
    // The manual mode never flies itself.
    let mut core = core_in(Phase::Manual, FlightMode::Manual, true, S);
    assert_eq!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Manual
    );
    // A silent board's bypass bit is stale: the transmitter is lost, the computer holds.
    let mut core = core_in(hold, FlightMode::Autonomous, true, S);
    core.devices.pilot = core
        .devices
        .pilot
        .map(|p| PilotUplink { bypass: true, ..p });
    core.devices.uplink_lost = true;
    assert!(matches!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Holding { .. }
    ));
}

#[test]
fn the_augmented_modes_fly_when_the_switch_is_on() {
    let rate = FlightMode::Augmented(AugmentedMode::Rate);
    let mut core = core_in(Phase::Manual, rate, true, S);
    assert_eq!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Augmented(AugmentedMode::Rate)
    );
}

#[test]
fn a_lost_transmitter_holds_in_the_air_and_idles_on_the_ground() {
    // In the air, in manual: hover here, the plan given up.
    let mut core = core_in(Phase::Manual, FlightMode::Manual, false, S);
    core.devices.pilot = Some(uplink(false, true));
    let (phase, out) = next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S);
    assert!(
        matches!(phase, Phase::Holding { since_us, .. } if since_us == S),
        "{phase:?}"
    );
    assert!(core.seq.plan_abandoned);
    assert!(out.is_empty());
    // A hold already in place is kept, with its time.
    core.seq.phase = Phase::Holding {
        target: Target::hold(Vector3::new(1.0, 1.0, -8.0), 0.3),
        since_us: 7,
    };
    core.seq.braking = None;
    let (phase, _) = next(&mut core, &est(8.0, 0.0, Vector3::zeros()), 2 * S);
    assert_eq!(
        phase,
        Phase::Holding {
            target: Target::hold(Vector3::new(1.0, 1.0, -8.0), 0.3),
            since_us: 7
        }
    );
    // On the ground: idle, even in a climb begun (not in a hold).
    let mut core = core_in(
        Phase::TakingOff {
            target: Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3),
        },
        FlightMode::Autonomous,
        true,
        S,
    );
    core.devices.pilot = Some(uplink(true, true));
    assert_eq!(
        next(&mut core, &est(0.1, 0.0, Vector3::zeros()), S).0,
        Phase::GroundFailsafe
    );
    // The board gone silent is the same loss.
    let mut core = core_in(Phase::Manual, FlightMode::Manual, false, S);
    core.devices.uplink_lost = true;
    assert!(matches!(
        next(&mut core, &est(8.0, 0.0, Vector3::zeros()), S).0,
        Phase::Holding { .. }
    ));
}

#[test]
fn the_climb_ends_within_its_tolerance_of_the_height() {
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
    let (phase, _) = next(&mut core, &est(9.6, 0.0, Vector3::zeros()), S);
    assert_eq!(phase, Phase::TakingOff { target });
    let (phase, _) = next(&mut core, &est(9.75, 0.0, Vector3::zeros()), S);
    assert!(matches!(phase, Phase::Holding { .. }), "{phase:?}");
    assert_eq!(core.seq.leg, 1);
}

#[test]
fn a_hold_lasts_its_leg_then_the_path_begins() {
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    let hold = Phase::Holding {
        target,
        since_us: S,
    };
    let mut core = core_in(hold, FlightMode::Autonomous, true, S);
    core.seq.leg = 1;
    let (phase, _) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), 6 * S - 1);
    assert!(matches!(phase, Phase::Holding { since_us, .. } if since_us == S));
    let (phase, _) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), 6 * S);
    match phase {
        Phase::Flying {
            target: t,
            to_ned_m,
        } => {
            assert_eq!(to_ned_m, Vector3::new(20.0, 0.0, -10.0));
            // From the hold's target, along the path at its speed, heading along it.
            assert_eq!(t.pos_ned_m, target.pos_ned_m);
            assert!((t.vel_ned_mps - Vector3::new(4.0, 0.0, 0.0)).norm() < 1e-12);
            assert!(t.yaw_rad.abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(core.seq.leg, 2);
    // A hold the plan gave up (a lost transmitter's) lasts.
    let mut core = core_in(hold, FlightMode::Autonomous, true, S);
    core.seq.leg = 1;
    core.seq.plan_abandoned = true;
    assert!(matches!(
        next(&mut core, &est(10.0, 0.0, Vector3::zeros()), 60 * S).0,
        Phase::Holding { .. }
    ));
}

#[test]
fn the_path_carries_its_target_at_the_speed_and_arrives_when_stopped_there() {
    let to = Vector3::new(20.0, 0.0, -10.0);
    let flying = |north: f64, speed: f64| Phase::Flying {
        target: Target {
            pos_ned_m: Vector3::new(north, 0.0, -10.0),
            vel_ned_mps: Vector3::new(speed, 0.0, 0.0),
            yaw_rad: 0.0,
        },
        to_ned_m: to,
    };
    let mut core = core_in(flying(5.0, 4.0), FlightMode::Autonomous, true, S);
    core.seq.leg = 2;
    match next(&mut core, &est(10.0, 5.0, Vector3::new(4.0, 0.0, 0.0)), S).0 {
        Phase::Flying { target, .. } => {
            assert!((target.pos_ned_m.x - (5.0 + 4.0 * DT)).abs() < 1e-12);
            assert_eq!(target.vel_ned_mps, Vector3::new(4.0, 0.0, 0.0));
        }
        other => panic!("{other:?}"),
    }
    // The last step reaches the end and stops the target there.
    let mut core = core_in(flying(20.0 - 0.05, 4.0), FlightMode::Autonomous, true, S);
    core.seq.leg = 2;
    match next(&mut core, &est(10.0, 19.0, Vector3::new(4.0, 0.0, 0.0)), S).0 {
        Phase::Flying { target, .. } => {
            assert_eq!(target.pos_ned_m, to);
            assert_eq!(target.vel_ned_mps, Vector3::zeros());
        }
        other => panic!("{other:?}"),
    }
    // Arrived: within 1.5 m and under 1 m/s.
    for (north, speed, arrived) in [(19.0, 0.5, true), (18.4, 0.5, false), (19.0, 1.1, false)] {
        let mut core = core_in(flying(20.0, 0.0), FlightMode::Autonomous, true, S);
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

#[test]
fn the_landing_settles_on_the_skids_then_the_plan_is_complete() {
    let landing = |z: f64, settled| Phase::Landing {
        target: Target {
            pos_ned_m: Vector3::new(20.0, 0.0, z),
            vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
            yaw_rad: 0.0,
        },
        settled_since_us: settled,
    };
    let mut core = core_in(landing(-5.0, None), FlightMode::Autonomous, true, S);
    core.seq.leg = 3;
    // In the air the target descends at its rate.
    match next(&mut core, &est(5.0, 20.0, Vector3::new(0.0, 0.0, 0.5)), S).0 {
        Phase::Landing {
            target,
            settled_since_us: None,
        } => assert!((target.pos_ned_m.z - (-5.0 + 0.5 * DT)).abs() < 1e-12),
        other => panic!("{other:?}"),
    }
    // Never more than a metre below the helicopter.
    let mut core = core_in(landing(0.5, None), FlightMode::Autonomous, true, S);
    core.seq.leg = 3;
    match next(&mut core, &est(2.0, 20.0, Vector3::new(0.0, 0.0, 0.5)), S).0 {
        Phase::Landing { target, .. } => assert!((target.pos_ned_m.z - (-1.0)).abs() < 1e-12),
        other => panic!("{other:?}"),
    }
    // On the skids (the target 0.6 m below, still): settling, then landed after a second.
    let mut core = core_in(landing(0.6, None), FlightMode::Autonomous, true, S);
    core.seq.leg = 3;
    let still = est(0.0, 20.0, Vector3::new(0.0, 0.0, 0.1));
    assert_eq!(
        next(&mut core, &still, 2 * S).0,
        landing(0.6 + 0.5 * DT, Some(2 * S))
    );
    let mut core = core_in(landing(0.6, Some(S)), FlightMode::Autonomous, true, S);
    core.seq.leg = 3;
    let (phase, out) = next(&mut core, &still, 2 * S - 1);
    assert!(matches!(phase, Phase::Landing { settled_since_us: Some(t), .. } if t == S));
    assert!(out.is_empty());
    assert!(!core.plan_complete(), "not before the landing is settled");
    let (phase, out) = next(&mut core, &still, 2 * S);
    assert_eq!(phase, Phase::Landed);
    assert!(core.plan_complete());
    assert!(raised(&out, CoreEvent::PlanComplete));
    // A landing the plan did not ask for lands without completing it.
    let mut core = core_in(landing(0.6, Some(S)), FlightMode::Autonomous, true, S);
    core.seq.plan_abandoned = true;
    let (phase, out) = next(&mut core, &still, 2 * S);
    assert_eq!(phase, Phase::Landed);
    assert!(!raised(&out, CoreEvent::PlanComplete));
    // Still sinking, or the target not below the skids: not settled.
    let mut core = core_in(landing(0.6, Some(S)), FlightMode::Autonomous, true, S);
    let sinking = est(0.0, 20.0, Vector3::new(0.0, 0.0, 0.4));
    assert!(matches!(
        next(&mut core, &sinking, 2 * S).0,
        Phase::Landing {
            settled_since_us: None,
            ..
        }
    ));
    let mut core = core_in(landing(0.4, Some(S)), FlightMode::Autonomous, true, S);
    assert!(matches!(
        next(&mut core, &still, 2 * S).0,
        Phase::Landing {
            settled_since_us: None,
            ..
        }
    ));
}

#[test]
fn without_an_estimate_the_pilot_or_the_blind_failsafe_flies() {
    let mut out = Vec::new();
    // Calibrating.
    let mut core = core_in(Phase::Calibrating, FlightMode::Autonomous, false, S);
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::Calibrating);
    // The estimate lost: the pilot if there is one.
    core.main_loop.estimate_valid = false;
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::Manual);
    core.devices.pilot = Some(uplink(false, true));
    assert_eq!(
        core.next_phase(None, S, DT, &mut out),
        Phase::GroundFailsafe
    );
    core.seq.airborne_once = true;
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::BlindDescent);
    core.devices.pilot = None;
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::BlindDescent);
}

#[test]
fn aligning_after_a_restart_the_pilot_flies_unless_the_switch_is_on() {
    let warm = WarmStart {
        gyro_bias_rps: [0.0; 3],
        origin: None,
        home_ned_m: Some([0.0; 3]),
        airborne: true,
        trim: None,
        references: heli_nav::GroundReferences::default(),
        roll: None,
    };
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm);
    let mut out = Vec::new();
    core.devices.pilot = Some(uplink(false, false));
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::Manual);
    core.devices.pilot = Some(uplink(true, false));
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::BlindDescent);
    core.devices.pilot = core
        .devices
        .pilot
        .map(|p| PilotUplink { bypass: true, ..p });
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::Manual);
    core.devices.pilot = Some(uplink(false, true));
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::BlindDescent);
    core.devices.pilot = None;
    assert_eq!(core.next_phase(None, S, DT, &mut out), Phase::BlindDescent);
}

#[test]
fn a_roll_under_way_is_finished_before_the_pilot_takes_over() {
    let plan = Plan::new(&[
        Leg::Takeoff { alt_m: 20.0 },
        Leg::Rolls {
            count: 1,
            speed_mps: 5.0,
        },
        Leg::Land,
    ])
    .unwrap();
    let rolling = |angle_rad| Phase::Maneuver {
        target: Target::hold(Vector3::new(0.0, 0.0, -20.0), 0.0),
        stage: RollStage::Rolling {
            angle_rad,
            since_us: S,
        },
        rolls_done: 0,
    };
    let mut core = core_in(rolling(1.0), FlightMode::Autonomous, false, S);
    core.seq.params.plan = plan;
    core.seq.leg = 1;
    let mut e = est(20.0, 0.0, Vector3::new(5.0, 0.0, 0.0));
    e.rate_body_rps.x = 3.0;
    // The switch is off, but the roll goes on.
    let (phase, _) = next(&mut core, &e, 2 * S);
    assert!(
        matches!(
            phase,
            Phase::Maneuver {
                stage: RollStage::Rolling { .. },
                ..
            }
        ),
        "{phase:?}"
    );
    // Upright again: the pilot has it.
    core.seq.phase = rolling(2.0 * core::f64::consts::PI);
    let (phase, out) = next(&mut core, &e, 2 * S);
    assert_eq!(phase, Phase::Manual);
    assert!(raised(&out, CoreEvent::RollCompleted(1)));
    // The bypass acts at once, mid-roll.
    core.seq.phase = rolling(1.0);
    core.devices.pilot = core
        .devices
        .pilot
        .map(|p| PilotUplink { bypass: true, ..p });
    assert_eq!(next(&mut core, &e, 2 * S).0, Phase::Manual);
}

#[test]
fn a_rolls_leg_accelerates_along_the_heading_and_the_plans_end_holds() {
    let plan = Plan::new(&[
        Leg::Takeoff { alt_m: 10.0 },
        Leg::Rolls {
            count: 1,
            speed_mps: 6.0,
        },
    ])
    .unwrap();
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
    core.seq.params.plan = plan;
    match next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S).0 {
        Phase::Maneuver {
            target: t,
            stage: RollStage::Accelerate { since_us },
            rolls_done: 0,
        } => {
            assert_eq!(since_us, S);
            assert_eq!(t.pos_ned_m, target.pos_ned_m);
            // From rest, speeding up along the heading.
            let dir = Vector3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
            let speed = t.vel_ned_mps.norm();
            assert!(
                speed <= super::roll::RUN_UP_ACCEL_MPS2 * 0.02 + 1e-12,
                "{t:?}"
            );
            assert!((t.vel_ned_mps - dir * speed).norm() < 1e-12, "{t:?}");
        }
        other => panic!("{other:?}"),
    }
    // Begun at 5 m/s along the heading: from there, not from rest.
    let dir = Vector3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
    let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
    core.seq.params.plan = Plan::new(&[
        Leg::Takeoff { alt_m: 10.0 },
        Leg::Rolls {
            count: 1,
            speed_mps: 6.0,
        },
    ])
    .unwrap();
    match next(&mut core, &est(10.0, 0.0, dir * 5.0), S).0 {
        Phase::Maneuver { target: t, .. } => {
            let from_5 = (t.vel_ned_mps - dir * 5.0).norm();
            assert!(
                from_5 <= super::roll::RUN_UP_ACCEL_MPS2 * 0.02 + 1e-12,
                "{t:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    // Past the last leg: the plan is complete, raised once, and it holds where it is.
    let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
    core.seq.params.plan = Plan::new(&[Leg::Takeoff { alt_m: 10.0 }]).unwrap();
    let (phase, out) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S);
    match phase {
        Phase::Holding {
            target: t,
            since_us,
        } => {
            assert_eq!(t.pos_ned_m, target.pos_ned_m);
            assert_eq!(t.vel_ned_mps, Vector3::zeros());
            assert!((t.yaw_rad - 0.3).abs() < 1e-12);
            assert_eq!(since_us, S);
        }
        other => panic!("{other:?}"),
    }
    assert!(raised(&out, CoreEvent::PlanComplete));
    assert!(core.plan_complete());
}

#[test]
fn a_short_path_keeps_the_heading_a_long_one_turns_along_it() {
    let plan = |north_m: f64, east_m: f64| {
        Plan::new(&[
            Leg::Takeoff { alt_m: 10.0 },
            Leg::Fly {
                north_m,
                east_m,
                alt_m: 10.0,
                speed_mps: 2.0,
            },
        ])
        .unwrap()
    };
    let target = Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3);
    for (north, east, heading) in [
        (3.0, 3.0, 0.3),
        (5.0, 0.0, 0.3),
        (0.0, 20.0, core::f64::consts::FRAC_PI_2),
    ] {
        let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
        core.seq.params.plan = plan(north, east);
        match next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S).0 {
            Phase::Flying { target: t, .. } => {
                assert!(
                    (t.yaw_rad - heading).abs() < 1e-12,
                    "{north} {east}: {}",
                    t.yaw_rad
                )
            }
            other => panic!("{other:?}"),
        }
    }
    // A path that goes nowhere (a micrometre at most) has no velocity.
    for north in [0.0, 1e-6] {
        let mut core = core_in(Phase::TakingOff { target }, FlightMode::Autonomous, true, S);
        core.seq.params.plan = plan(north, 0.0);
        match next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S).0 {
            Phase::Flying { target: t, .. } => assert_eq!(t.vel_ned_mps, Vector3::zeros()),
            other => panic!("{other:?}"),
        }
    }
}
