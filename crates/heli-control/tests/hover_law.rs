//! The hover controller's law, stage by stage, against values worked out from its
//! documentation (docs/control.md and the doc comments): each stage's output for inputs
//! where every term counts, the limits, and the integrators' memory. Gains are chosen apart
//! from one another (no 1s, no equal pairs) so that a term with the wrong gain, sign or
//! operation gives another number.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::arithmetic_side_effects
)]

use heli_control::hover::{HoverController, HoverGains, Target, YAW_TRIM_AUTHORITY};
use heli_control::sanitize_dt;
use heli_control::{GOVERNED_THROTTLE, limit};
use heli_nav::{GRAVITY_MPS2, NavState};
use nalgebra::{UnitQuaternion, Vector3};

const TOL: f64 = 1e-12;

fn gains() -> HoverGains {
    HoverGains {
        pos_to_vel: 0.45,
        max_horizontal_speed_mps: 2.5,
        vel_to_accel: 0.7,
        vel_integral: 0.3,
        max_accel_mps2: 50.0,
        max_trim_accel_mps2: 40.0,
        max_tilt_rad: 1.2,
        att_to_rate: 3.0,
        max_rate_rps: 20.0,
        rate_feedforward: 0.25,
        rate_feedback: 0.07,
        alt_to_climb: 0.8,
        max_climb_mps: 1.5,
        max_descent_mps: 1.1,
        climb_feedback: 0.12,
        climb_integral: 0.04,
        hover_collective: 0.52,
        heading_to_rate: 2.2,
        heading_lock_to_rate: 8.0,
        max_yaw_rate_rps: 1.3,
        yaw_rate_feedback: 0.35,
        yaw_integral: 0.11,
        tail_trim: 0.4,
        tail_feedforward_lag_s: 0.5,
    }
}

/// An estimate at roll 0.1, pitch −0.05, yaw 0.4 rad, moving and turning.
fn est() -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.1, -0.05, 0.4),
        vel_ned_mps: Vector3::new(1.0, -0.5, 0.3),
        pos_ned_m: Vector3::new(2.0, 3.0, -10.0),
        rate_body_rps: Vector3::new(0.2, -0.1, 0.05),
        accel_body_mps2: Vector3::new(0.0, 0.0, -9.81),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < TOL, "{a} != {b}");
}

/// Acceleration (NED) to roll and pitch at yaw `yaw`: into the heading frame, nose down to
/// go forward, right roll to go right.
fn tilt_for(accel_n: f64, accel_e: f64, yaw: f64) -> (f64, f64) {
    let fwd = yaw.cos() * accel_n + yaw.sin() * accel_e;
    let right = -yaw.sin() * accel_n + yaw.cos() * accel_e;
    ((right / GRAVITY_MPS2).atan(), -(fwd / GRAVITY_MPS2).atan())
}

#[test]
fn velocity_to_attitude_is_correction_plus_trim_turned_into_the_heading() {
    let mut c = HoverController::new(gains());
    let cmd = Vector3::new(3.0, 2.0, 0.0);
    // Velocity error (2.0, 2.5); the integrator holds error × dt = (0.2, 0.25).
    let (roll, pitch) = c.velocity_to_attitude(&est(), &cmd, 0.1, true);
    let (r, p) = tilt_for(0.7 * 2.0 + 0.3 * 0.2, 0.7 * 2.5 + 0.3 * 0.25, 0.4);
    close(roll, r);
    close(pitch, p);
    close(c.trim_accel_ned_mps2().x, 0.3 * 0.2);
    close(c.trim_accel_ned_mps2().y, 0.3 * 0.25);
    close(c.trim_accel_ned_mps2().z, 0.0);
    // The integrator remembers: a second step adds to it.
    let (roll, pitch) = c.velocity_to_attitude(&est(), &cmd, 0.1, true);
    let (r, p) = tilt_for(0.7 * 2.0 + 0.3 * 0.4, 0.7 * 2.5 + 0.3 * 0.5, 0.4);
    close(roll, r);
    close(pitch, p);
}

#[test]
fn on_the_ground_the_velocity_integrator_holds_still() {
    let mut c = HoverController::new(gains());
    let cmd = Vector3::new(3.0, 2.0, 0.0);
    let (roll, pitch) = c.velocity_to_attitude(&est(), &cmd, 0.1, false);
    let (r, p) = tilt_for(0.7 * 2.0, 0.7 * 2.5, 0.4);
    close(roll, r);
    close(pitch, p);
    assert_eq!(c.trim_accel_ned_mps2(), Vector3::zeros());
}

#[test]
fn the_correction_and_the_trim_are_limited_apart_and_the_tilt_on_the_sum() {
    let g = HoverGains {
        max_accel_mps2: 1.0,
        max_trim_accel_mps2: 0.09,
        ..gains()
    };
    let mut c = HoverController::new(g);
    let cmd = Vector3::new(4.0, -0.5, 0.0);
    // Error (3, 0): correction 2.1 limited to 1.0; trim 0.3 × 0.3 = 0.09 is at its limit.
    let (roll, pitch) = c.velocity_to_attitude(&est(), &cmd, 0.1, true);
    let (r, p) = tilt_for(1.0 + 0.09, 0.0, 0.4);
    close(roll, r);
    close(pitch, p);
    // Error (3, 0) again: the trim would be 0.18 and is scaled back to 0.09.
    let (roll, pitch) = c.velocity_to_attitude(&est(), &cmd, 0.1, true);
    close(roll, r);
    close(pitch, p);
    close(c.trim_accel_ned_mps2().norm(), 0.09);
    // A diagonal error: the correction's length is limited, its direction kept.
    let mut c = HoverController::new(g);
    let (roll, pitch) = c.velocity_to_attitude(&est(), &Vector3::new(4.0, 3.5, 0.0), 0.0, true);
    let (r, p) = tilt_for(3.0 / 5.0, 4.0 / 5.0, 0.4);
    close(roll, r);
    close(pitch, p);
    // The tilt limit.
    let g = HoverGains {
        max_tilt_rad: 0.05,
        ..gains()
    };
    let mut c = HoverController::new(g);
    let (roll, pitch) = c.velocity_to_attitude(&est(), &Vector3::new(-9.0, 9.0, 0.0), 0.0, false);
    close(roll, 0.05);
    close(pitch, 0.05);
}

#[test]
fn attitude_to_cyclic_is_rate_feedforward_plus_feedback() {
    let c = HoverController::new(gains());
    let (roll, pitch, _) = est().euler_rad();
    let (a, e) = c.attitude_to_cyclic(&est(), 0.3, -0.2);
    let p_cmd = 3.0 * (0.3 - roll);
    let q_cmd = 3.0 * (-0.2 - pitch);
    close(a, 0.25 * p_cmd + 0.07 * (p_cmd - 0.2));
    close(e, 0.25 * q_cmd + 0.07 * (q_cmd + 0.1));
    // Rate commands limited.
    let c = HoverController::new(HoverGains {
        max_rate_rps: 0.1,
        ..gains()
    });
    let (a, e) = c.attitude_to_cyclic(&est(), 0.3, -0.2);
    close(a, 0.25 * 0.1 + 0.07 * (0.1 - 0.2));
    close(e, 0.25 * -0.1 + 0.07 * (-0.1 + 0.1));
    // The cyclic limited to full travel.
    let (a, e) = HoverController::new(gains()).rates_to_cyclic(&est(), 9.0, -9.0);
    close(a, 1.0);
    close(e, -1.0);
}

#[test]
fn climb_to_collective_is_tilt_corrected_feedforward_with_feedback_and_integral() {
    let mut c = HoverController::new(gains());
    let (roll, pitch, _) = est().euler_rad();
    let tilt_cos = roll.cos() * pitch.cos();
    // w_cmd −1.2 against 0.3 down: error −1.5; integral −0.15 after 0.1 s.
    let u = c.climb_to_collective(&est(), -1.2, 0.1);
    close(u, 0.52 / tilt_cos + 0.12 * 1.5 + 0.04 * 0.15);
    let u = c.climb_to_collective(&est(), -1.2, 0.1);
    close(u, 0.52 / tilt_cos + 0.12 * 1.5 + 0.04 * 0.3);
    // The integral holds at most half the travel.
    let mut c = HoverController::new(gains());
    for _ in 0..200 {
        c.climb_to_collective(&est(), 10.0, 0.1);
    }
    let u = c.climb_to_collective(&est(), 0.3, 0.1);
    close(u, 0.52 / tilt_cos - 0.5);
    // Steeply tilted, the feedforward is capped at twice the hover collective.
    let mut steep = est();
    steep.att = UnitQuaternion::from_euler_angles(1.2, 0.4, 0.0);
    let mut c = HoverController::new(HoverGains {
        hover_collective: 0.4,
        ..gains()
    });
    close(c.climb_to_collective(&steep, 0.3, 0.0), 0.4 / 0.5);
}

#[test]
fn yaw_rate_to_tail_follows_the_lagged_torque_and_the_rate_error() {
    let mut c = HoverController::new(gains());
    // In the air: the feedforward starts at the torque of this collective, 0.4 × 0.65/0.52.
    let ff = 0.4 * 0.65 / 0.52;
    // Rate error 0.5 − 0.05 = 0.45, integral 0.045 after 0.1 s.
    let u = c.yaw_rate_to_tail(&est(), 0.5, 0.65, 0.1, true);
    close(u, ff + 0.35 * 0.45 + 0.11 * 0.045);
    // The collective drops to 0.26: the feedforward moves a fifth of the way (0.1 s / 0.5 s).
    let lagged = ff + 0.2 * (0.4 * 0.26 / 0.52 - ff);
    let u = c.yaw_rate_to_tail(&est(), 0.5, 0.26, 0.1, true);
    close(u, lagged + 0.35 * 0.45 + 0.11 * 0.09);
    // On the ground the engine's torque starts from idle and the integral stays empty.
    let mut c = HoverController::new(gains());
    let u = c.yaw_rate_to_tail(&est(), 0.5, 0.65, 0.1, false);
    close(u, 0.2 * ff + 0.35 * 0.45);
    // The torque feedforward is capped at twice the trim, the integral at the tail's
    // authority.
    let mut c = HoverController::new(HoverGains {
        tail_feedforward_lag_s: 0.0,
        ..gains()
    });
    let u = c.yaw_rate_to_tail(&est(), 0.05, 3.0, 0.1, false);
    close(u, 0.8);
    let mut c = HoverController::new(HoverGains {
        yaw_rate_feedback: 0.0,
        tail_trim: 0.0,
        ..gains()
    });
    for _ in 0..2_000 {
        c.yaw_rate_to_tail(&est(), -20.0, 0.5, 0.1, true);
    }
    let u = c.yaw_rate_to_tail(&est(), 0.05, 0.5, 0.1, true);
    close(u, -0.11 * YAW_TRIM_AUTHORITY / 0.11);
}

#[test]
fn update_chains_the_stages() {
    let g = gains();
    let mut c = HoverController::new(g);
    let mut stages = HoverController::new(g);
    let target = Target {
        pos_ned_m: Vector3::new(6.0, 0.0, -14.0),
        vel_ned_mps: Vector3::new(0.5, 0.2, -0.1),
        yaw_rad: 1.1,
    };
    let u = c.update(&est(), &target, 0.02, true);
    // Position error (4, −3): 0.45 × 5 = 2.25 m/s, under the 2.5 limit.
    let vel_cmd = Vector3::new(0.5 + 0.45 * 4.0, 0.2 - 0.45 * 3.0, 0.0);
    let (roll, pitch) = stages.velocity_to_attitude(&est(), &vel_cmd, 0.02, true);
    let (a, e) = stages.attitude_to_cyclic(&est(), roll, pitch);
    // Altitude error −4 m: 0.8 × −4 = −3.2, limited to a 1.5 m/s climb.
    let collective = stages.climb_to_collective(&est(), -0.1 - 1.5, 0.02);
    // Heading error 0.7 rad: 2.2 × 0.7 = 1.54, limited to 1.3.
    let rudder = stages.yaw_rate_to_tail(&est(), 1.3, collective, 0.02, true);
    close(u.aileron, a);
    close(u.elevator, e);
    close(u.collective, limit(collective, 1.0));
    close(u.rudder, rudder);
    assert_eq!(u.throttle, GOVERNED_THROTTLE);
    assert_eq!(c, stages);
    // Close by, neither the climb nor the yaw rate is limited: 0.8 × −0.5 m and
    // 2.2 × 0.1 rad.
    let mut c = HoverController::new(g);
    let mut stages = HoverController::new(g);
    let near = Target::hold(Vector3::new(2.0, 3.0, -10.5), 0.5);
    let u = c.update(&est(), &near, 0.02, true);
    stages.velocity_to_attitude(&est(), &Vector3::zeros(), 0.02, true);
    let collective = stages.climb_to_collective(&est(), 0.8 * -0.5, 0.02);
    let rudder = stages.yaw_rate_to_tail(&est(), 2.2 * 0.1, collective, 0.02, true);
    close(u.collective, collective);
    close(u.rudder, rudder);
    // Far away, the position correction is limited to 2.5 m/s along the error.
    let mut c = HoverController::new(g);
    let mut stages = HoverController::new(g);
    let far = Target::hold(Vector3::new(2.0 + 30.0, 3.0 + 40.0, -10.0), 0.4);
    let u = c.update(&est(), &far, 0.02, false);
    let vel_cmd = Vector3::new(2.5 * 0.6, 2.5 * 0.8, 0.0);
    let (roll, pitch) = stages.velocity_to_attitude(&est(), &vel_cmd, 0.02, false);
    let (a, e) = stages.attitude_to_cyclic(&est(), roll, pitch);
    close(u.aileron, a);
    close(u.elevator, e);
    // Below the target by more than the descent limit allows: 1.1 m/s down at most.
    let low = Target::hold(Vector3::new(2.0, 3.0, -4.0), 0.4);
    let mut c = HoverController::new(g);
    let mut stages = HoverController::new(g);
    let u = c.update(&est(), &low, 0.02, false);
    close(u.collective, stages.climb_to_collective(&est(), 1.1, 0.02));
}

#[test]
fn reset_forgets_every_integrator() {
    let g = gains();
    let mut c = HoverController::new(g);
    let target = Target::hold(Vector3::new(9.0, -4.0, -12.0), 2.0);
    for _ in 0..50 {
        c.update(&est(), &target, 0.02, true);
    }
    assert_ne!(c, HoverController::new(g));
    c.reset();
    assert_eq!(c, HoverController::new(g));
}

#[test]
fn a_step_time_is_made_safe() {
    assert_eq!(sanitize_dt(0.02), 0.02);
    assert_eq!(sanitize_dt(-0.02), 0.0);
    assert_eq!(sanitize_dt(0.5), 0.1);
    assert_eq!(sanitize_dt(f64::NAN), 0.0);
    assert_eq!(sanitize_dt(f64::INFINITY), 0.0);
}
