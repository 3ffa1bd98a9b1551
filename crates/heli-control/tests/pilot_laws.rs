//! The laws the pilot flies through (manual yaw damping, the augmented modes, the aileron
//! roll) and the safety rule's condition sets, against values worked out from their
//! documentation (docs/control.md and the doc comments).

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::arithmetic_side_effects
)]

use heli_control::heading_lock::HeadingLock;
use heli_control::hover::{HoverController, HoverGains};
use heli_control::safety::{Condition, Conditions, Facts, Rule};
use heli_control::{
    GOVERNED_THROTTLE, RollGains, StickScales, YawDamper, augmented_controls, limit,
    manual_with_yaw_damping, rolling_controls,
};
use heli_nav::NavState;
use heli_proto::scb::Controls;
use heli_types::{AugmentedMode, FlightMode};
use nalgebra::{UnitQuaternion, Vector3};

const TOL: f64 = 1e-12;

/// A step long enough that the heading lock's shaping (4.7 rad/s²) passes the stick's rate.
const DT: f64 = 0.1;

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < TOL, "{a} != {b}");
}

fn est() -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.08, -0.04, 0.6),
        vel_ned_mps: Vector3::new(0.7, -0.4, 0.2),
        pos_ned_m: Vector3::new(1.0, 2.0, -8.0),
        rate_body_rps: Vector3::new(0.15, -0.25, 0.4),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

fn sticks() -> Controls {
    Controls {
        aileron: 0.3,
        elevator: -0.2,
        rudder: 0.15,
        collective: 0.25,
        throttle: 0.7,
    }
}

fn scales() -> StickScales {
    StickScales {
        rate_rps: 1.7,
        angle_rad: 0.45,
        speed_mps: 4.0,
        climb_mps: 1.5,
        yaw_rate_rps: 1.9,
    }
}

#[test]
fn manual_passes_the_sticks_and_damps_the_yaw_rate_on_the_tail() {
    let damper = YawDamper {
        gain: 0.2,
        trim: 0.3,
    };
    let u = manual_with_yaw_damping(&sticks(), 0.4, &damper);
    close(u.rudder, 0.15 + 0.3 - 0.2 * 0.4);
    assert_eq!(
        Controls {
            rudder: sticks().rudder,
            ..u
        },
        sticks()
    );
    // A yaw rate that is not a reading is no rate.
    close(
        manual_with_yaw_damping(&sticks(), f64::NAN, &damper).rudder,
        0.45,
    );
}

#[test]
fn the_roll_flies_its_rate_and_schedules_the_collective_on_the_angle() {
    let g = RollGains {
        rate_cmd_rps: 2.0,
        rate_feedforward: 0.3,
        rate_feedback: 0.07,
        pitch_rate_feedback: 0.15,
        yaw_rate_feedback: 0.25,
        collective_amplitude: 0.6,
        tail_feedforward: 0.35,
        ..RollGains::default()
    };
    let e = est();
    let u = rolling_controls(&e.rate_body_rps, 0.7, &g);
    close(u.aileron, 0.3 * 2.0 + 0.07 * (2.0 - 0.15));
    close(u.elevator, -0.15 * -0.25);
    let collective = 0.6 * 0.7f64.cos();
    close(u.collective, collective);
    close(u.rudder, 0.35 * collective / 0.6 - 0.25 * 0.4);
    assert_eq!(u.throttle, GOVERNED_THROTTLE);
    // Inverted: the collective pushes the other way, the tail sees the same torque.
    let u = rolling_controls(&e.rate_body_rps, 2.6, &g);
    close(u.collective, 0.6 * 2.6f64.cos());
    close(
        u.rudder,
        0.35 * (0.6 * 2.6f64.cos()).abs() / 0.6 - 0.25 * 0.4,
    );
}

#[test]
fn the_velocity_sticks_command_forward_right_and_up() {
    let v = heli_control::augmented::commanded_velocity(&sticks(), &scales());
    close(v.x, 0.2 * 4.0);
    close(v.y, 0.3 * 4.0);
    close(v.z, -0.25 * 1.5);
    // Beyond full travel counts as full travel.
    let v = heli_control::augmented::commanded_velocity(
        &Controls {
            elevator: -3.0,
            aileron: 2.0,
            collective: 1.5,
            ..Controls::default()
        },
        &scales(),
    );
    close(v.x, 4.0);
    close(v.y, 4.0);
    close(v.z, -1.5);
}

/// The rudder the augmented modes fly: the stick's rate through the heading lock, then the
/// hover's tail stage with the collective flown.
fn augmented_rudder(inner: &mut HoverController, collective: f64, airborne: bool) -> f64 {
    let e = est();
    let mut lock = HeadingLock::default();
    let r = lock.rate(
        0.6,
        0.15 * 1.9,
        inner.gains.heading_lock_to_rate,
        DT,
        airborne,
    );
    inner.yaw_rate_to_tail(&e, r, collective, DT, airborne)
}

#[test]
fn rate_mode_flies_the_sticks_as_rates() {
    let g = HoverGains::default();
    let mut inner = HoverController::new(g);
    let u = augmented_controls(
        AugmentedMode::Rate,
        &sticks(),
        &est(),
        &scales(),
        &mut inner,
        DT,
        true,
    );
    let mut stages = HoverController::new(g);
    let (a, e) = stages.rates_to_cyclic(&est(), 0.3 * 1.7, -0.2 * 1.7);
    close(u.aileron, a);
    close(u.elevator, e);
    close(u.collective, 0.25);
    close(u.throttle, 0.7);
    close(u.rudder, augmented_rudder(&mut stages, 0.25, true));
}

#[test]
fn attitude_mode_flies_the_sticks_as_angles() {
    let g = HoverGains::default();
    let mut inner = HoverController::new(g);
    let u = augmented_controls(
        AugmentedMode::Attitude,
        &sticks(),
        &est(),
        &scales(),
        &mut inner,
        DT,
        false,
    );
    let mut stages = HoverController::new(g);
    let (a, e) = stages.attitude_to_cyclic(&est(), 0.3 * 0.45, -0.2 * 0.45);
    close(u.aileron, a);
    close(u.elevator, e);
    close(u.collective, 0.25);
    close(u.throttle, 0.7);
    close(u.rudder, augmented_rudder(&mut stages, 0.25, false));
}

#[test]
fn velocity_mode_flies_the_sticks_as_velocities_in_the_heading_frame() {
    let g = HoverGains::default();
    let mut inner = HoverController::new(g);
    let u = augmented_controls(
        AugmentedMode::Velocity,
        &sticks(),
        &est(),
        &scales(),
        &mut inner,
        DT,
        true,
    );
    let mut stages = HoverController::new(g);
    // 0.8 m/s forward and 1.2 m/s right at heading 0.6 rad, climbing 0.375 m/s.
    let (s, c) = 0.6f64.sin_cos();
    let v_ned = Vector3::new(c * 0.8 - s * 1.2, s * 0.8 + c * 1.2, 0.0);
    let (roll, pitch) = stages.velocity_to_attitude(&est(), &v_ned, DT, true);
    let (a, e) = stages.attitude_to_cyclic(&est(), roll, pitch);
    let collective = stages.climb_to_collective(&est(), -0.375, DT);
    close(u.aileron, a);
    close(u.elevator, e);
    close(u.collective, limit(collective, 1.0));
    assert_eq!(u.throttle, GOVERNED_THROTTLE);
    close(u.rudder, augmented_rudder(&mut stages, collective, true));
}

#[test]
fn only_the_augmented_modes_are_augmented() {
    assert!(!FlightMode::Manual.is_augmented());
    assert!(!FlightMode::Autonomous.is_augmented());
    assert!(FlightMode::Augmented(AugmentedMode::Rate).is_augmented());
}

/// The conditions a rule finds wanting, from facts where each named one is false.
fn wanting(conditions: &'static [Rule]) -> Conditions {
    let facts = Condition::ALL
        .into_iter()
        .fold(Facts::none(), |f, c| f.with(c, false));
    Rule::All(conditions).judge(facts).wanted_true
}

#[test]
fn condition_sets_are_sets() {
    const GPS: &[Rule] = &[Rule::Is(Condition::Gps)];
    const BOTH: &[Rule] = &[Rule::Is(Condition::Gps), Rule::Is(Condition::Compass)];
    let gps = wanting(GPS);
    let both = wanting(BOTH);
    assert!(Conditions::EMPTY.is_empty());
    assert!(!gps.is_empty());
    assert!(gps.contains(Condition::Gps) && !gps.contains(Condition::Compass));
    // A union with itself is itself.
    assert_eq!(gps.union(gps), gps);
    assert_eq!(gps.union(Conditions::EMPTY), gps);
    assert!(both.contains_all(gps));
    assert!(!gps.contains_all(both));
    assert!(gps.contains_all(Conditions::EMPTY));
    assert_eq!(
        both.iter().collect::<Vec<_>>(),
        vec![Condition::Gps, Condition::Compass]
    );
}

#[test]
fn a_conjunction_inside_a_disjunction_is_bracketed() {
    const INNER: &[Rule] = &[Rule::Is(Condition::Gps), Rule::Is(Condition::Satellites)];
    const RULE: &[Rule] = &[Rule::All(INNER), Rule::Not(Condition::Bypass)];
    assert_eq!(
        Rule::Any(RULE).to_string(),
        "(gps AND satellites) OR NOT bypass"
    );
    const NESTED: &[Rule] = &[Rule::All(INNER), Rule::Is(Condition::Imu)];
    assert_eq!(Rule::All(NESTED).to_string(), "gps AND satellites AND imu");
}
