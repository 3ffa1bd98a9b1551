use super::*;

fn sample(bias: f64) -> ImuRepr {
    ImuRepr {
        rate_rps: [bias, -bias, 2.0 * bias],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 25.0,
    }
}

#[test]
fn eighty_second_window_after_warm_up_yields_mean_gyro() {
    let mut cal = BiasCalibration::new(5.0, 80.0);
    let mut done = None;
    let mut t = 0u64;
    // Samples during warm-up carry a different (transient) bias that must be ignored.
    while t < 5_000_000 {
        assert!(cal.push(&sample(0.5)).is_none());
        t += 10_000;
    }
    while done.is_none() {
        done = cal.push(&sample(0.01));
        t += 10_000;
        assert!(t < 100_000_000, "calibration never finished");
    }
    let b = done.unwrap_or_else(|| unreachable!());
    assert!((b.gyro_rps.x - 0.01).abs() < 1e-9);
    assert!((b.gyro_rps.z - 0.02).abs() < 1e-9);
    assert!((b.mean_accel_mps2.z + 9.81).abs() < 1e-9);
    assert_eq!(b.samples, 8000);
    // It closes 85 s after the first sample (5 s warm-up + 80 s).
    assert_eq!(t - 10_000, 85_000_000);
    assert!(
        cal.push(&sample(0.01)).is_none(),
        "biases are delivered once"
    );
}

/// A sample of gyro bias (0.01, -0.01, 0.02) rad/s turning at `rate_z` more about z,
/// tilted `tilt` rad about x.
fn moving(rate_z: f64, tilt: f64) -> ImuRepr {
    ImuRepr {
        rate_rps: [0.01, -0.01, 0.02 + rate_z],
        accel_mps2: [0.0, 9.81 * tilt.sin(), -9.81 * tilt.cos()],
        temp_c: 25.0,
    }
}

/// A calibration of `window_s` whose window opened at 1 s (the 101st sample, after a warm-up
/// of 100), and the time of its next sample.
fn opened_for(window_s: f64) -> (BiasCalibration, u64) {
    let mut cal = BiasCalibration::new(1.0, window_s);
    for _ in 0..100 {
        assert!(cal.push(&moving(0.0, 0.0)).is_none());
    }
    assert!(matches!(cal.phase(), CalibrationPhase::WarmingUp { .. }));
    assert!(cal.push(&moving(0.0, 0.0)).is_none());
    assert!(matches!(cal.phase(), CalibrationPhase::Accumulating { .. }));
    (cal, 1_010_000)
}

/// Feeds `seconds` of samples made by `f` (of the sample's index) 10 ms apart; the biases
/// if the window closed.
fn feed(
    cal: &mut BiasCalibration,
    t: &mut u64,
    seconds: f64,
    f: impl Fn(u32) -> ImuRepr,
) -> Option<ImuBiases> {
    let mut done = None;
    for k in 0..(seconds * 100.0).round() as u32 {
        done = done.or(cal.push(&f(k)));
        *t += 10_000;
    }
    done
}

#[test]
fn a_turn_on_the_skids_is_left_out_and_the_window_made_longer() {
    let (mut cal, mut t) = opened_for(20.0);
    // Still for ten seconds, with a gust's rocking that averages out in each second.
    feed(&mut cal, &mut t, 10.0, |k| {
        let rock = if (500..700).contains(&k) {
            0.2 * (f64::from(k) * 0.6).sin()
        } else {
            0.0
        };
        moving(rock, 0.0)
    });
    assert_eq!(cal.take_left_out(), None);
    // Turning at 5 deg/s for two and a half seconds, from the middle of a second: two whole
    // seconds are beyond the limit, the edges (half a second in all) are not.
    feed(&mut cal, &mut t, 0.5, |_| moving(0.0, 0.0));
    feed(&mut cal, &mut t, 2.5, |_| moving(0.09, 0.0));
    let left = cal.take_left_out().unwrap_or_else(|| panic!("left out"));
    assert!(left.motion.rate_rps > MOTION_RATE_RPS, "{left:?}");
    assert_eq!(
        left.seconds, 2,
        "said on the first of the run, with the edge before it"
    );
    assert_eq!(cal.take_left_out(), None, "said once a run");
    assert_eq!(cal.left_out_s(), 3, "the edge before and two moved seconds");
    assert_eq!(cal.take_motion(), None, "no restart");
    // Still again: the second after the turn (its other edge) is left out too, and the
    // window closes four seconds late, on still seconds only.
    let mut seconds = 0.0;
    let mut done = None;
    while done.is_none() {
        done = feed(&mut cal, &mut t, 0.01, |_| moving(0.0, 0.0));
        seconds += 0.01;
        assert!(seconds < 30.0, "never finished");
    }
    let b = done.unwrap_or_else(|| unreachable!());
    assert_eq!(cal.restarts(), 0);
    assert_eq!(
        b.samples, 2000,
        "twenty still seconds, the turn's four left out"
    );
    assert_eq!(cal.left_out_s(), 4);
    // Nothing of the turn (the rocking leaves a little).
    assert!((b.gyro_rps.z - 0.02).abs() < 3e-4, "{b:?}");
    assert!(
        (t as f64 * 1e-6 - 25.01).abs() < 0.02,
        "closed at {} s: 1 + 20 + 4",
        t as f64 * 1e-6
    );
}

#[test]
fn a_creep_too_slow_for_the_one_second_check_adds_up_to_a_restart() {
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 10.0, |_| moving(0.0, 0.0));
    // 1.1 deg/s, under the one-second limit, for eight seconds: 9 deg.
    feed(&mut cal, &mut t, 8.0, |_| moving(0.02, 0.0));
    assert_eq!(cal.left_out_s(), 0, "no second beyond the rate limit");
    let m = cal.take_motion().unwrap_or_else(|| panic!("restarted"));
    assert!(m.turn_rad > MOTION_TURN_RAD, "{m:?}");
    assert!(m.rate_rps <= MOTION_RATE_RPS, "{m:?}");
    assert_eq!(cal.restarts(), 1);
}

#[test]
fn a_helicopter_that_stands_differently_starts_again_and_rocking_does_not() {
    // Tilted 4 deg for two seconds and back: rocking, left out.
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 5.0, |_| moving(0.0, 0.0));
    feed(&mut cal, &mut t, 2.0, |_| moving(0.0, 0.07));
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.0));
    assert_eq!(cal.take_motion(), None);
    let left = cal.take_left_out().unwrap_or_else(|| panic!("left out"));
    assert!(left.motion.tilt_rad > MOTION_TILT_RAD, "{left:?}");
    assert_eq!(cal.left_out_s(), 4, "two tilted and their edges");
    // Tilted for three: it stands differently now.
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.07));
    let m = cal.take_motion().unwrap_or_else(|| panic!("restarted"));
    assert!(m.tilt_rad > MOTION_TILT_RAD, "{m:?}");
    assert_eq!(cal.left_out_s(), 0, "a new window");
}

#[test]
fn a_helicopter_never_still_starts_again_and_a_turn_in_the_first_second_is_no_bias() {
    // Turning one way and back two seconds in three (a gust swinging the tail): more
    // seconds moved than were still, beyond ten.
    let swinging = |k: u32| {
        let rate = match (k / 100) % 3 {
            0 => 0.0,
            1 => 0.2,
            _ => -0.2,
        };
        moving(rate, 0.0)
    };
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 14.0, swinging);
    assert_eq!(cal.take_motion(), None, "not yet ten moved");
    feed(&mut cal, &mut t, 6.0, swinging);
    let m = cal.take_motion().unwrap_or_else(|| panic!("never still"));
    assert!(m.rate_rps > MOTION_RATE_RPS, "the last motion: {m:?}");
    // A window that opens in a 6 deg turn: its first second is the reference, but not for
    // long — the median of the next still ones shows it as a turn.
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 1.0, |_| moving(0.1, 0.0));
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.0));
    let m = cal.take_motion().unwrap_or_else(|| panic!("restarted"));
    assert!(m.turn_rad > MOTION_TURN_RAD, "{m:?}");
}

#[test]
fn motion_is_judged_on_whole_seconds() {
    // A turn over the whole fourth second is found on its last sample and not before (the
    // window's first second began with the sample that opened it).
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 2.99, |_| moving(0.0, 0.0));
    for k in 1..=100u32 {
        feed(&mut cal, &mut t, 0.01, |_| moving(0.2, 0.0));
        // The second before it is left out with it, as the turn's edge.
        assert_eq!(cal.left_out_s(), 2 * u32::from(k == 100), "sample {k}");
    }
    // A one-sample jolt of 3 rad/s in a still second averages out (0.03 rad/s), and it
    // turned 1.7 deg: kept.
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 3.0, |k| {
        moving(if k == 150 { 3.0 } else { 0.0 }, 0.0)
    });
    assert_eq!(cal.left_out_s(), 0);
    assert_eq!(cal.take_motion(), None);
}

#[test]
fn a_second_exactly_at_the_rate_limit_is_still_and_one_beyond_it_is_motion() {
    // Five samples of 1 rad/s in a second of 100: a mean of exactly 0.05 rad/s from the
    // median of three still seconds and itself.
    let second = |fast: f64| {
        move |k: u32| ImuRepr {
            rate_rps: [0.0, if k < 5 { fast } else { 0.0 }, 0.0],
            ..sample(0.0)
        }
    };
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 3.0, second(0.0));
    feed(&mut cal, &mut t, 1.0, second(1.0));
    assert_eq!(cal.left_out_s(), 0, "at the limit");
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 3.0, second(0.0));
    feed(&mut cal, &mut t, 1.0, second(1.001));
    let left = cal.take_left_out();
    assert!(
        left.is_some_and(|l| (l.motion.rate_rps - 0.05005).abs() < 1e-12),
        "{left:?}"
    );
}

#[test]
fn a_turns_edge_leaves_the_average_whole() {
    // A second leaning 1 deg (under the tilt limit: kept), then a turn: the leaning second
    // is the turn's edge and leaves the average, its specific force with it.
    let (mut cal, mut t) = opened_for(10.0);
    feed(&mut cal, &mut t, 2.99, |_| moving(0.0, 0.0));
    feed(&mut cal, &mut t, 1.0, |_| moving(0.0, 0.0175));
    feed(&mut cal, &mut t, 1.0, |_| moving(0.2, 0.0));
    assert_eq!(cal.left_out_s(), 2);
    let mut done = None;
    while done.is_none() {
        done = feed(&mut cal, &mut t, 0.01, |_| moving(0.0, 0.0));
        assert!(t < 30_000_000, "never closed");
    }
    let b = done.unwrap_or_else(|| unreachable!());
    assert!(b.mean_accel_mps2.y.abs() < 1e-12, "{b:?}");
    assert!((b.gyro_rps.z - 0.02).abs() < 1e-12, "{b:?}");
}

#[test]
fn the_seconds_judged_are_counted_and_a_restart_forgets_them() {
    let (mut cal, mut t) = opened_for(60.0);
    assert_eq!(cal.seconds_judged(), 0);
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.0));
    assert_eq!(cal.seconds_judged(), 3);
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.07));
    assert!(cal.take_motion().is_some(), "tilted three seconds");
    assert_eq!(cal.seconds_judged(), 0);
}

#[test]
fn more_seconds_moved_than_still_is_judged_on_the_eleventh() {
    // One still second, then seconds swinging one way and back, every one moved.
    let (mut cal, mut t) = opened_for(60.0);
    feed(&mut cal, &mut t, 0.99, |_| moving(0.0, 0.0));
    let swing = |k: u32| {
        moving(
            if (k / 100).is_multiple_of(2) {
                0.2
            } else {
                -0.2
            },
            0.0,
        )
    };
    feed(&mut cal, &mut t, 10.0, swing);
    assert_eq!(cal.take_motion(), None, "ten moved, not beyond ten");
    assert_eq!(cal.restarts(), 0);
    feed(&mut cal, &mut t, 1.0, |k| swing(k + 1000));
    assert!(cal.take_motion().is_some(), "eleven moved");
}

#[test]
fn a_window_of_part_seconds_ends_on_a_part_second_judged_like_a_second() {
    // A 2.34 s window: two seconds and a part of 34 samples, whatever the samples' times.
    let run = |rate_z: f64| {
        let mut cal = BiasCalibration::new(0.0, 2.34);
        let mut closed_on = None;
        let mut done = None;
        for k in 0..1000u32 {
            let s = if (201..235).contains(&k) {
                moving(rate_z, 0.0)
            } else {
                moving(0.0, 0.0)
            };
            if let Some(b) = cal.push(&s) {
                done = Some(b);
                closed_on = Some(k);
                break;
            }
        }
        (done, closed_on, cal)
    };
    // The first sample is the warm-up; the window is samples 1 to 234, closed by the next.
    let (done, closed_on, _) = run(0.0);
    let b = done.unwrap_or_else(|| panic!("closed"));
    assert_eq!(b.samples, 234, "the part-second kept");
    assert_eq!(closed_on, Some(235));
    // The part-second turning: left out with the second before it, the window as many
    // samples longer, and closed on still seconds.
    let (done, closed_on, cal) = run(0.2);
    assert_eq!(
        cal.left_out_s(),
        3,
        "the edge before, the part-second, the edge after"
    );
    let b = done.unwrap_or_else(|| panic!("closed"));
    assert_eq!(b.samples, 234, "{b:?}");
    // 134 samples for the edge and the part-second, 100 for the edge after.
    assert_eq!(closed_on, Some(235 + 134 + 100));
    assert!((b.gyro_rps.z - 0.02).abs() < 1e-9, "{b:?}");
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(64))]

    /// No restart and no second left out without a gyro or accelerometer reading beyond its
    /// limit: a still helicopter with any bias, sensor noise and rotor vibration under them
    /// calibrates in one window.
    #[test]
    fn a_still_helicopter_is_never_judged_moving(
        bias in proptest::array::uniform3(-0.05f64..0.05),
        noise_rps in 0.0f64..0.02,
        vibration_mps2 in 0.0f64..2.0,
        seed in 0u64..u64::MAX,
    ) {
        let mut cal = BiasCalibration::new(1.0, 80.0);
        let mut state = seed | 1;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut done = None;
        let mut t = 0u64;
        while done.is_none() && t < 100_000_000 {
            let phase = t as f64 * 1e-6 * 27.0 * std::f64::consts::TAU;
            let s = ImuRepr {
                rate_rps: [
                    bias[0] + noise_rps * uniform(),
                    bias[1] + noise_rps * uniform(),
                    bias[2] + noise_rps * uniform(),
                ],
                accel_mps2: [
                    vibration_mps2 * phase.sin(),
                    vibration_mps2 * phase.cos(),
                    -9.81 + 0.1 * uniform(),
                ],
                temp_c: 25.0,
            };
            done = cal.push(&s);
            proptest::prop_assert_eq!(cal.take_motion(), None);
            proptest::prop_assert_eq!(cal.take_left_out(), None);
            t += 10_000;
        }
        let b = done.unwrap_or_else(|| panic!("never closed"));
        proptest::prop_assert!((b.gyro_rps.z - bias[2]).abs() < 1e-3);
    }
}

#[test]
fn the_windows_buffers_are_taken_once_and_kept_through_restarts() {
    // Room for the window's seconds and those left out with them: nothing is allocated
    // while it is judged, in this window or the next (the flight computer's no-alloc test
    // counts it).
    let (mut cal, mut t) = opened_for(80.0);
    let room = |cal: &BiasCalibration| (cal.window.seconds.capacity(), cal.window.axis.capacity());
    let (seconds, axis) = room(&cal);
    assert!(seconds >= 320 && axis >= 320, "{seconds} {axis}");
    feed(&mut cal, &mut t, 5.0, |_| moving(0.0, 0.0));
    feed(&mut cal, &mut t, 3.0, |_| moving(0.0, 0.07));
    assert_eq!(cal.restarts(), 1, "started again");
    assert_eq!(cal.seconds_judged(), 0);
    assert_eq!(room(&cal), (seconds, axis), "the same buffers");
}
