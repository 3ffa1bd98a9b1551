//! The autorotation's law against values worked out from its documentation
//! (docs/autorotation.md and the doc comments): the stages and their order, the rotor-speed
//! collective and the cushion's sink limit, the glide's speed and entry flare, the flare's
//! deceleration, the righting of an upset, the tail.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::arithmetic_side_effects
)]

use heli_control::autorotation::{
    Autorotation, AutorotationGains, AutorotationStage, HOVERING_MAX_SPEED_MPS,
};
use heli_control::hover::{HoverController, HoverGains, accel_to_attitude};
use heli_control::{GOVERNED_THROTTLE, limit};
use heli_nav::NavState;
use nalgebra::{UnitQuaternion, Vector3};

const TOL: f64 = 1e-12;

fn close(a: f64, b: f64) {
    assert!((a - b).abs() < TOL, "{a} != {b}");
}

fn gains() -> AutorotationGains {
    AutorotationGains {
        rotor_target_rpm: 1400.0,
        glide_collective: -0.3,
        rotor_to_collective: 0.004,
        rotor_integral: 0.002,
        min_collective: -0.45,
        glide_speed_mps: 12.0,
        glide_max_tilt_rad: 0.35,
        glide_rotor_band_rpm: 600.0,
        entry_pitch_rad: 0.45,
        flare_height_m: 10.0,
        level_height_m: 1.5,
        flare_max_tilt_rad: 0.3,
        flare_decel_per_mps: 0.3,
        cushion_decel_mps2: 9.0,
        hover_auto_height_m: 4.0,
        hover_cushion_decel_mps2: 2.5,
        touchdown_sink_mps: 0.6,
        touchdown_height_m: 0.3,
        sink_to_collective: 0.7,
        cushion_collective: 0.4,
        upset_collective: 0.05,
        upset_tilt_rad: 1.2,
        upset_rate_rps: 5.0,
    }
}

fn est(att: UnitQuaternion<f64>, vel: Vector3<f64>) -> NavState {
    NavState {
        t_us: 0,
        att,
        vel_ned_mps: vel,
        pos_ned_m: Vector3::zeros(),
        rate_body_rps: Vector3::new(0.1, -0.2, 0.03),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

fn level(yaw: f64, vel: Vector3<f64>) -> NavState {
    est(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw), vel)
}

#[test]
fn the_sink_profile_decelerates_to_the_touchdown_sink_above_the_ground() {
    let ar = Autorotation::begin(gains(), &level(0.0, Vector3::zeros()), 50.0);
    close(ar.sink_profile_mps(0.1), 0.6);
    close(ar.sink_profile_mps(0.3), 0.6);
    close(ar.sink_profile_mps(5.3), (0.36f64 + 2.0 * 9.0 * 5.0).sqrt());
}

#[test]
fn close_to_the_ground_at_walking_speed_the_autorotation_is_a_hovering_one() {
    let g = gains();
    let hovering_profile = (0.36f64 + 2.0 * 2.5 * 5.0).sqrt();
    let glide_profile = (0.36f64 + 2.0 * 9.0 * 5.0).sqrt();
    // Still, below the height (and just below it): hovering.
    for height_m in [0.5, 3.0, 4.0 - 1e-9] {
        let ar = Autorotation::begin(g, &level(0.0, Vector3::zeros()), height_m);
        assert!(ar.hovering(), "{height_m}");
        close(ar.sink_profile_mps(5.3), hovering_profile);
        close(ar.sink_profile_mps(0.2), 0.6);
    }
    // At walking speed exactly, in any direction, and sinking: hovering.
    let walking = Vector3::new(0.6, 0.8, 0.0) * HOVERING_MAX_SPEED_MPS;
    let ar = Autorotation::begin(g, &level(1.0, walking + Vector3::new(0.0, 0.0, 1.5)), 2.0);
    assert!(ar.hovering());
    // From the height up, or faster than walking: the glide's cushion.
    let faster = Vector3::new(0.6, 0.8, 0.0) * (HOVERING_MAX_SPEED_MPS + 1e-6);
    for (vel, height_m) in [
        (Vector3::zeros(), 4.0),
        (Vector3::zeros(), 40.0),
        (faster, 2.0),
        (Vector3::zeros(), f64::NAN),
    ] {
        let ar = Autorotation::begin(g, &level(0.0, vel), height_m);
        assert!(!ar.hovering(), "{vel:?} at {height_m}");
        close(ar.sink_profile_mps(5.3), glide_profile);
    }
}

#[test]
fn a_hovering_autorotation_raises_the_collective_on_a_sink_the_glide_would_allow() {
    let g = gains();
    let mut hover = HoverController::new(HoverGains::default());
    // 2 m up, sinking 3.5 m/s, the rotor on its target: the glide's profile allows
    // 5.6 m/s here (no cushion yet, the flare), the hovering one 3.0 m/s (the cushion).
    let e = level(0.0, Vector3::new(0.0, 0.0, 3.5));
    let mut low = Autorotation::begin(g, &level(0.0, Vector3::zeros()), 2.0);
    let mut high = Autorotation::begin(g, &level(0.0, Vector3::zeros()), 50.0);
    let allowed = (0.36f64 + 2.0 * 2.5 * 1.7).sqrt();
    assert!(allowed < 3.5 && (0.36f64 + 2.0 * 9.0 * 1.7).sqrt() > 3.5);
    let u = low.update(&mut hover, &e, 2.0, 1400.0, 0.02);
    assert_eq!(low.stage(), AutorotationStage::Cushion);
    close(u.collective, 0.4 + 0.7 * (3.5 - allowed));
    let mut hover = HoverController::new(HoverGains::default());
    let u = high.update(&mut hover, &e, 2.0, 1400.0, 0.02);
    assert_eq!(high.stage(), AutorotationStage::Flare);
    close(u.collective, -0.3);
}

#[test]
fn the_stages_follow_height_sink_and_attitude() {
    let g = gains();
    let mut hover = HoverController::new(HoverGains::default());
    let e = level(0.0, Vector3::new(8.0, 0.0, 3.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    assert_eq!(ar.stage(), AutorotationStage::Glide);
    ar.update(&mut hover, &e, 40.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Glide);
    ar.update(&mut hover, &e, 9.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Flare);
    // Below the level height: level.
    ar.update(&mut hover, &e, 0.6, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Level);
    // 8 m/s down at 2 m is faster than the profile (5.6 m/s): the cushion, which goes on
    // when the sink is back under the profile.
    let fast = level(0.0, Vector3::new(8.0, 0.0, 8.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    ar.update(&mut hover, &fast, 2.0, 1400.0, 0.02);
    assert!(ar.sink_profile_mps(2.0) < 8.0);
    assert_eq!(ar.stage(), AutorotationStage::Cushion);
    let slow = level(0.0, Vector3::new(8.0, 0.0, 0.5));
    ar.update(&mut hover, &slow, 8.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Cushion);
    // At the profile exactly, not faster: no cushion.
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let at = ar.sink_profile_mps(2.0);
    ar.update(
        &mut hover,
        &level(0.0, Vector3::new(8.0, 0.0, at)),
        2.0,
        1400.0,
        0.02,
    );
    assert_eq!(ar.stage(), AutorotationStage::Flare);
    // At the level height exactly, not yet level; at the flare height exactly, flaring.
    let mut ar = Autorotation::begin(g, &e, 50.0);
    ar.update(&mut hover, &e, 1.5, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Flare);
    let mut ar = Autorotation::begin(g, &e, 50.0);
    ar.update(&mut hover, &e, 10.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Glide);
    // Below the level height, level whatever the sink.
    ar.update(&mut hover, &e, 1.4, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Level);
    // Tilted past the upset limit (1.3 rad of roll), at any height.
    let tilted = est(
        UnitQuaternion::from_euler_angles(1.3, 0.0, 0.0),
        e.vel_ned_mps,
    );
    ar.update(&mut hover, &tilted, 1.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Upset);
    let under = est(
        UnitQuaternion::from_euler_angles(1.1, 0.0, 0.0),
        e.vel_ned_mps,
    );
    ar.update(&mut hover, &under, 1.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Level);
    for (stage, name) in [
        (AutorotationStage::Upset, "upset"),
        (AutorotationStage::Glide, "glide"),
        (AutorotationStage::Flare, "flare"),
        (AutorotationStage::Cushion, "cushion"),
        (AutorotationStage::Level, "level"),
    ] {
        assert_eq!(stage.name(), name);
    }
}

#[test]
fn the_collective_holds_the_rotor_speed_with_feedback_and_integral() {
    let g = gains();
    let mut hover = HoverController::new(HoverGains::default());
    let e = level(0.0, Vector3::new(8.0, 0.0, 3.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    // 100 rpm fast: −0.3 + 0.004 × 100 + 0.002 × (100 × 0.02).
    let u = ar.update(&mut hover, &e, 40.0, 1500.0, 0.02);
    close(u.collective, -0.3 + 0.4 + 0.002 * 2.0);
    let u = ar.update(&mut hover, &e, 40.0, 1500.0, 0.02);
    close(u.collective, -0.3 + 0.4 + 0.002 * 4.0);
    assert_eq!(u.throttle, GOVERNED_THROTTLE);
    // Slow: held at the lowest collective.
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let u = ar.update(&mut hover, &e, 40.0, 1300.0, 0.02);
    close(u.collective, -0.45);
    // A rotor speed that is not a reading counts as on target.
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let u = ar.update(&mut hover, &e, 40.0, f64::NAN, 0.02);
    close(u.collective, -0.3);
    // The integral holds at most half the travel.
    let mut ar = Autorotation::begin(g, &e, 50.0);
    for _ in 0..2_000 {
        ar.update(&mut hover, &e, 40.0, 1900.0, 0.1);
    }
    let u = ar.update(&mut hover, &e, 40.0, 1400.0, 0.0);
    close(u.collective, -0.3 + 0.5);
}

#[test]
fn the_cushion_limits_the_sink_and_freezes_the_rotor_integral() {
    let g = gains();
    let mut hover = HoverController::new(HoverGains::default());
    let e = level(0.0, Vector3::new(4.0, 0.0, 6.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    ar.update(&mut hover, &e, 40.0, 1500.0, 0.02);
    // 2 m up, 6 m/s down: the profile is sqrt(0.36 + 18 × 1.7) = 5.56 m/s.
    let profile = (0.36f64 + 2.0 * 9.0 * 1.7).sqrt();
    let u = ar.update(&mut hover, &e, 2.0, 1500.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Cushion);
    close(u.collective, 0.4 + 0.7 * (6.0 - profile));
    // Under the profile now, the rotor's collective wins if higher: the integral kept
    // its 2 rpm·s from the glide.
    let slow = level(0.0, Vector3::new(4.0, 0.0, -5.0));
    let u = ar.update(&mut hover, &slow, 2.0, 1500.0, 0.02);
    let for_sink = 0.4 + 0.7 * (-5.0 - profile);
    let for_rotor: f64 = -0.3 + 0.4 + 0.002 * 2.0;
    close(u.collective, for_rotor.max(for_sink));
}

#[test]
fn the_glide_flies_its_speed_along_the_way_it_was_going() {
    let g = gains();
    let hg = HoverGains::default();
    // Moving at 5 m/s north-east: the glide goes that way, whatever the heading.
    let e = level(0.3, Vector3::new(3.0, 4.0, 2.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    let u = ar.update(&mut hover, &e, 40.0, 1400.0, 0.02);
    let mut stages = HoverController::new(hg);
    let (roll, pitch) =
        stages.velocity_to_attitude(&e, &(Vector3::new(0.6, 0.8, 0.0) * 12.0), 0.02, true);
    // Rotor on target: the nose may go down to the glide's largest tilt.
    let (a, el) = stages.attitude_to_cyclic(&e, limit(roll, 0.35), pitch.clamp(-0.35, 0.35));
    close(u.aileron, a);
    close(u.elevator, el);
    // At 2 m/s exactly, and slower, the glide goes along the heading.
    let e2 = level(0.3, Vector3::new(2.0, 0.0, 2.0));
    let mut ar = Autorotation::begin(g, &e2, 50.0);
    let mut hover = HoverController::new(hg);
    let u = ar.update(&mut hover, &e2, 40.0, 1400.0, 0.02);
    let mut stages = HoverController::new(hg);
    let dir = Vector3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
    let (roll, pitch) = stages.velocity_to_attitude(&e2, &(dir * 12.0), 0.02, true);
    let (a, el) = stages.attitude_to_cyclic(&e2, limit(roll, 0.35), pitch.clamp(-0.35, 0.35));
    close(u.aileron, a);
    close(u.elevator, el);
    // Nearly still: the glide goes along the heading.
    let e = level(0.3, Vector3::new(1.0, 1.0, 2.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    let u = ar.update(&mut hover, &e, 40.0, 1400.0, 0.02);
    let mut stages = HoverController::new(hg);
    let dir = Vector3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
    let (roll, pitch) = stages.velocity_to_attitude(&e, &(dir * 12.0), 0.02, true);
    let (a, el) = stages.attitude_to_cyclic(&e, limit(roll, 0.35), pitch.clamp(-0.35, 0.35));
    close(u.aileron, a);
    close(u.elevator, el);
}

#[test]
fn with_the_rotor_slow_the_glide_trades_speed_for_rotor_speed() {
    let g = gains();
    let hg = HoverGains::default();
    // Heading north at 10 m/s, rotor 300 rpm slow: ready = (−300 + 600)/600 = 0.5, all
    // the speed share (10/5 ≥ 1): the pitch is at least −0.35 × 0.5 + 0.45 × 1 × 0.5.
    let e = level(0.0, Vector3::new(10.0, 0.0, 2.0));
    let floor = -0.35 * 0.5 + 0.45 * 0.5;
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    let u = ar.update(&mut hover, &e, 40.0, 1100.0, 0.02);
    let mut stages = HoverController::new(hg);
    let (roll, pitch) = stages.velocity_to_attitude(&e, &Vector3::new(12.0, 0.0, 0.0), 0.02, true);
    assert!(pitch < floor);
    let (a, el) = stages.attitude_to_cyclic(&e, limit(roll, 0.35), floor);
    close(u.aileron, a);
    close(u.elevator, el);
    // At 2.5 m/s along the glide, half the entry pitch.
    let e = level(0.0, Vector3::new(2.5, 0.0, 2.0));
    let floor = -0.35 * 0.5 + 0.45 * 0.5 * 0.5;
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    let u = ar.update(&mut hover, &e, 40.0, 1100.0, 0.02);
    let mut stages = HoverController::new(hg);
    let (roll, pitch) = stages.velocity_to_attitude(&e, &Vector3::new(12.0, 0.0, 0.0), 0.02, true);
    let (a, el) = stages.attitude_to_cyclic(
        &e,
        limit(roll, 0.35),
        pitch.max(floor).min(0.35f64.max(floor)),
    );
    close(u.aileron, a);
    close(u.elevator, el);
}

#[test]
fn the_flare_decelerates_along_the_glide_and_stops_the_sideways_drift() {
    let g = gains();
    let hg = HoverGains::default();
    let begin = level(0.0, Vector3::new(10.0, 0.0, 2.0));
    let mut ar = Autorotation::begin(g, &begin, 50.0);
    let mut hover = HoverController::new(hg);
    // Heading 0.2 rad, 6 m/s along the glide (north) and 1 m/s east.
    let e = level(0.2, Vector3::new(6.0, 1.0, 2.0));
    let u = ar.update(&mut hover, &e, 8.0, 1400.0, 0.02);
    assert_eq!(ar.stage(), AutorotationStage::Flare);
    let accel = Vector3::new(-0.3 * 6.0, -hg.vel_to_accel * 1.0, 0.0);
    let (roll, pitch) = accel_to_attitude(0.2, &accel);
    let stages = HoverController::new(hg);
    let (a, el) = stages.attitude_to_cyclic(&e, limit(roll, 0.3), limit(pitch, 0.3));
    close(u.aileron, a);
    close(u.elevator, el);
    // Level near the ground.
    let u = ar.update(&mut hover, &e, 1.0, 1400.0, 0.02);
    let (a, el) = stages.attitude_to_cyclic(&e, 0.0, 0.0);
    close(u.aileron, a);
    close(u.elevator, el);
}

#[test]
fn an_upset_is_righted_the_shortest_way_at_the_upset_collective() {
    let g = gains();
    let hg = HoverGains::default();
    let e = level(0.0, Vector3::new(10.0, 0.0, 2.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    // Rolled 2.0 rad right: right it by rolling left at att_to_rate × 2.0, at most 5 rad/s.
    let upset = est(
        UnitQuaternion::from_euler_angles(2.0, 0.0, 0.0),
        e.vel_ned_mps,
    );
    let u = ar.update(&mut hover, &upset, 50.0, 1400.0, 0.02);
    let stages = HoverController::new(hg);
    let rate = (hg.att_to_rate * 2.0).min(5.0);
    let (a, el) = stages.rates_to_cyclic(&upset, -rate, 0.0);
    close(u.aileron, a);
    close(u.elevator, el);
    close(u.collective, 0.05);
    // With room under the rate limit, the rate is the gain times the tilt.
    let mut ar = Autorotation::begin(
        AutorotationGains {
            upset_rate_rps: 10.0,
            ..gains()
        },
        &e,
        50.0,
    );
    // A gentle gain keeps the cyclic off its stops: 0.5 × 2.0 rad.
    let gentle = HoverGains {
        att_to_rate: 0.5,
        ..hg
    };
    let mut gentle_hover = HoverController::new(gentle);
    let u = ar.update(&mut gentle_hover, &upset, 50.0, 1400.0, 0.02);
    let (a, el) = HoverController::new(gentle).rates_to_cyclic(&upset, -0.5 * 2.0, 0.0);
    assert!(a.abs() < 1.0, "{a}");
    close(u.aileron, a);
    close(u.elevator, el);
    // Pitched 1.4 rad nose up, with a slower limit: pitch down at 1 rad/s.
    let g = AutorotationGains {
        upset_rate_rps: 1.0,
        ..gains()
    };
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let nose_up = est(
        UnitQuaternion::from_euler_angles(0.0, 1.4, 0.0),
        e.vel_ned_mps,
    );
    let u = ar.update(&mut hover, &nose_up, 50.0, 1400.0, 0.02);
    let (a, el) = stages.rates_to_cyclic(&nose_up, 0.0, -1.0);
    close(u.aileron, a);
    close(u.elevator, el);
    // Upside down exactly: any axis will do; it rolls.
    let inverted = est(
        UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0),
        e.vel_ned_mps,
    );
    let u = ar.update(&mut hover, &inverted, 50.0, 1400.0, 0.02);
    let (a, el) = stages.rates_to_cyclic(&inverted, 1.0, 0.0);
    close(u.aileron, a);
    close(u.elevator, el);
}

#[test]
fn the_tail_holds_the_heading_it_began_on_without_engine_torque() {
    let g = gains();
    let hg = HoverGains::default();
    let e = level(0.5, Vector3::new(10.0, 0.0, 2.0));
    let mut ar = Autorotation::begin(g, &e, 50.0);
    let mut hover = HoverController::new(hg);
    // Turned 0.2 rad off the heading it began on.
    let turned = level(0.7, Vector3::new(10.0, 0.0, 2.0));
    let u = ar.update(&mut hover, &turned, 40.0, 1400.0, 0.02);
    let mut stages = HoverController::new(hg);
    stages.velocity_to_attitude(&turned, &(Vector3::x() * 12.0), 0.02, true);
    let r_cmd = limit(hg.heading_to_rate * -0.2, hg.max_yaw_rate_rps);
    let rudder = stages.yaw_rate_to_tail(&turned, r_cmd, 0.0, 0.02, true);
    close(u.rudder, rudder);
}
