//! Component tests of the control dispatch (`dispatch.rs`): for each phase, the servo
//! command is the one its controller gives for the same estimate, sticks and time step.

use super::*;
use heli_control::autorotation::Autorotation;
use heli_proto::scb::Pulses;
use nalgebra::UnitQuaternion;

const DT: f64 = 0.02;

fn imu() -> ImuRepr {
    ImuRepr {
        rate_rps: [0.01, -0.02, 0.3],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
}

fn sticks() -> Controls {
    Controls {
        aileron: 0.2,
        elevator: -0.1,
        rudder: 0.1,
        collective: 0.05,
        throttle: 0.7,
    }
}

/// The pilot's sticks as the board reports them (quantised to its pulse widths).
fn pilot_sticks() -> Controls {
    Pulses::from_controls(&sticks()).to_controls()
}

/// An estimate `height_m` above home, moving and turning.
fn est(height_m: f64) -> NavState {
    NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.05, -0.03, 0.7),
        vel_ned_mps: Vector3::new(1.0, 0.5, -0.2),
        pos_ned_m: Vector3::new(3.0, -2.0, -height_m),
        rate_body_rps: Vector3::new(0.1, -0.1, -0.25),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

fn core_in(phase: Phase, mode: FlightMode) -> FlightCore {
    let mut core = FlightCore::new(
        CoreConfig::default(),
        FlightParams {
            mode,
            plan: Plan::hover(10.0, 60.0),
        },
    );
    core.seq.home_ned_m = Some(Vector3::zeros());
    core.devices.pilot = Some(PilotUplink {
        rotor_rpm: 1500,
        pulses: Pulses::from_controls(&sticks()),
        auto_mode: true,
        bypass: false,
        receiver_batt_v: 5.0,
        servo_batt_v: 5.0,
    });
    core.seq.phase = phase;
    core
}

fn target() -> Target {
    Target {
        pos_ned_m: Vector3::new(6.0, 1.0, -9.0),
        vel_ned_mps: Vector3::new(0.5, 0.0, 0.0),
        yaw_rad: 0.4,
    }
}

#[test]
fn a_roll_in_progress_flies_the_roll_law() {
    let stage = RollStage::Rolling {
        angle_rad: 2.0,
        since_us: 0,
    };
    let mut core = core_in(
        Phase::Maneuver {
            target: target(),
            stage,
            rolls_done: 0,
        },
        FlightMode::Autonomous,
    );
    let e = est(20.0);
    let u = core.phase_controls(Some(e), &imu(), DT);
    assert_eq!(
        u,
        rolling_controls(&e.rate_body_rps, 2.0, &core.config.roll)
    );
}

#[test]
fn the_autonomous_phases_fly_the_hover_controller_with_its_integrators_in_the_air() {
    let phases = [
        Phase::TakingOff { target: target() },
        Phase::Holding {
            target: target(),
            since_us: 0,
        },
        Phase::Flying {
            target: target(),
            to_ned_m: Vector3::zeros(),
        },
        Phase::Maneuver {
            target: target(),
            stage: RollStage::PullUp { since_us: 0 },
            rolls_done: 0,
        },
        Phase::Landing {
            target: target(),
            settled_since_us: None,
        },
    ];
    for phase in phases {
        for (height, airborne) in [(8.0, true), (0.3, false), (0.1, false)] {
            let mut core = core_in(phase, FlightMode::Autonomous);
            let mut hover = HoverController::new(core.config.hover);
            let e = est(height);
            let u = core.phase_controls(Some(e), &imu(), DT);
            assert_eq!(
                u,
                hover.update(&e, &target(), DT, airborne),
                "{phase:?} {height}"
            );
            // The controller's integrators moved as the direct call's did.
            assert_eq!(core.hover, hover);
        }
    }
}

#[test]
fn the_autorotation_flies_the_autorotation_law() {
    let mut core = core_in(
        Phase::Autorotation {
            settled_since_us: None,
        },
        FlightMode::Autonomous,
    );
    let e = est(30.0);
    let u = core.phase_controls(Some(e), &imu(), DT);
    let mut hover = HoverController::new(core.config.hover);
    let mut ar = Autorotation::begin(core.config.autorotation, &e, 30.0);
    assert_eq!(u, ar.update(&mut hover, &e, 30.0, 1500.0, DT));
}

#[test]
fn an_autorotation_begun_close_to_the_ground_is_a_hovering_one() {
    let mut core = core_in(
        Phase::Autorotation {
            settled_since_us: None,
        },
        FlightMode::Autonomous,
    );
    // 2 m up, sinking 3.5 m/s at walking speed: the hovering autorotation's cushion.
    let mut e = est(2.0);
    e.vel_ned_mps.z = 3.5;
    let u = core.phase_controls(Some(e), &imu(), DT);
    let law = |height_m: f64| {
        let mut hover = HoverController::new(core.config.hover);
        Autorotation::begin(core.config.autorotation, &e, height_m)
            .update(&mut hover, &e, 2.0, 1500.0, DT)
    };
    assert_eq!(u, law(2.0));
    assert_ne!(u, law(30.0));
    assert!(core.engine.autorotation.is_some_and(|a| a.hovering()));
}

#[test]
fn the_augmented_modes_fly_the_sticks_through_their_law() {
    for mode in [
        AugmentedMode::Rate,
        AugmentedMode::Attitude,
        AugmentedMode::Velocity,
    ] {
        for (height, airborne) in [(8.0, true), (0.3, false)] {
            let mut core = core_in(Phase::Augmented(mode), FlightMode::Augmented(mode));
            core.seq.has_flown = true;
            let e = est(height);
            let u = core.phase_controls(Some(e), &imu(), DT);
            let mut hover = HoverController::new(core.config.hover);
            let expected = augmented_controls(
                mode,
                &pilot_sticks(),
                &e,
                &core.config.sticks,
                &mut hover,
                DT,
                airborne,
            );
            assert_eq!(u, expected, "{mode:?} {height}");
        }
    }
}

#[test]
fn velocity_mode_idles_on_the_skids_until_the_climb_stick_lifts_it() {
    let velocity = AugmentedMode::Velocity;
    let mut core = core_in(Phase::Augmented(velocity), FlightMode::Augmented(velocity));
    let idle = Controls {
        throttle: heli_control::GOVERNED_THROTTLE,
        ..Controls::default()
    };
    assert_eq!(core.phase_controls(Some(est(0.0)), &imu(), DT), idle);
    // The climb stick above a tenth: it flies.
    let mut lifted = sticks();
    lifted.collective = 0.3;
    core.devices.pilot = core.devices.pilot.map(|p| PilotUplink {
        pulses: Pulses::from_controls(&lifted),
        ..p
    });
    assert_ne!(core.phase_controls(Some(est(0.0)), &imu(), DT), idle);
    // Once it has been more than a metre up, low down is flight, not idle.
    let mut core = core_in(Phase::Augmented(velocity), FlightMode::Augmented(velocity));
    core.phase_controls(Some(est(1.2)), &imu(), DT);
    assert!(core.seq.has_flown);
    assert_ne!(core.phase_controls(Some(est(0.0)), &imu(), DT), idle);
    for height in [0.9, 1.0] {
        let mut core = core_in(Phase::Augmented(velocity), FlightMode::Augmented(velocity));
        core.phase_controls(Some(est(height)), &imu(), DT);
        assert!(!core.seq.has_flown, "{height} m is not more than a metre");
    }
    // The rate mode never idles.
    let rate = AugmentedMode::Rate;
    let mut core = core_in(Phase::Augmented(rate), FlightMode::Augmented(rate));
    assert_ne!(core.phase_controls(Some(est(0.0)), &imu(), DT), idle);
}

#[test]
fn on_the_ground_the_rotor_is_governed_at_low_collective_or_everything_idles() {
    let governed = Controls {
        collective: -0.1,
        throttle: heli_control::GOVERNED_THROTTLE,
        ..Controls::default()
    };
    for phase in [
        Phase::Landed,
        Phase::TakeoffRefused,
        Phase::PreflightCheck { since_us: 0 },
    ] {
        let mut core = core_in(phase, FlightMode::Autonomous);
        assert_eq!(core.phase_controls(Some(est(0.0)), &imu(), DT), governed);
        assert_eq!(core.phase_controls(None, &imu(), DT), governed);
    }
    let mut core = core_in(Phase::GroundFailsafe, FlightMode::Autonomous);
    assert_eq!(
        core.phase_controls(Some(est(0.0)), &imu(), DT),
        Controls::default()
    );
}

#[test]
fn the_blind_descent_sinks_slowly_on_the_tail_trim() {
    let mut core = core_in(Phase::BlindDescent, FlightMode::Autonomous);
    let u = core.phase_controls(None, &imu(), DT);
    let g = core.config;
    assert_eq!(
        u,
        Controls {
            collective: g.hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
            rudder: g.yaw_damper.trim,
            throttle: heli_control::GOVERNED_THROTTLE,
            ..Controls::default()
        }
    );
}

#[test]
fn the_pilot_flies_with_yaw_damping_from_the_best_rate_there_is() {
    let damper = CoreConfig::default().yaw_damper;
    let mut core = core_in(Phase::Manual, FlightMode::Manual);
    // With an estimate: its bias-corrected rate.
    let u = core.phase_controls(Some(est(5.0)), &imu(), DT);
    assert_eq!(u, manual_with_yaw_damping(&pilot_sticks(), -0.25, &damper));
    // Without one yet (calibrating): the IMU's own rate.
    let u = core.phase_controls(None, &imu(), DT);
    assert_eq!(u, manual_with_yaw_damping(&pilot_sticks(), 0.3, &damper));
    // With the estimate declared invalid, the last sample is stale: no damping.
    core.main_loop.estimate_valid = false;
    let u = core.phase_controls(None, &imu(), DT);
    assert_eq!(u, manual_with_yaw_damping(&pilot_sticks(), 0.0, &damper));
    // A silent uplink's sticks count as none.
    core.devices.uplink_lost = true;
    let u = core.phase_controls(None, &imu(), DT);
    assert_eq!(
        u,
        manual_with_yaw_damping(&Controls::default(), 0.0, &damper)
    );
}

#[test]
fn only_autonomous_flight_in_the_air_goes_into_the_trim() {
    let hold = Phase::Holding {
        target: target(),
        since_us: 0,
    };
    for (phase, airborne_once, averages) in [
        (hold, true, true),
        (Phase::TakingOff { target: target() }, true, true),
        (
            Phase::Flying {
                target: target(),
                to_ned_m: Vector3::zeros(),
            },
            true,
            true,
        ),
        (hold, false, false),
        (Phase::Manual, true, false),
        (
            Phase::Landing {
                target: target(),
                settled_since_us: None,
            },
            true,
            false,
        ),
    ] {
        let mut core = core_in(phase, FlightMode::Autonomous);
        core.seq.airborne_once = airborne_once;
        assert_eq!(core.averages_trim(), averages, "{phase:?} {airborne_once}");
    }
}
