use super::*;

pub(super) fn still() -> ImuRepr {
    ImuRepr {
        rate_rps: [0.001, 0.0, -0.002],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
}

/// A core with a short calibration, flying `mode` with a 10 m hover plan.
pub(super) fn core_with(mode: FlightMode) -> FlightCore {
    FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 1.0,
            ..CoreConfig::default()
        },
        FlightParams {
            mode,
            plan: Plan::hover(10.0, 60.0),
        },
    )
}

fn short_core() -> FlightCore {
    FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 1.0,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    )
}

#[test]
fn every_other_imu_sample_is_a_control_step_with_a_servo_command() {
    let mut core = short_core();
    let mut out = Vec::new();
    for k in 0..10u64 {
        core.handle(Input::Imu(still()), k * 10_000, &mut out);
    }
    let servos = out.iter().filter(|a| matches!(a, Action::Servo(_))).count();
    assert_eq!(servos, 5);
    assert_eq!(core.stats().control_steps, 5);
    assert_eq!(core.stats().imu_samples, 10);
}

#[test]
fn watchdog_repeats_the_last_sample_after_12_ms_and_counts_it() {
    let mut core = short_core();
    let mut out = Vec::new();
    core.handle(Input::Imu(still()), 0, &mut out);
    assert_eq!(core.poll_at(), Some(12_000));
    core.handle(Input::Timer, 11_000, &mut out);
    assert_eq!(core.stats().watchdog_fires, 0, "not yet due");
    out.clear();
    core.handle(Input::Timer, 12_000, &mut out);
    assert_eq!(core.stats().watchdog_fires, 1);
    let repeated: Vec<_> = out
        .iter()
        .filter_map(|a| match a {
            Action::Publish(Record::Imu(r)) => Some(r),
            _ => None,
        })
        .collect();
    assert_eq!(repeated.len(), 1);
    assert!(repeated[0].value.repeated);
    assert_eq!(repeated[0].value.imu, still());
    assert_eq!(repeated[0].t_us, 12_000);
    assert_eq!(core.poll_at(), Some(24_000));
}

#[test]
fn calibration_then_auto_switch_starts_a_takeoff() {
    let mut core = core_with(FlightMode::Autonomous);
    let mut out = Vec::new();
    let pilot = PilotUplink {
        rotor_rpm: 1600,
        pulses: heli_proto::scb::Pulses::from_controls(&Controls {
            throttle: 0.8,
            ..Default::default()
        }),
        auto_mode: true,
        bypass: false,
        receiver_batt_v: 5.1,
        servo_batt_v: 5.1,
    };
    core.handle(Input::Uplink(pilot), 0, &mut out);
    // Calibrated at 1.1 s; it waits on the skids for its first fused GPS fix, then goes.
    for k in 0..300u64 {
        core.handle(Input::Imu(still()), k * 10_000, &mut out);
        if k % 50 == 0 {
            core.handle(Input::Gps(gps_fix(8)), k * 10_000, &mut out);
        }
    }
    match core.phase() {
        Phase::TakingOff { target } => assert!((target.pos_ned_m.z + 10.0).abs() < 1e-6),
        other => panic!("expected take-off, got {other:?}"),
    }
    assert!(out.iter().any(
        |a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::CalibrationDone { .. }))
    ));
}

pub(super) fn uplink(auto_mode: bool, lost: bool) -> PilotUplink {
    let sticks = Controls {
        collective: 0.0,
        throttle: 0.8,
        ..Default::default()
    };
    PilotUplink {
        rotor_rpm: 1600,
        pulses: if lost {
            heli_proto::scb::Pulses::default()
        } else {
            heli_proto::scb::Pulses::from_controls(&sticks)
        },
        auto_mode,
        bypass: false,
        receiver_batt_v: 5.1,
        servo_batt_v: 5.1,
    }
}

/// The pilot packet 10 ms after `t`, then four IMU samples 10 ms apart (two control
/// steps); returns the time of the last.
fn pilot_then_imu(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    mut t: u64,
    pilot: PilotUplink,
) -> u64 {
    t += 10_000;
    core.handle(Input::Uplink(pilot), t, out);
    for _ in 0..4 {
        t += 10_000;
        core.handle(Input::Imu(still()), t, out);
    }
    t
}

/// A calibrated core in manual mode; with `height_m` > 0 the altimeter has told it it is
/// that high (the IMU says it is still, as in a steady hover).
fn calibrated_manual_core(height_m: f64) -> (FlightCore, Vec<Action>, u64) {
    let mut core = short_core();
    let mut out = Vec::new();
    core.handle(Input::Uplink(uplink(false, false)), 0, &mut out);
    let mut t = 0u64;
    let p0 = 1013.25;
    for k in 0..4000u64 {
        t = k * 10_000;
        core.handle(Input::Imu(still()), t, &mut out);
        if k % 20 == 0 {
            let calibrated = core.navigator().state().is_some();
            let alt = if calibrated && k > 200 { height_m } else { 0.0 };
            let pressure_mbar = heli_proto::baro::pressure_at_altitude_mbar(alt, p0);
            core.handle(Input::Baro { pressure_mbar }, t, &mut out);
        }
    }
    (core, out, t)
}

fn last_servo(out: &[Action]) -> Controls {
    out.iter()
        .rev()
        .find_map(|a| match a {
            Action::Servo(s) => Some(s.value),
            _ => None,
        })
        .unwrap_or_default()
}

#[test]
fn transmitter_lost_on_the_ground_idles_instead_of_taking_off() {
    let (mut core, mut out, mut t) = calibrated_manual_core(0.0);
    assert_eq!(core.phase(), Phase::Manual);
    t = pilot_then_imu(&mut core, &mut out, t, uplink(false, true));
    assert_eq!(core.phase(), Phase::GroundFailsafe);
    let servo = last_servo(&out);
    assert_eq!(servo.collective, 0.0);
    assert_eq!(servo.throttle, 0.0);
    assert!(
        out.iter()
            .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::PilotSignalLost))
    );
    // The signal comes back: the pilot has the helicopter again.
    pilot_then_imu(&mut core, &mut out, t, uplink(false, false));
    assert_eq!(core.phase(), Phase::Manual);
}

#[test]
fn transmitter_lost_in_the_air_is_a_command_to_hover_where_it_is() {
    let (mut core, mut out, t) = calibrated_manual_core(8.0);
    let z = core.navigator().state().map_or(0.0, |s| s.pos_ned_m.z);
    assert!(
        z < -5.0,
        "the altimeter should have lifted the estimate: z = {z}"
    );
    assert_eq!(core.phase(), Phase::Manual);
    pilot_then_imu(&mut core, &mut out, t, uplink(false, true));
    match core.phase() {
        Phase::Holding { target, .. } => assert!((target.pos_ned_m.z - z).abs() < 0.5),
        other => panic!("expected a hover hold, got {other:?}"),
    }
    let servo = last_servo(&out);
    assert!(servo.collective > 0.3 && servo.throttle > 0.7, "{servo:?}");
}

#[test]
fn watchdog_armed_at_start_notices_an_imu_that_never_speaks() {
    let mut core = short_core();
    let mut out = Vec::new();
    core.start(0);
    assert_eq!(core.poll_at(), Some(12_000));
    core.handle(Input::Timer, 12_000, &mut out);
    assert_eq!(core.stats().watchdog_fires, 1);
    assert_eq!(core.stats().control_steps, 0, "nothing to repeat yet");
    assert!(
        out.iter()
            .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::WatchdogFired))
    );
}

#[test]
fn inputs_from_the_past_or_not_finite_are_refused_and_counted() {
    let mut core = short_core();
    let mut out = Vec::new();
    core.handle(Input::Imu(still()), 50_000, &mut out);
    out.clear();
    core.handle(Input::Imu(still()), 40_000, &mut out);
    let mut nan = still();
    nan.rate_rps[1] = f64::NAN;
    core.handle(Input::Imu(nan), 60_000, &mut out);
    core.handle(
        Input::Baro {
            pressure_mbar: f64::INFINITY,
        },
        60_000,
        &mut out,
    );
    assert_eq!(core.stats().rejected_inputs, 3);
    assert_eq!(core.stats().imu_samples, 1);
    assert!(out.is_empty(), "a refused input changes nothing");
}

#[test]
fn emergency_bypass_hands_the_pilot_the_helicopter_with_yaw_damping() {
    let mut core = core_with(FlightMode::Autonomous);
    let mut out = Vec::new();
    let mut bypassed = uplink(true, false);
    bypassed.bypass = true;
    core.handle(Input::Uplink(bypassed), 0, &mut out);
    let spinning = ImuRepr {
        rate_rps: [0.0, 0.0, 0.5],
        ..still()
    };
    for k in 0..200u64 {
        let sample = if k < 150 { still() } else { spinning };
        core.handle(Input::Imu(sample), k * 10_000, &mut out);
    }
    assert_eq!(core.phase(), Phase::Manual, "auto switch on, but bypassed");
    let rudder = last_servo(&out).rudder;
    let damper = YawDamper::default();
    assert!(
        rudder < damper.trim,
        "yaw damping opposes the turn: {rudder}"
    );
}

#[test]
fn augmented_mode_follows_the_auto_switch() {
    let (mut core, mut out) = core_with_gps(FlightMode::Augmented(AugmentedMode::Rate), Some(8), 2);
    assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
    core.handle(Input::Uplink(uplink(false, false)), 2_000_000, &mut out);
    core.handle(Input::Imu(still()), 2_000_000, &mut out);
    core.handle(Input::Imu(still()), 2_010_000, &mut out);
    assert_eq!(core.phase(), Phase::Manual);
}

/// Feeds the core for `duration_us` after `t`: IMU samples every 10 ms when `imu`, pilot
/// packets every 20 ms when `pilot` is given, and the timer whenever it is due. Returns the
/// time reached.
pub(super) fn fly_for(
    core: &mut FlightCore,
    out: &mut Vec<Action>,
    t: u64,
    duration_us: u64,
    imu: bool,
    pilot: Option<PilotUplink>,
) -> u64 {
    let end = t + duration_us;
    let mut now = t;
    while now < end {
        now += 1_000;
        if let Some(at) = core.poll_at()
            && at <= now
        {
            core.handle(Input::Timer, now, out);
        }
        if imu && now.is_multiple_of(10_000) {
            core.handle(Input::Imu(still()), now, out);
        }
        if let Some(p) = pilot
            && now.is_multiple_of(20_000)
        {
            core.handle(Input::Uplink(p), now, out);
        }
    }
    now
}

pub(super) fn raised(out: &[Action], event: CoreEvent) -> bool {
    out.iter()
        .any(|a| matches!(a, Action::Event(e) if e.value == event))
}

#[test]
fn a_silent_uplink_in_the_air_is_transmitter_loss() {
    let (mut core, mut out, t) = settled(8.0, uplink(false, false));
    assert_eq!(core.phase(), Phase::Manual);
    out.clear();
    // The board's line goes quiet: late after 60 ms, silent after 500 ms.
    let t = fly_for(&mut core, &mut out, t, 100_000, true, None);
    assert!(raised(
        &out,
        CoreEvent::DeviceHealth {
            device: Device::Uplink,
            state: HealthState::Late
        }
    ));
    assert_eq!(core.phase(), Phase::Manual, "late is not lost");
    assert!(!raised(&out, CoreEvent::UplinkLost), "late is not lost");
    fly_for(&mut core, &mut out, t, 500_000, true, None);
    assert!(raised(&out, CoreEvent::UplinkLost));
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    assert_eq!(core.health().state(Device::Uplink), HealthState::Silent);
    assert_eq!(
        CoreEvent::UplinkLost.severity(),
        Severity::WarningHi,
        "transmitter loss changes what the software does"
    );
}

#[test]
fn a_silent_uplink_on_the_ground_idles() {
    let (mut core, mut out, t) = settled(0.0, uplink(false, false));
    fly_for(&mut core, &mut out, t, 700_000, true, None);
    assert_eq!(core.phase(), Phase::GroundFailsafe);
    assert_eq!(last_servo(&out).throttle, 0.0);
}

#[test]
fn imu_silence_invalidates_the_estimate_and_hands_the_pilot_the_helicopter() {
    let (mut core, mut out, t) = settled(8.0, uplink(false, false));
    out.clear();
    // 0.2 s without the IMU: repeated samples, but the estimate still stands.
    let t = fly_for(
        &mut core,
        &mut out,
        t,
        200_000,
        false,
        Some(uplink(false, false)),
    );
    assert!(core.estimate_valid());
    assert!(!raised(&out, CoreEvent::EstimateInvalid));
    fly_for(
        &mut core,
        &mut out,
        t,
        200_000,
        false,
        Some(uplink(false, false)),
    );
    assert!(raised(&out, CoreEvent::EstimateInvalid));
    assert!(!core.estimate_valid());
    assert_eq!(CoreEvent::EstimateInvalid.severity(), Severity::Fatal);
    assert!(raised(
        &out,
        CoreEvent::DeviceHealth {
            device: Device::Imu,
            state: HealthState::Silent
        }
    ));
    assert_eq!(core.phase(), Phase::Manual);
    // The pilot's sticks pass through; the tail gets no damping from a stale yaw rate.
    let servo = last_servo(&out);
    assert_eq!(servo.collective, 0.0);
    assert!(
        (servo.rudder - YawDamper::default().trim).abs() < 1e-9,
        "{servo:?}"
    );
}

#[test]
fn imu_silence_without_a_pilot_is_the_blind_descent() {
    let (mut core, mut out, t) = settled(8.0, uplink(false, true));
    assert!(matches!(core.phase(), Phase::Holding { .. }));
    fly_for(
        &mut core,
        &mut out,
        t,
        500_000,
        false,
        Some(uplink(false, true)),
    );
    assert_eq!(core.phase(), Phase::BlindDescent);
    let servo = last_servo(&out);
    let hover = HoverGains::default().hover_collective;
    assert!((servo.collective - (hover - BLIND_DESCENT_COLLECTIVE_MARGIN)).abs() < 1e-9);
    assert_eq!((servo.aileron, servo.elevator), (0.0, 0.0));
}

#[test]
fn every_device_that_never_speaks_is_reported_silent() {
    let mut core = short_core();
    let mut out = Vec::new();
    core.start(0);
    fly_for(
        &mut core,
        &mut out,
        0,
        3_500_000,
        true,
        Some(uplink(false, false)),
    );
    for device in [Device::Gps, Device::Baro, Device::Compass] {
        assert_eq!(
            core.health().state(device),
            HealthState::Silent,
            "{device:?}"
        );
        assert!(raised(
            &out,
            CoreEvent::DeviceHealth {
                device,
                state: HealthState::Silent
            }
        ));
    }
    assert_eq!(core.health().state(Device::Imu), HealthState::Ok);
    assert_eq!(core.health().state(Device::Uplink), HealthState::Ok);
}

#[test]
fn an_imu_that_has_not_spoken_yet_invalidates_nothing() {
    let mut core = short_core();
    let mut out = Vec::new();
    core.start(0);
    // A second without the IMU (a port still opening): watchdog fires, nothing to repeat.
    fly_for(
        &mut core,
        &mut out,
        0,
        1_000_000,
        false,
        Some(uplink(false, false)),
    );
    assert!(core.stats().watchdog_fires > 50);
    assert!(core.estimate_valid());
    assert!(!raised(&out, CoreEvent::EstimateInvalid));
}

#[test]
fn an_estimate_lost_on_the_ground_without_a_pilot_idles() {
    let (mut core, mut out, t) = settled(0.0, uplink(false, true));
    fly_for(
        &mut core,
        &mut out,
        t,
        500_000,
        false,
        Some(uplink(false, true)),
    );
    assert!(!core.estimate_valid());
    assert_eq!(
        core.phase(),
        Phase::GroundFailsafe,
        "no blind descent from the skids"
    );
    assert_eq!(last_servo(&out).throttle, 0.0);
}

#[test]
fn a_device_that_comes_back_is_raised_as_back() {
    let (mut core, mut out, t) = calibrated_manual_core(8.0);
    let t = fly_for(&mut core, &mut out, t, 700_000, true, None);
    assert!(raised(&out, CoreEvent::UplinkLost));
    out.clear();
    fly_for(
        &mut core,
        &mut out,
        t,
        100_000,
        true,
        Some(uplink(false, false)),
    );
    assert!(raised(
        &out,
        CoreEvent::DeviceHealth {
            device: Device::Uplink,
            state: HealthState::Ok
        }
    ));
    assert_eq!(core.phase(), Phase::Manual, "the pilot has it again");
}

pub(super) fn gps_fix(satellites: u8) -> heli_proto::gps::GpsNav {
    heli_proto::gps::GpsNav {
        tow_ms: 0,
        lat_deg: 42.3581,
        lon_deg: -71.0966,
        alt_m: 5.0,
        vel_ned_mps: [0.0; 3],
        satellites,
        fix: heli_proto::gps::FixType::Fix3D,
    }
}

/// A short-calibration autonomous core with the auto switch on, fed IMU and (if
/// `satellites` is given) GPS fixes at 2 Hz for `seconds`.
fn auto_core_with_gps(satellites: Option<u8>, seconds: u64) -> (FlightCore, Vec<Action>) {
    core_with_gps(FlightMode::Autonomous, satellites, seconds)
}

/// A short-calibration core flying `mode` with the auto switch on, fed IMU, the pilot's
/// packets and (if `satellites` is given) GPS fixes at 2 Hz for `seconds`.
pub(super) fn core_with_gps(
    mode: FlightMode,
    satellites: Option<u8>,
    seconds: u64,
) -> (FlightCore, Vec<Action>) {
    let mut core = core_with(mode);
    let mut out = Vec::new();
    core.start(0);
    let mut now = 0;
    while now < seconds * 1_000_000 {
        now = fly_for(
            &mut core,
            &mut out,
            now,
            500_000,
            true,
            Some(uplink(true, false)),
        );
        if let Some(n) = satellites {
            core.handle(Input::Gps(gps_fix(n)), now, &mut out);
        }
    }
    (core, out)
}

#[test]
fn no_autonomous_take_off_without_a_gps_fix_or_with_too_few_satellites() {
    // Waiting for the checks at first, on the skids.
    let (core, out) = auto_core_with_gps(None, 3);
    assert!(
        matches!(core.phase(), Phase::PreflightCheck { .. }),
        "{:?}",
        core.phase()
    );
    assert!(!raised(&out, CoreEvent::TakeoffRefused(Refusal::NoGpsFix)));
    // Refused once the wait is over.
    let (core, out) = auto_core_with_gps(None, 33);
    assert_eq!(core.phase(), Phase::TakeoffRefused);
    assert!(raised(&out, CoreEvent::TakeoffRefused(Refusal::NoGpsFix)));
    assert_eq!(
        last_servo(&out).collective,
        -0.1,
        "on the skids, rotor governed"
    );

    let (core, out) = auto_core_with_gps(Some(4), 33);
    assert_eq!(core.phase(), Phase::TakeoffRefused);
    assert!(raised(
        &out,
        CoreEvent::TakeoffRefused(Refusal::TooFewSatellites(4))
    ));

    let (core, _) = auto_core_with_gps(Some(8), 3);
    assert!(
        matches!(core.phase(), Phase::TakingOff { .. }),
        "{:?}",
        core.phase()
    );
}

#[test]
fn a_refused_take_off_waits_for_the_switch_to_be_cycled() {
    let (mut core, mut out) = auto_core_with_gps(None, 33);
    assert_eq!(core.phase(), Phase::TakeoffRefused);
    // The GPS comes: still refused while the switch stays on (no surprise take-off).
    let mut now = 33_000_000;
    for _ in 0..4 {
        now = fly_for(
            &mut core,
            &mut out,
            now,
            500_000,
            true,
            Some(uplink(true, false)),
        );
        core.handle(Input::Gps(gps_fix(8)), now, &mut out);
    }
    assert_eq!(core.phase(), Phase::TakeoffRefused);
    // Off, then on again: the checks pass and it goes.
    now = fly_for(
        &mut core,
        &mut out,
        now,
        200_000,
        true,
        Some(uplink(false, false)),
    );
    core.handle(Input::Gps(gps_fix(8)), now, &mut out);
    fly_for(
        &mut core,
        &mut out,
        now,
        200_000,
        true,
        Some(uplink(true, false)),
    );
    assert!(
        matches!(core.phase(), Phase::TakingOff { .. }),
        "{:?}",
        core.phase()
    );
}

#[test]
fn a_gps_fix_that_jumps_is_refused_before_the_filter() {
    let (mut core, mut out) = auto_core_with_gps(Some(8), 4);
    let fused = core.navigator().stats().gps_fused;
    assert!(fused > 0);
    let mut glitch = gps_fix(8);
    glitch.lat_deg += 1_000.0 / 111_000.0; // a kilometre north, half a second later
    core.handle(Input::Gps(glitch), 4_500_000, &mut out);
    assert_eq!(
        core.navigator().stats().gps_fused,
        fused,
        "never reached the filter"
    );
    assert_eq!(core.stats().gps_implausible, 1);
    assert!(out.iter().any(|a| matches!(
        a,
        Action::Event(e) if matches!(e.value, CoreEvent::GpsImplausible(Implausible::Jump { .. }))
    )));
}

/// A calibrated manual core (see [`calibrated_manual_core`]) flown 0.2 s more with the IMU
/// and `pilot`'s packets, so that every watchdog is fed.
pub(super) fn settled(height_m: f64, pilot: PilotUplink) -> (FlightCore, Vec<Action>, u64) {
    let (mut core, mut out, t) = calibrated_manual_core(height_m);
    let t = fly_for(&mut core, &mut out, t, 200_000, true, Some(pilot));
    (core, out, t)
}

#[test]
fn a_process_restarted_in_the_air_aligns_on_the_trim_instead_of_calibrating() {
    let trim = Controls {
        aileron: 0.02,
        elevator: 0.01,
        rudder: 0.41,
        collective: 0.55,
        throttle: heli_control::GOVERNED_THROTTLE,
    };
    let warm = WarmStart {
        gyro_bias_rps: [0.001, 0.0, -0.002],
        origin: None,
        home_ned_m: Some([0.0, 0.0, 0.0]),
        airborne: true,
        trim: Some(trim),
        references: heli_nav::GroundReferences::default(),
        roll: None,
    };
    let mut core = FlightCore::restarted(CoreConfig::default(), FlightParams::default(), warm);
    assert!(core.aligning());
    let mut out = Vec::new();
    // One second of samples (no GPS: it waits up to three for a fix), flying the trim with
    // the tail damping the bias-free gyro: the still samples' -0.002 rad/s is all bias.
    for k in 0..100u64 {
        core.handle(Input::Imu(still()), k * 10_000, &mut out);
    }
    assert!(raised(&out, CoreEvent::RestartedInAir));
    assert_eq!(core.phase(), Phase::BlindDescent);
    let servo = last_servo(&out);
    assert!(
        (servo.collective - trim.collective).abs() < 1e-9,
        "{servo:?}"
    );
    assert!((servo.rudder - trim.rudder).abs() < 1e-9, "{servo:?}");
    assert!(core.navigator().state().is_none(), "waits for a GPS fix");
    for k in 100..301u64 {
        core.handle(Input::Imu(still()), k * 10_000, &mut out);
    }
    assert!(raised(&out, CoreEvent::AlignedInAir { gps: false }));
    assert!(!core.aligning() && core.navigator().state().is_some());
    assert_eq!(core.stats().imu_samples, 301, "no 80 s calibration");
    // A record of a helicopter that never flew gives an ordinary start.
    let grounded = FlightCore::restarted(
        CoreConfig::default(),
        FlightParams::default(),
        WarmStart {
            airborne: false,
            ..warm
        },
    );
    assert!(!grounded.aligning());
    assert_eq!(grounded.phase(), Phase::Calibrating);
    assert_eq!(
        short_core().warm_start(),
        None,
        "nothing to leave before calibrating"
    );
}

#[test]
fn a_compass_heading_moving_while_the_gyros_see_no_turn_is_said_never_a_restart() {
    // The IMU still, the compass's heading moving 1 deg/s (a magnetic disturbance, or a
    // creep too slow for the gyros): only the sensors that can see motion restart the
    // window. Past 5 deg the operator is told once, and the calibration goes on.
    let mut core = FlightCore::new(
        CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 30.0,
            ..CoreConfig::default()
        },
        FlightParams::default(),
    );
    let mut out = Vec::new();
    core.start(0);
    let compass = |heading_rad: f64| {
        heli_proto::compass::CompassAdc::from_field(&heli_proto::compass::MagField {
            field_gauss: [0.19 * heading_rad.cos(), -0.19 * heading_rad.sin(), 0.48],
        })
    };
    for k in 1..=3200u64 {
        let now = k * 10_000;
        core.handle(Input::Imu(still()), now, &mut out);
        if k % 5 == 0 {
            let turned_rad = (now as f64 * 1e-6 - 1.0).max(0.0).to_radians();
            core.handle(Input::Compass(compass(turned_rad)), now, &mut out);
        }
    }
    let events: Vec<CoreEvent> = out
        .iter()
        .filter_map(|a| match a {
            Action::Event(e) => Some(e.value),
            _ => None,
        })
        .collect();
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, CoreEvent::CalibrationRestarted(_))),
        "{events:?}"
    );
    let said: Vec<f64> = events
        .iter()
        .filter_map(|e| match e {
            CoreEvent::CalibrationCompassMoved { moved_rad } => Some(moved_rad.to_degrees()),
            _ => None,
        })
        .collect();
    assert_eq!(said.len(), 1, "{events:?}");
    assert!(said[0] > 5.0 && said[0] < 7.0, "{said:?}");
    assert!(
        events
            .iter()
            .any(|e| matches!(e, CoreEvent::CalibrationDone { .. })),
        "the window closed on time: {events:?}"
    );
}

#[test]
fn the_core_runs_with_the_configuration_it_was_given() {
    let core = core_with(FlightMode::Autonomous);
    assert_eq!(core.config().calibration_s, 1.0);
    assert_eq!(core.config().imu_warm_up_s, 0.1);
    assert_eq!(
        core.watchdog_deadline_us(),
        None,
        "armed at start, not before"
    );
}
