//! Component tests of a stall of the devices in the air (the IMU silent long enough to
//! declare the estimate invalid, then back): what is flown during it, and the alignment in
//! the air that starts the estimate again when the IMU returns.

use super::engine_tests::{fly, hovering};
use super::tests::{fly_for, gps_fix, raised, still, uplink};
use super::*;

/// `seconds` with no device at all (the whole HILSim stopped): only the watchdog runs.
fn stall(core: &mut FlightCore, out: &mut Vec<Action>, t: &mut u64, seconds: f64) {
    let end = *t + (seconds * 1e6) as u64;
    while *t < end {
        *t += 1_000;
        if core.poll_at().is_some_and(|at| at <= *t) {
            core.handle(Input::Timer, *t, out);
        }
    }
}

/// An autonomous hold 8 m up, the pilot's switch on.
fn holding() -> (FlightCore, Vec<Action>, u64) {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    fly(&mut core, &mut out, &mut t, 1.0, uplink(true, false), 8.0);
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    out.clear();
    (core, out, t)
}

#[test]
fn a_stall_in_autonomous_flight_is_not_handed_to_a_pilot_who_is_not_flying() {
    let (mut core, mut out, mut t) = holding();
    stall(&mut core, &mut out, &mut t, 3.0);
    assert!(raised(&out, CoreEvent::EstimateInvalid));
    assert!(!core.estimate_valid());
    assert_eq!(core.phase(), Phase::BlindDescent);
    // The IMU alone silent, the board still speaking: the switch is on, the pilot left the
    // helicopter to the computer, and is not handed it unawares.
    let (mut core, mut out, t) = holding();
    fly_for(
        &mut core,
        &mut out,
        t,
        1_000_000,
        false,
        Some(uplink(true, false)),
    );
    assert!(raised(&out, CoreEvent::EstimateInvalid));
    assert_eq!(core.phase(), Phase::BlindDescent);
    // The emergency bypass: the pilot has taken the helicopter, and flies it.
    let (mut core, mut out, t) = holding();
    let bypass = PilotUplink {
        bypass: true,
        ..uplink(true, false)
    };
    fly_for(&mut core, &mut out, t, 1_000_000, false, Some(bypass));
    assert_eq!(core.phase(), Phase::Manual);
    // A flight the pilot flies through the augmentation: the switch is on, and the pilot
    // is flying.
    let (mut core, mut out, mut t) = hovering(FlightMode::Augmented(AugmentedMode::Attitude), 8.0);
    fly(&mut core, &mut out, &mut t, 1.0, uplink(true, false), 8.0);
    assert!(
        matches!(core.phase(), Phase::Augmented(_)),
        "{:?}",
        core.phase()
    );
    fly_for(
        &mut core,
        &mut out,
        t,
        1_000_000,
        false,
        Some(uplink(true, false)),
    );
    assert!(raised(&out, CoreEvent::EstimateInvalid));
    assert_eq!(core.phase(), Phase::Manual);
}

#[test]
fn devices_that_come_back_after_a_stall_start_the_estimate_again_and_the_hold_resumes() {
    let (mut core, mut out, mut t) = holding();
    let before = core.warm_start().unwrap();
    stall(&mut core, &mut out, &mut t, 3.0);
    assert!(!core.estimate_valid());
    out.clear();
    // The devices are back: an alignment in the air, as after a restart, that keeps the
    // gyro biases and the navigation frame of the flight.
    fly(&mut core, &mut out, &mut t, 0.5, uplink(true, false), 8.0);
    assert!(raised(&out, CoreEvent::ImuBackInAir));
    assert!(core.aligning());
    assert!(!core.estimate_valid(), "not used while it aligns");
    assert_eq!(core.phase(), Phase::BlindDescent);
    fly(&mut core, &mut out, &mut t, 1.5, uplink(true, false), 8.0);
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: true }));
    assert!(core.estimate_valid() && !core.aligning());
    let after = core.warm_start().unwrap();
    assert_eq!(after.origin, before.origin);
    assert_eq!(after.home_ned_m, before.home_ned_m);
    assert_eq!(after.gyro_bias_rps, before.gyro_bias_rps);
    fly(&mut core, &mut out, &mut t, 1.0, uplink(true, false), 8.0);
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    let height = core.navigator().state().map(|s| core.height_above_home(s));
    assert!(height.is_some_and(|h| (h - 8.0).abs() < 1.0), "{height:?}");
}

#[test]
fn a_pilot_who_flies_keeps_the_helicopter_through_a_stall_and_after_it() {
    let (mut core, mut out, mut t) = hovering(FlightMode::Autonomous, 8.0);
    stall(&mut core, &mut out, &mut t, 3.0);
    // The board is silent too: no pilot is heard, the blind failsafe holds on.
    assert_eq!(core.phase(), Phase::BlindDescent);
    fly(&mut core, &mut out, &mut t, 0.5, uplink(false, false), 8.0);
    assert!(core.aligning());
    assert_eq!(
        core.phase(),
        Phase::Manual,
        "the switch is off: the pilot flies"
    );
    fly(&mut core, &mut out, &mut t, 1.5, uplink(false, false), 8.0);
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: true }));
    assert_eq!(core.phase(), Phase::Manual);
}

#[test]
fn on_the_ground_a_stall_is_not_followed_by_an_alignment() {
    let mut core = super::tests::core_with(FlightMode::Autonomous);
    let (mut out, mut t) = (Vec::new(), 0);
    core.start(0);
    fly(&mut core, &mut out, &mut t, 2.0, uplink(false, false), 0.0);
    stall(&mut core, &mut out, &mut t, 1.0);
    assert!(!core.estimate_valid());
    fly(&mut core, &mut out, &mut t, 1.0, uplink(false, false), 0.0);
    assert!(!raised(&out, CoreEvent::ImuBackInAir));
    assert!(!core.aligning() && !core.estimate_valid());
}

#[test]
fn the_watchdogs_copies_of_a_sample_never_count_as_calibration_samples() {
    let mut core = FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 0.5,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    );
    let mut out = Vec::new();
    core.start(0);
    // The warm-up's 10 samples and the window's 50: the next real sample closes it.
    let mut t = 0;
    while t < 600_000 {
        t += 10_000;
        core.handle(Input::Imu(super::tests::still()), t, &mut out);
    }
    // A short silence at the window's end: the loop runs on copies, the calibration waits
    // for a real sample.
    let copies = core.stats().watchdog_fires;
    stall(&mut core, &mut out, &mut t, 0.1);
    assert!(core.stats().watchdog_fires > copies + 5);
    let done = |out: &[Action]| {
        out.iter().any(|a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::CalibrationDone { .. })))
    };
    assert!(!done(&out), "the calibration ended on copies");
    assert!(core.navigator().state().is_none());
    core.handle(Input::Imu(super::tests::still()), t + 1_000, &mut out);
    assert!(done(&out));
}

/// The calibration's events and the sample that closed it, for IMU samples with noise
/// arriving at `arrival_us(k)`.
fn calibrated(arrival_us: impl Fn(u64) -> u64) -> (Vec<CoreEvent>, Option<u64>) {
    let mut core = FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.5,
            calibration_s: 3.0,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    );
    let mut out = Vec::new();
    core.start(0);
    // Noise as an IMU has it: ±0.4 m/s², ±0.01 rad/s, one sample's worth enough to tip
    // gravity's direction by two degrees on its own.
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % 2001) as f64 / 1000.0 - 1.0
    };
    let mut events = Vec::new();
    for k in 0..400u64 {
        let sample = ImuRepr {
            rate_rps: [0.01 * noise(), 0.01 * noise(), 0.01 * noise()],
            accel_mps2: [0.4 * noise(), 0.4 * noise(), -9.81 + 0.4 * noise()],
            temp_c: 25.0,
        };
        out.clear();
        core.handle(Input::Imu(sample), arrival_us(k), &mut out);
        events.extend(out.iter().filter_map(|a| match a {
            Action::Event(e) => Some(e.value),
            _ => None,
        }));
        if events
            .iter()
            .any(|e| matches!(e, CoreEvent::CalibrationDone { .. }))
        {
            return (events, Some(k));
        }
    }
    (events, None)
}

#[test]
fn the_same_samples_arriving_with_jitter_calibrate_the_same_on_the_same_sample() {
    // On time, then each up to 4 ms early or late (under the 12 ms watchdog): a replay of a
    // recorded flight on another machine. A window timed by the clock closed one sample
    // earlier or later, or on a part-second of a sample whose noise looked like a tilt.
    let on_time = calibrated(|k| k * 10_000);
    assert!(on_time.1.is_some(), "never closed");
    for seed in 1..20u64 {
        let jittered = calibrated(|k| {
            let j = (k.wrapping_mul(seed).wrapping_mul(2_654_435_761) >> 7) % 8_001;
            (k * 10_000 + 4_000).saturating_sub(j)
        });
        assert_eq!(jittered, on_time, "jitter {seed}");
    }
}

/// The hold of [`holding`] turned into the first roll of a roll leg, `angle_rad` round.
fn rolling_at(angle_rad: f64) -> (FlightCore, Vec<Action>, u64) {
    let (mut core, out, t) = holding();
    core.seq.params.plan = Plan::new(&[
        Leg::Rolls {
            count: 1,
            speed_mps: 5.0,
        },
        Leg::Hold { seconds: 5.0 },
    ])
    .unwrap_or_else(|e| panic!("{e}"));
    core.seq.leg = 0;
    let target = core
        .seq
        .phase
        .target()
        .unwrap_or_else(|| Target::hold(Vector3::zeros(), 0.0));
    core.seq.phase = Phase::Maneuver {
        target,
        stage: RollStage::Rolling {
            angle_rad,
            since_us: t,
        },
        rolls_done: 0,
    };
    (core, out, t)
}

#[test]
fn in_a_roll_the_estimate_is_given_up_at_the_fifth_missed_sample_not_the_twenty_fifth() {
    let (mut core, mut out, mut t) = rolling_at(2.0);
    // Four watchdog periods: a packet or two lost, nothing more.
    stall(&mut core, &mut out, &mut t, 0.059);
    assert!(!raised(&out, CoreEvent::EstimateInvalid));
    // Five (60 ms) and a little.
    stall(&mut core, &mut out, &mut t, 0.003);
    assert!(raised(&out, CoreEvent::EstimateInvalid));
    assert!(!core.estimate_valid());
    // In the hold the same silence is only late.
    let (mut core, mut out, mut t) = holding();
    stall(&mut core, &mut out, &mut t, 0.062);
    assert!(!raised(&out, CoreEvent::EstimateInvalid));
    assert!(core.estimate_valid());
}

#[test]
fn a_roll_blinded_past_a_quarter_turn_is_finished_and_only_then_aligned() {
    let (mut core, mut out, mut t) = rolling_at(3.0);
    // Blind for 0.3 s: still rolling, on the feedforward alone, full lateral cyclic.
    stall(&mut core, &mut out, &mut t, 0.3);
    let Phase::Maneuver {
        stage: RollStage::Rolling { angle_rad, .. },
        ..
    } = core.phase()
    else {
        panic!("still rolling: {:?}", core.phase());
    };
    assert!(
        angle_rad > 3.5,
        "went on at the commanded rate: {angle_rad}"
    );
    let g = core.config.roll;
    let last = out.iter().rev().find_map(|a| match a {
        Action::Servo(s) => Some(s.value),
        _ => None,
    });
    let expected =
        heli_control::rolling_controls(&Vector3::new(g.rate_cmd_rps, 0.0, 0.0), angle_rad, &g);
    assert_eq!(last, Some(expected));
    // The IMU back mid-roll: no alignment yet (a rolling helicopter's accelerometers say
    // nothing of which way is up); the roll goes on, on the gyros.
    out.clear();
    fly(&mut core, &mut out, &mut t, 0.2, uplink(true, false), 8.0);
    assert!(!core.aligning(), "{:?}", core.phase());
    assert!(!raised(&out, CoreEvent::ImuBackInAir));
    // The helicopter in `fly` does not turn, so the gyros say the roll stands still: the
    // roll is given up at twice its nominal time and the cyclic levelled; then it aligns.
    fly(&mut core, &mut out, &mut t, 6.0, uplink(true, false), 8.0);
    assert!(raised(&out, CoreEvent::RollEndedBlind { finished: true }));
    assert!(raised(&out, CoreEvent::ImuBackInAir));
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: true }));
}

#[test]
fn a_roll_blinded_before_a_quarter_turn_is_stopped_at_once() {
    let (mut core, mut out, mut t) = rolling_at(1.0);
    stall(&mut core, &mut out, &mut t, 0.08);
    assert!(raised(&out, CoreEvent::RollEndedBlind { finished: false }));
    assert_eq!(core.phase(), Phase::BlindDescent);
    let last = out.iter().rev().find_map(|a| match a {
        Action::Servo(s) => Some(s.value),
        _ => None,
    });
    assert!(
        last.is_some_and(|c| c.aileron == 0.0 && c.elevator == 0.0),
        "{last:?}"
    );
}

#[test]
fn the_estimate_started_again_by_an_alignment_in_the_air_keeps_the_invariants() {
    let (mut core, mut out, mut t) = holding();
    stall(&mut core, &mut out, &mut t, 1.0);
    assert!(!core.estimate_valid());
    let mut checker = crate::invariants::Invariants::new(&core, core.config.watchdog_us);
    let mut aligned = false;
    let end = t + 3_000_000;
    while t < end && !aligned {
        t += 10_000;
        let mut inputs = vec![Input::Imu(still())];
        if t.is_multiple_of(200_000) {
            inputs.push(Input::Gps(GpsNav {
                alt_m: gps_fix(8).alt_m + 8.0,
                ..gps_fix(8)
            }));
        }
        for input in inputs {
            let mut actions = Vec::new();
            core.handle(input, t, &mut actions);
            aligned |= raised(&actions, CoreEvent::AlignedInAir { gps: true });
            assert_eq!(checker.check(&core, t, &actions), Ok(()), "t = {t}");
        }
    }
    assert!(aligned && core.estimate_valid());
}

#[test]
fn after_a_stall_only_a_fix_that_came_while_aligning_places_the_helicopter() {
    let (mut core, mut out, mut t) = holding();
    stall(&mut core, &mut out, &mut t, 1.0);
    out.clear();
    // The IMU back, no fix since the one from before the stall: past the accelerometers'
    // second it still waits for a fix.
    let imu_only = |core: &mut FlightCore, out: &mut Vec<Action>, t: &mut u64, seconds: f64| {
        let end = *t + (seconds * 1e6) as u64;
        while *t < end {
            *t += 10_000;
            core.handle(Input::Imu(still()), *t, out);
        }
    };
    imu_only(&mut core, &mut out, &mut t, 1.5);
    assert!(core.aligning(), "aligned on the fix from before the stall");
    // A fix now: aligned on it at the next sample.
    core.handle(
        Input::Gps(GpsNav {
            alt_m: gps_fix(8).alt_m + 8.0,
            ..gps_fix(8)
        }),
        t,
        &mut out,
    );
    imu_only(&mut core, &mut out, &mut t, 0.02);
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: true }));
}

#[test]
fn a_roll_finished_blind_counts_the_gyro_less_its_bias() {
    // A process started again in the air with a large roll-gyro bias, aligned, then blinded
    // in a roll: when the IMU speaks again the roll goes on at the gyro's rate less that bias.
    let bias_x = 0.3;
    let warm = WarmStart {
        gyro_bias_rps: [bias_x, 0.0, 0.0],
        origin: None,
        home_ned_m: Some([0.0, 0.0, 0.0]),
        airborne: true,
        trim: None,
        references: heli_nav::GroundReferences::default(),
        roll: None,
    };
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm);
    let mut out = Vec::new();
    let biased = |p: f64| ImuRepr {
        rate_rps: [p + bias_x, 0.0, 0.0],
        ..still()
    };
    let mut t = 0;
    core.start(0);
    core.handle(Input::Gps(gps_fix(8)), 0, &mut out);
    while core.aligning() && t < 5_000_000 {
        t += 10_000;
        core.handle(Input::Imu(biased(0.0)), t, &mut out);
    }
    assert!(core.estimate_valid(), "aligned");
    let (mut core, mut out, mut t) = {
        let target = Target::hold(Vector3::zeros(), 0.0);
        core.seq.params.plan = Plan::new(&[Leg::Rolls {
            count: 1,
            speed_mps: 5.0,
        }])
        .unwrap_or_else(|e| panic!("{e}"));
        core.seq.phase = Phase::Maneuver {
            target,
            stage: RollStage::Rolling {
                angle_rad: 3.0,
                since_us: t,
            },
            rolls_done: 0,
        };
        (core, out, t)
    };
    stall(&mut core, &mut out, &mut t, 0.1);
    assert!(!core.estimate_valid());
    let angle = |core: &FlightCore| match core.phase() {
        Phase::Maneuver {
            stage: RollStage::Rolling { angle_rad, .. },
            ..
        } => angle_rad,
        other => panic!("{other:?}"),
    };
    // Real samples turning at 1 rad/s: the first control step after the stall spans the
    // gap; the next is 20 ms.
    for _ in 0..2 {
        t += 10_000;
        core.handle(Input::Imu(biased(1.0)), t, &mut out);
    }
    let before = angle(&core);
    for _ in 0..2 {
        t += 10_000;
        core.handle(Input::Imu(biased(1.0)), t, &mut out);
    }
    let turned = angle(&core) - before;
    assert!((turned - 1.0 * 0.02).abs() < 1e-9, "{turned} rad in a step");
}
