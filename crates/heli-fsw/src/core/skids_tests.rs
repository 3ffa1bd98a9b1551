//! Standing on the skids: when the flight core tells the estimator the helicopter is not
//! moving (zero-velocity updates), and when it must not.

use super::step::ROTOR_IDLE_FRACTION;
use super::tests::{core_with, uplink};
use super::*;
use heli_control::Target;
use heli_types::AugmentedMode;

fn target() -> Target {
    Target::hold(nalgebra::Vector3::zeros(), 0.0)
}

#[test]
fn the_helicopter_stands_in_the_ground_phases_before_its_first_lift_off_and_once_landed() {
    let mut core = core_with(FlightMode::Autonomous);
    let cases = [
        (Phase::Calibrating, false),
        (Phase::PreflightCheck { since_us: 0 }, true),
        (Phase::TakeoffRefused, true),
        (Phase::GroundFailsafe, true),
        (Phase::Landed, true),
        (Phase::TakingOff { target: target() }, false),
        (
            Phase::Holding {
                target: target(),
                since_us: 0,
            },
            false,
        ),
        (Phase::BlindDescent, false),
    ];
    for (phase, stands) in cases {
        core.seq.phase = phase;
        core.seq.airborne_once = false;
        assert_eq!(core.on_skids(), stands, "{phase:?}");
        core.seq.airborne_once = true;
        // Landed is on the skids whatever came before; the rest have flown since.
        assert_eq!(core.on_skids(), phase == Phase::Landed, "{phase:?}, flown");
    }
}

#[test]
fn with_the_pilot_it_stands_only_while_the_rotor_cannot_lift_it() {
    let mut core = core_with(FlightMode::Manual);
    let mut out = Vec::new();
    let governed = core.config.engine.governed_rpm;
    for phase in [Phase::Manual, Phase::Augmented(AugmentedMode::Velocity)] {
        core.seq.phase = phase;
        core.seq.airborne_once = false;
        let mut pilot = uplink(false, false);
        // No rotor speed known (no uplink yet): not judged standing.
        assert!(!core.on_skids(), "{phase:?} without a rotor speed");
        for (rpm, stands) in [
            (0.0, true),
            (governed * ROTOR_IDLE_FRACTION - 1.0, true),
            (governed * ROTOR_IDLE_FRACTION, false),
            (governed, false),
        ] {
            pilot.rotor_rpm = rpm as u16;
            core.handle(Input::Uplink(pilot), 0, &mut out);
            assert_eq!(core.on_skids(), stands, "{phase:?} at {rpm} rpm");
        }
        core.seq.airborne_once = true;
        pilot.rotor_rpm = 0;
        core.handle(Input::Uplink(pilot), 0, &mut out);
        assert!(!core.on_skids(), "{phase:?}: flown already");
        core = core_with(FlightMode::Manual);
    }
}

#[test]
fn standing_the_estimator_is_told_so_ten_times_a_second() {
    // Calibrated at 1.1 s; no GPS: the pre-flight check waits on the skids.
    let mut core = core_with(FlightMode::Autonomous);
    let mut out = Vec::new();
    core.handle(Input::Uplink(uplink(true, false)), 0, &mut out);
    for k in 0..300u64 {
        core.handle(Input::Imu(super::tests::still()), k * 10_000, &mut out);
    }
    assert!(core.on_skids(), "{:?}", core.phase());
    let before = core.navigator().stats().still_fused;
    assert!(before > 0);
    for k in 300..400u64 {
        core.handle(Input::Imu(super::tests::still()), k * 10_000, &mut out);
    }
    assert_eq!(
        core.navigator().stats().still_fused - before,
        10,
        "a second at 10 Hz"
    );
    // In the air, never.
    core.seq.phase = Phase::Holding {
        target: target(),
        since_us: 0,
    };
    core.seq.airborne_once = true;
    let flying = core.navigator().stats().still_fused;
    for k in 400..500u64 {
        core.handle(Input::Imu(super::tests::still()), k * 10_000, &mut out);
    }
    assert_eq!(core.navigator().stats().still_fused, flying);
}
