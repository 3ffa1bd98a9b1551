//! Component tests of the restart in the air (`restart.rs`): the record left for a
//! successor, the trim it keeps, what a restarted process flies while it aligns, and when the
//! alignment ends.

use super::tests::{gps_fix, raised, still};
use super::*;
use heli_proto::scb::Controls;

const S: u64 = 1_000_000;

fn warm(trim: Option<Controls>) -> WarmStart {
    WarmStart {
        gyro_bias_rps: [0.001, 0.0, -0.002],
        origin: None,
        home_ned_m: Some([1.0, 2.0, 3.0]),
        airborne: true,
        trim,
        references: heli_nav::GroundReferences::default(),
        roll: None,
    }
}

fn trim() -> Controls {
    Controls {
        aileron: 0.02,
        elevator: -0.03,
        rudder: 0.41,
        collective: 0.55,
        throttle: heli_control::GOVERNED_THROTTLE,
    }
}

#[test]
fn the_trim_is_a_two_second_average_of_the_commands() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    let first = trim();
    core.average_trim(&first, 0.02);
    assert_eq!(
        core.restart.trim,
        Some(first),
        "the first command is the average"
    );
    let next = Controls {
        aileron: 0.12,
        elevator: 0.07,
        rudder: 0.21,
        collective: 0.35,
        throttle: 0.9,
    };
    core.average_trim(&next, 0.5);
    let k = 0.5 / restart::TRIM_AVERAGE_S;
    let t = core.restart.trim.unwrap();
    let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-12, "{a} {b}");
    close(t.aileron, 0.02 + k * 0.1);
    close(t.elevator, -0.03 + k * 0.1);
    close(t.rudder, 0.41 - k * 0.2);
    close(t.collective, 0.55 - k * 0.2);
    // The throttle is the governor's, not averaged.
    close(t.throttle, 0.9);
    // A step longer than the window replaces it.
    core.average_trim(&first, 5.0);
    assert_eq!(core.restart.trim, Some(first));
}

#[test]
fn the_record_left_for_a_successor() {
    let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    assert_eq!(
        core.warm_start(),
        None,
        "nothing before the estimate starts"
    );
    core.nav.initialise(
        0,
        &heli_nav::ImuBiases {
            gyro_rps: Vector3::new(0.001, 0.002, -0.003),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
            samples: 100,
        },
    );
    core.seq.home_ned_m = Some(Vector3::new(1.0, 2.0, 3.0));
    core.seq.airborne_once = true;
    core.restart.trim = Some(trim());
    let w = core.warm_start().unwrap();
    assert_eq!(w.gyro_bias_rps, [0.001, 0.002, -0.003]);
    assert_eq!(w.home_ned_m, Some([1.0, 2.0, 3.0]));
    assert!(w.airborne);
    assert_eq!(w.trim, Some(trim()));
}

#[test]
fn while_aligning_it_flies_the_trim_with_the_tail_damping_the_true_yaw_rate() {
    let core = FlightCore::restarted(
        CoreConfig::default(),
        FlightParams::default(),
        warm(Some(trim())),
    );
    let damper = core.config.yaw_damper;
    // The gyro reads 0.3 rad/s; 0.302 of it is rate, the bias being −0.002.
    let u = core.aligning_controls(0.3).unwrap();
    assert_eq!(
        u,
        Controls {
            rudder: 0.41 - damper.gain * 0.302,
            ..trim()
        }
        .clamped()
    );
    // Without a trim: the blind failsafe's collective, with the damped tail on its trim.
    let core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm(None));
    let g = core.config;
    assert_eq!(
        core.aligning_controls(0.3).unwrap(),
        Controls {
            collective: g.hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
            rudder: damper.trim - damper.gain * 0.302,
            throttle: heli_control::GOVERNED_THROTTLE,
            ..Controls::default()
        }
        .clamped()
    );
    // Not aligning: nothing.
    let core = FlightCore::new(CoreConfig::default(), FlightParams::default());
    assert_eq!(core.aligning_controls(0.3), None);
}

#[test]
fn the_alignment_waits_for_a_gps_fix_up_to_its_limit() {
    // With a fix: one second.
    let mut core =
        FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm(None));
    let mut out = Vec::new();
    core.handle(Input::Gps(gps_fix(8)), 0, &mut out);
    assert!(core.nav.origin().is_some() && core.aiding.last_good_fix.is_some());
    let mut t = 0;
    while core.aligning() && t < 5 * S {
        t += 10_000;
        core.handle(Input::Imu(still()), t, &mut out);
        if t.is_multiple_of(200_000) {
            core.handle(Input::Gps(gps_fix(8)), t, &mut out);
        }
    }
    let aligned_after = t;
    assert!(raised(&out, CoreEvent::RestartedInAir));
    let with_gps = raised(&out, CoreEvent::AlignedInAir { gps: true });
    // Without one: three seconds.
    let mut core =
        FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm(None));
    let mut out = Vec::new();
    let mut t = 0;
    while core.aligning() && t < 5 * S {
        t += 10_000;
        core.handle(Input::Imu(still()), t, &mut out);
    }
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: false }));
    // The first sample opens the window at 10 ms.
    assert_eq!(t, 10_000 + (restart::ALIGN_GPS_WAIT_S * 1e6) as u64);
    // The predecessor's origin is no fix: without one heard, still three seconds.
    let located = WarmStart {
        origin: Some(heli_nav::GeoOrigin {
            lat_deg: 42.36,
            lon_deg: -71.09,
            alt_m: 10.0,
        }),
        ..warm(None)
    };
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), located);
    assert!(core.nav.origin().is_some());
    let mut t = 0;
    while core.aligning() && t < 5 * S {
        t += 10_000;
        core.handle(Input::Imu(still()), t, &mut Vec::new());
    }
    assert_eq!(t, 10_000 + (restart::ALIGN_GPS_WAIT_S * 1e6) as u64);
    assert!(with_gps, "aligned with the GPS's velocity");
    assert_eq!(aligned_after, 10_000 + (restart::ALIGN_S * 1e6) as u64);
    // The estimate starts level from the samples' mean specific force, with the bias kept.
    let state = core.navigator().state().unwrap();
    let (roll, pitch, _) = state.euler_rad();
    assert!(roll.abs() < 0.01 && pitch.abs() < 0.01, "{roll} {pitch}");
    assert!((state.gyro_bias_rps.z + 0.002).abs() < 1e-9);
}

#[test]
fn a_helicopter_still_rolling_is_levelled_where_it_is_at_the_end_of_the_window() {
    // Rolling right at 1 rad/s through the whole window, from 0.2 rad: the specific force
    // turns in the body frame. The mean of the raw readings would level it at the window's
    // middle (0.5 rad behind); turned back by the gyros, it is levelled at its end.
    let rate_rps = 1.0;
    let roll_at = |t_us: u64| 0.2 + rate_rps * t_us as f64 * 1e-6;
    // Biases large enough that using them the wrong way round would show.
    let biased = WarmStart {
        gyro_bias_rps: [0.05, -0.04, 0.01],
        ..warm(None)
    };
    let bias = biased.gyro_bias_rps;
    let sample = |t_us: u64| {
        let roll = roll_at(t_us);
        ImuRepr {
            rate_rps: [rate_rps + bias[0], bias[1], bias[2]],
            accel_mps2: [0.0, -9.81 * roll.sin(), -9.81 * roll.cos()],
            temp_c: 30.0,
        }
    };
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), biased);
    let mut out = Vec::new();
    core.handle(Input::Gps(gps_fix(8)), 0, &mut out);
    let mut t = 0;
    while core.aligning() && t < 5 * S {
        t += 10_000;
        core.handle(Input::Imu(sample(t)), t, &mut out);
    }
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: true }));
    let (roll, pitch, _) = core.navigator().state().unwrap().euler_rad();
    assert!(
        (roll - roll_at(t)).abs() < 0.02,
        "levelled at {roll} rad, rolled {} rad",
        roll_at(t)
    );
    assert!(pitch.abs() < 0.02, "{pitch}");
    // A gap in the samples is not integrated across: the step is bounded.
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), biased);
    core.handle(Input::Gps(gps_fix(8)), 0, &mut out);
    let level = ImuRepr {
        rate_rps: [rate_rps + bias[0], bias[1], bias[2]],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    };
    core.handle(Input::Imu(level), 10_000, &mut out);
    // One sample 0.9 s later: integrated over at most 50 ms (0.05 rad), not 0.9 s.
    let turned = ImuRepr {
        accel_mps2: [0.0, -9.81 * 0.05_f64.sin(), -9.81 * 0.05_f64.cos()],
        ..level
    };
    core.handle(Input::Imu(turned), 910_000, &mut out);
    let mut t = 910_000;
    while core.aligning() && t < 5 * S {
        t += 10_000;
        let a = 0.05 + rate_rps * (t - 910_000) as f64 * 1e-6;
        core.handle(
            Input::Imu(ImuRepr {
                accel_mps2: [0.0, -9.81 * a.sin(), -9.81 * a.cos()],
                ..level
            }),
            t,
            &mut out,
        );
    }
    let (roll, _, _) = core.navigator().state().unwrap().euler_rad();
    let expected = 0.05 + rate_rps * (t - 910_000) as f64 * 1e-6;
    assert!((roll - expected).abs() < 0.02, "{roll} against {expected}");
}
