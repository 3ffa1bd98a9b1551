//! Built-in fault scenarios: each device's watchdog must raise its fault and the flight
//! software act on it as documented (docs/architecture.md, device health); the pre-flight
//! checks must refuse a take-off they cannot back; a roll interrupted by transmitter loss
//! must end upright before the hover; a flight computer that browns out in the air must
//! come back and hold.

use crate::flights::{hover, manual_sweep, rc_loss, rolls};
use crate::scenario::{Limits, Scenario};

/// `uplink-silent`: the servo board's line goes quiet while flying a path, which is
/// transmitter loss: hover within 2 s where it is.
pub fn uplink_silent() -> Scenario {
    // The transmitter-loss flight, with the board's line cut instead of the receiver's signal.
    let mut s = rc_loss();
    s.name = "uplink-silent".into();
    s.description = "the servo board's uplink falls silent while flying a path at 3 m/s: treated as transmitter loss, hover within 2.5 s".into();
    s.duration_s = 150.0;
    s.faults.uplink_silent = std::mem::take(&mut s.faults.transmitter_lost);
    s.limits.rc_loss_hover_within_s = Some(2.5);
    s.expect_events = vec![
        "uplink late".into(),
        "uplink silent".into(),
        "uplink lost".into(),
    ];
    s
}

/// `imu-failure`: the IMU dies while the pilot hovers by hand: the estimate is declared
/// invalid and the pilot keeps the helicopter, without yaw damping.
pub fn imu_failure() -> Scenario {
    let mut s = manual_sweep();
    s.name = "imu-failure".into();
    s.description =
        "the IMU falls silent while the pilot hovers by hand: estimate declared invalid, the pilot keeps flying".into();
    s.duration_s = 140.0;
    s.pilot.inputs.clear();
    s.faults.imu_silent = vec![[115.0, 1000.0]];
    s.limits = Limits {
        manual_distance_max_m: Some(10.0),
        ..Limits::default()
    };
    s.expect_events = vec!["imu silent".into(), "estimate invalid".into()];
    s
}

/// `baro-failure`: the altimeter never answers its handshake: the driver gives up after
/// three tries, the fault is raised, and the hover holds height on GPS and the IMU.
pub fn baro_failure() -> Scenario {
    let mut s = hover();
    s.name = "baro-failure".into();
    s.description =
        "the altimeter never answers: handshake failed, raised, hover on GPS and IMU height".into();
    s.faults.baro_silent = vec![[0.0, 1000.0]];
    s.limits.hold_altitude_rms_m = Some(1.0);
    s.limits.hold_true_max_m = Some(4.0);
    s.expect_events = vec!["baro failed".into()];
    s
}

/// `compass-silent`: the compass channels stop for 30 s in hover: raised, and the hold
/// goes on with heading from the IMU and GPS.
pub fn compass_silent() -> Scenario {
    let mut s = hover();
    s.name = "compass-silent".into();
    s.description = "the compass stops for 30 s in hover: raised, the hold goes on".into();
    s.faults.compass_silent = vec![[110.0, 140.0]];
    s.expect_events = vec!["compass silent".into(), "compass ok".into()];
    s
}

/// `no-gps-takeoff`: the GPS never delivers a fix: the pre-flight checks refuse the
/// autonomous take-off and the helicopter stays on its skids.
pub fn no_gps_takeoff() -> Scenario {
    let mut s = hover();
    s.name = "no-gps-takeoff".into();
    s.description =
        "no GPS fix at all: the autonomous take-off is refused, the helicopter stays on the ground"
            .into();
    s.duration_s = 120.0;
    s.faults.gps_outages = vec![[0.0, 1000.0]];
    // On its skids the estimate stays put too (zero-velocity updates): judged over five
    // minutes by `on_its_skids_without_gps_the_estimate_stays_where_the_helicopter_is`; this
    // scenario stays the short base the campaign tests shorten further, before any estimate.
    s.limits = Limits {
        ground_max_m: Some(0.3),
        ..Limits::default()
    };
    s.expect_events = vec!["take-off refused: no GPS fix".into()];
    s
}

/// `roll-rc-loss`: the transmitter is lost in the middle of the first roll: the roll is
/// finished upright, then the helicopter hovers where it stops.
pub fn roll_rc_loss() -> Scenario {
    let mut s = rolls();
    s.name = "roll-rc-loss".into();
    s.description =
        "transmitter lost in the middle of a roll: the roll ends upright, then a hover".into();
    s.faults.transmitter_lost = vec![[118.8, 1000.0]];
    s.limits = Limits {
        recovery_attitude_max_deg: Some(20.0),
        altitude_loss_max_m: Some(5.0),
        rc_loss_hover_within_s: Some(12.0),
        rc_loss_drift_max_m: Some(5.0),
        ..Limits::default()
    };
    s.expect_events = vec!["roll 1 completed".into(), "pilot signal lost".into()];
    s
}

/// `brownout`: the flight computer loses its power for half a second in the hover; the
/// servo board holds the last command, the computer boots, and the new flight process
/// aligns in the air from the record the old one left, then holds where it is.
pub fn brownout() -> Scenario {
    let mut s = hover();
    s.name = "brownout".into();
    s.description =
        "the flight computer browns out for 0.5 s in the hover: restarted, aligned in the air, holding"
            .into();
    s.duration_s = 150.0;
    s.faults.brownouts = vec![[110.0, 110.5]];
    // The limits are the measured envelope of the brown-out's 100 first seeds (2026-11-27,
    // docs/robustness.md): the half second without control and the levelling in the air put
    // the hold up to 3.0 m off its point and tilt it up to 20.2 deg (a clean hover: 10).
    // One seed in a hundred (45) runs away 25 m, a known limit shown there.
    s.limits = Limits {
        height_min_m: Some(8.0),
        tilt_max_deg: Some(22.0),
        hold_true_max_m: Some(3.5),
        ..Limits::default()
    };
    s.expect_events = vec![
        "flight process restarted in the air".into(),
        "aligned in the air: estimate running".into(),
    ];
    s
}

/// `gps-lost`: the GPS is lost for good in the hover: after 20 s of coasting the estimate is
/// declared degraded and the helicopter lands where it is, gently.
pub fn gps_lost() -> Scenario {
    let mut s = hover();
    s.name = "gps-lost".into();
    s.description =
        "the GPS is lost for good in the hover: estimate degraded after 20 s, landing in place"
            .into();
    s.duration_s = 200.0;
    s.faults.gps_outages = vec![[110.0, 1000.0]];
    s.limits = Limits {
        touchdown_sink_max_mps: Some(1.0),
        // Without GPS the inertial estimate drifts: up to 1.2 m/s over the ground on ten seeds.
        touchdown_speed_max_mps: Some(1.5),
        tilt_max_deg: Some(20.0),
        ..Limits::default()
    };
    // Landed is judged on the vertical speed alone without GPS: the rotor is brought down
    // on the ground, not left turning until the pilot takes over.
    s.expect_events = vec!["estimate degraded".into(), "phase landed".into()];
    s
}
