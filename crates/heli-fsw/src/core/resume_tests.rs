//! Component tests of a flight process started again in a roll (`resume.rs`): the roll it
//! is handed in the record, the angle reckoned over the time nobody saw it, the roll finished
//! on the gyros, and the alignment from the attitude carried through it.

use super::tests::{gps_fix, raised};
use super::*;
use crate::phase::RollStage;
use heli_control::Target;
use nalgebra::UnitQuaternion;

const S: u64 = 1_000_000;

/// The record's gyro biases: large enough that using them the wrong way round would show.
const BIAS: [f64; 3] = [0.05, -0.04, 0.03];

fn in_roll(at_us: i64, angle_rad: f64, rate_rps: f64) -> WarmStart {
    WarmStart {
        gyro_bias_rps: BIAS,
        origin: None,
        home_ned_m: Some([0.0, 0.0, 0.0]),
        airborne: true,
        trim: None,
        references: heli_nav::GroundReferences::default(),
        roll: Some(RollRecord {
            at_us,
            angle_rad,
            rate_rps: [rate_rps, 0.1, -0.2],
            att: {
                let q = UnitQuaternion::from_euler_angles(angle_rad, 0.1, 0.7);
                [q.w, q.i, q.j, q.k]
            },
            elapsed_s: 0.3,
            rolls_done: 1,
            pos_ned_m: [70.0, 0.0, -31.0],
            yaw_rad: 0.7,
        }),
    }
}

/// A rolling helicopter's sample: the gyros at `rate_rps` (plus the record's bias), the
/// accelerometers reading the rotor's thrust along the body's -z — upright by them, whatever
/// the attitude.
fn sample_at(rate_rps: Vector3<f64>) -> ImuRepr {
    ImuRepr {
        rate_rps: [
            rate_rps.x + BIAS[0],
            rate_rps.y + BIAS[1],
            rate_rps.z + BIAS[2],
        ],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
}

/// Rolling at `rate_rps` about the body x axis, pitching and yawing a little.
fn rolling_sample(rate_rps: f64) -> ImuRepr {
    sample_at(Vector3::new(rate_rps, 0.2, -0.3))
}

#[test]
fn the_angle_turned_unseen_follows_the_rate_to_its_new_value() {
    let g = heli_control::RollGains::default();
    // At a steady rate: rate × time.
    let a = roll::turned_unseen(&g, 3.0, 3.0, 0.5);
    assert!((a - 1.5).abs() < 1e-12, "{a}");
    // From rest to 3 rad/s: less the time the rate took to get there, a time constant.
    let tau = g.rate_response_s;
    let a = roll::turned_unseen(&g, 0.0, 3.0, 0.5);
    let expect = 3.0 * 0.5 - 3.0 * tau * (1.0 - (-0.5 / tau).exp());
    assert!((a - expect).abs() < 1e-12, "{a} {expect}");
    assert!(
        a > 1.5 * 0.5 && a < 1.5,
        "more than the mean of the rates, less than the last"
    );
    // A roll to the left counts its own way.
    let left = heli_control::RollGains {
        rate_cmd_rps: -3.0,
        ..g
    };
    assert!((roll::turned_unseen(&left, -3.0, -3.0, 0.5) - 1.5).abs() < 1e-12);
}

#[test]
fn the_record_of_a_roll_under_way() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    core.nav.initialise(
        0,
        &heli_nav::ImuBiases {
            gyro_rps: Vector3::zeros(),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
            samples: 100,
        },
    );
    core.seq.airborne_once = true;
    assert_eq!(
        core.warm_start().unwrap().roll,
        None,
        "no roll, no record of one"
    );
    core.seq.phase = Phase::Maneuver {
        target: Target::hold(Vector3::zeros(), 0.4),
        stage: RollStage::Rolling {
            angle_rad: 1.2,
            since_us: 3 * S,
        },
        rolls_done: 2,
    };
    // The first control step gives the time and the rates.
    core.main_loop.step_dt(3 * S + 400_000);
    core.gyro_rps = Some(Vector3::new(2.9, 0.1, -0.2));
    let r = core.warm_start().unwrap().roll.unwrap();
    assert_eq!(r.at_us, 3_400_000);
    assert_eq!(r.angle_rad, 1.2);
    assert_eq!(r.rate_rps, [2.9, 0.1, -0.2]);
    assert!((r.elapsed_s - 0.4).abs() < 1e-12);
    assert_eq!((r.rolls_done, r.yaw_rad), (2, 0.4));
    // A roll flown blind has no attitude to hand on.
    core.main_loop.invalidate();
    assert_eq!(core.warm_start().unwrap().roll, None);
}

#[test]
fn restarted_in_a_roll_it_finishes_the_roll_on_the_gyros_then_aligns_from_the_carried_attitude() {
    let warm = in_roll(-500_000, 0.3, 3.0);
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm);
    assert!(core.phase().rolling(), "{:?}", core.phase());
    assert!(!core.estimate_valid(), "no estimate to fly on yet");
    assert!(!core.aligning(), "no levelling of a rolling helicopter");
    let mut out = Vec::new();
    core.start(0);
    core.handle(Input::Gps(gps_fix(8)), 0, &mut out);
    // The first sample, 0.5 s after the record, rolling at 3.2 rad/s.
    core.handle(Input::Imu(rolling_sample(3.2)), 0, &mut out);
    let g = core.config.roll;
    let turned = roll::turned_unseen(&g, 3.0, 3.2, 0.5);
    let event = out.iter().find_map(|a| match a {
        Action::Event(Stamped {
            value:
                CoreEvent::RestartedInRoll {
                    angle_rad,
                    unseen_s,
                },
            ..
        }) => Some((*angle_rad, *unseen_s)),
        _ => None,
    });
    let (angle, unseen_s) = event.expect("the restart in a roll is raised");
    assert!((unseen_s - 0.5).abs() < 1e-9, "{unseen_s}");
    assert!((angle.unwrap() - (0.3 + turned)).abs() < 1e-9, "{angle:?}");
    // It flies the roll law on the gyros: full lateral cyclic, collective by the angle.
    let mut t = 0;
    let mut first_servo = None;
    while core.phase().rolling() && t < 3 * S {
        t += 10_000;
        out.clear();
        core.handle(Input::Imu(rolling_sample(3.2)), t, &mut out);
        if first_servo.is_none() {
            first_servo = out.iter().find_map(|a| match a {
                Action::Servo(c) => Some(c.value),
                _ => None,
            });
        }
    }
    let u = first_servo.expect("a command while rolling");
    assert!(u.aileron > 0.8, "{u:?}");
    assert!(
        raised(&out, CoreEvent::RollEndedBlind { finished: true }),
        "finished, not stopped"
    );
    let rolled_s = t as f64 * 1e-6;
    // It ended where the angle reckoned with the unseen turn reached a whole roll less the
    // exit lead, counted at 3.2 rad/s a control step at a time.
    let left_rad = 2.0 * std::f64::consts::PI - g.exit_lead_rad - (0.3 + turned);
    assert!(
        (rolled_s - left_rad / 3.2).abs() < 0.03,
        "rolled {rolled_s} s for {left_rad} rad"
    );
    // ... then aligns (the next sample) from the attitude carried through the roll, not from
    // the accelerometers, which say "upright" whatever the helicopter does; it still turns a
    // little while it aligns.
    let settling = Vector3::new(0.4, 0.0, 0.1);
    let roll_end_us = t;
    core.handle(Input::Imu(sample_at(settling)), t + 10_000, &mut out);
    assert!(core.aligning());
    let mut t = t + 10_000;
    while core.aligning() && t < 10 * S {
        t += 10_000;
        core.handle(Input::Imu(sample_at(settling)), t, &mut out);
    }
    assert!(
        core.estimate_valid(),
        "aligned: flying on the estimate again"
    );
    let aligning_s = (t - roll_end_us) as f64 * 1e-6;
    let [w, i, j, k] = warm.roll.unwrap().att;
    // The unseen turn: the roll reckoned, pitch and yaw at the mean of the rates recorded
    // (0.1, -0.2) and measured (0.2, -0.3).
    let unseen = Vector3::new(turned, 0.15 * 0.5, -0.25 * 0.5);
    let expect = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, i, j, k))
        * UnitQuaternion::from_scaled_axis(unseen)
        * UnitQuaternion::from_scaled_axis(Vector3::new(3.2, 0.2, -0.3) * rolled_s)
        * UnitQuaternion::from_scaled_axis(settling * aligning_s);
    let att = core.navigator().state().unwrap().att;
    let err = (att.inverse() * expect).angle();
    assert!(
        err < 0.01,
        "attitude {:?} against {:?}: {err} rad",
        att.euler_angles(),
        expect.euler_angles()
    );
}

#[test]
fn the_roll_goes_on_counting_its_time_from_when_it_began() {
    // Recorded 0.3 s into the roll at 2.0 s of the new clock (a clock started long before
    // the record, as the lockstep's shared one): the roll began at 1.7 s, and a roll that
    // takes twice its nominal time from then is given up.
    let core = FlightCore::restarted(
        CoreConfig::default(),
        FlightParams::default(),
        in_roll(2_000_000, 0.3, 3.0),
    );
    match core.phase() {
        Phase::Maneuver {
            stage:
                RollStage::Rolling {
                    since_us,
                    angle_rad,
                },
            rolls_done,
            target,
        } => {
            assert_eq!(since_us, 1_700_000);
            assert_eq!((angle_rad, rolls_done), (0.3, 1));
            assert_eq!(target.pos_ned_m, Vector3::new(70.0, 0.0, -31.0));
            assert_eq!(target.yaw_rad, 0.7);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_roll_unseen_for_longer_than_the_board_holds_a_command_is_given_up_and_the_process_aligns() {
    let warm = in_roll(-1_500_000, 0.3, 3.0);
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm);
    let mut out = Vec::new();
    core.handle(Input::Imu(rolling_sample(0.5)), 0, &mut out);
    assert!(raised(
        &out,
        CoreEvent::RestartedInRoll {
            angle_rad: None,
            unseen_s: 1.5
        }
    ));
    assert_eq!(core.phase(), Phase::BlindDescent);
    assert!(core.aligning());
    // A record from the future (a clock set back) is no better.
    let mut core = FlightCore::restarted(
        CoreConfig::default(),
        FlightParams::default(),
        in_roll(2_000_000, 0.3, 3.0),
    );
    out.clear();
    core.handle(Input::Imu(rolling_sample(0.5)), 0, &mut out);
    assert!(core.aligning());
    assert_eq!(core.phase(), Phase::BlindDescent);
}
