//! The built-in flights every other built-in scenario starts from: the hover, the rolls,
//! the demonstration, the transmitter loss on a path, the GPS outage, the manual sweep, the
//! augmented flight. Each takes its plan from the plan library under its own name.

use crate::faults::{Battery, Faults, Power};
use crate::pilot::{Channel, Pilot, Shape, StickInput};
use crate::scenario::{FlightMode, Limits, Scenario};
use heli_model::params::{Airframe, Atmosphere};
use heli_types::Leg;

impl Default for Scenario {
    fn default() -> Self {
        hover()
    }
}

/// The plan of the library named `name` (the plan the built-in scenario of that name flies).
pub(crate) fn library_plan(name: &str) -> Vec<Leg> {
    heli_types::library::plan(name).map_or_else(Vec::new, |p| p.legs.to_vec())
}

fn base(name: &str, description: &str, duration_s: f64) -> Scenario {
    Scenario {
        name: name.into(),
        description: description.into(),
        seed: 1,
        duration_s,
        wind_ned_mps: [0.0; 3],
        turbulence_sigma_mps: 0.0,
        wind_shear_mps_per_m: [0.0; 3],
        wind_changes: Vec::new(),
        atmosphere: Atmosphere::default(),
        airframe: Airframe::default(),
        battery: Battery::default(),
        power: Power::default(),
        mode: FlightMode::Autonomous,
        plan: library_plan(name),
        pilot: Pilot::default(),
        faults: Faults::default(),
        limits: Limits::default(),
        expect_events: Vec::new(),
    }
}

/// Built-in scenario `hover`: rotor governed at 1600 rpm on the ground, 80 s calibration,
/// autonomous take-off to 10 m, 60 s position hold.
pub fn hover() -> Scenario {
    let mut s = base(
        "hover",
        "calibrate on the ground, take off autonomously to 10 m, hold position for 60 s",
        200.0,
    );
    s.limits = Limits {
        hold_min_s: Some(60.0),
        hold_horizontal_rms_m: Some(1.0),
        hold_altitude_rms_m: Some(0.5),
        hold_true_max_m: Some(3.0),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `rolls`: forward flight at 8 m/s, three autonomous aileron rolls,
/// recovery to the trim trajectory.
pub fn rolls() -> Scenario {
    let mut s = base(
        "rolls",
        "take off, climb to 25 m, three autonomous aileron rolls from 8 m/s, recover, hold",
        260.0,
    );
    s.limits = Limits {
        rolls_min: Some(3.0),
        altitude_loss_max_m: Some(5.0),
        recovery_attitude_max_deg: Some(15.0),
        recovery_speed_max_mps: Some(3.0),
        att_err_rms_max_deg: Some(1.5),
        att_err_max_deg: Some(5.0),
        pos_err_rms_max_m: Some(2.5),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `demo`, the default of `heli sim`: take-off, hover, the way out to the
/// west end of a flight line in front of the pilot, three rolls back along it past the pilot,
/// return and landing.
pub fn demo() -> Scenario {
    let mut s = base(
        "demo",
        "demonstration flight: take off, hover, out to the flight line's west end, three aileron rolls back along it past the pilot, fly home, land",
        320.0,
    );
    s.limits = Limits {
        rolls_min: Some(3.0),
        altitude_loss_max_m: Some(5.0),
        recovery_attitude_max_deg: Some(15.0),
        recovery_speed_max_mps: Some(3.0),
        att_err_max_deg: Some(5.0),
        plan_complete: Some(true),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `rc-loss`: the pilot's transmitter is lost while the helicopter flies a
/// path; the computer must hover.
pub fn rc_loss() -> Scenario {
    let mut s = base(
        "rc-loss",
        "transmitter lost while flying a path at 3 m/s: hover within 2 s, drift under 3 m",
        160.0,
    );
    s.faults.transmitter_lost = vec![[110.0, 1000.0]];
    s.limits = Limits {
        rc_loss_hover_within_s: Some(2.0),
        rc_loss_drift_max_m: Some(3.0),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `gps-outage`: 10 s without GPS in hover.
pub fn gps_outage() -> Scenario {
    let mut s = hover();
    s.name = "gps-outage".into();
    s.description =
        "10 s without GPS while hovering: no divergence, position error under 5 m".into();
    s.faults.gps_outages = vec![[120.0, 130.0]];
    s.limits.gps_outage_pos_err_max_m = Some(5.0);
    // The GPS watchdog raises the silence; the filter reports its coasting.
    s.expect_events = vec!["gps silent".into(), "GPS lost".into(), "GPS back".into()];
    s.limits.hold_true_max_m = Some(6.0);
    s
}

/// Built-in scenario `manual-sweep`: the pilot takes over from an autonomous hover, hovers
/// by hand and flies a lateral-cyclic frequency sweep, as the thesis's identification flights
/// did; the computer damps yaw.
pub fn manual_sweep() -> Scenario {
    let mut s = base(
        "manual-sweep",
        "manual flight with computer yaw damping: a 0.3-3 Hz lateral-cyclic sweep from a hover",
        170.0,
    );
    s.pilot.auto_flipped = vec![[105.0, 155.0]];
    s.pilot.hovers_in_manual = true;
    s.pilot.inputs = vec![StickInput {
        channel: Channel::Aileron,
        shape: Shape::Sweep,
        start_s: 112.0,
        duration_s: 30.0,
        amplitude: 0.15,
        f0_hz: 0.3,
        f1_hz: 3.0,
    }];
    s.limits = Limits {
        manual_yaw_rate_max_dps: Some(30.0),
        manual_distance_max_m: Some(10.0),
        sweep_roll_rate_rms_min_dps: Some(10.0),
        ..Limits::default()
    };
    s
}

/// Built-in scenario `augmented`: velocity-command augmentation; the pilot's scripted sticks
/// climb, fly forward, sideways and turn.
pub fn augmented() -> Scenario {
    let mut s = base(
        "augmented",
        "augmented velocity mode: scripted sticks climb, fly forward, sideways, turn; the computer tracks",
        140.0,
    );
    s.mode = FlightMode::Augmented(heli_types::AugmentedMode::Velocity);
    let step = |channel, start_s, duration_s, amplitude| StickInput {
        channel,
        shape: Shape::Step,
        start_s,
        duration_s,
        amplitude,
        f0_hz: 0.0,
        f1_hz: 0.0,
    };
    s.pilot.inputs = vec![
        step(Channel::Collective, 86.0, 10.0, 0.5),
        step(Channel::Elevator, 100.0, 10.0, -0.6),
        step(Channel::Aileron, 114.0, 8.0, 0.4),
        step(Channel::Rudder, 126.0, 3.0, 0.25),
    ];
    s.limits = Limits {
        velocity_tracking_max_mps: Some(0.6),
        yaw_rate_tracking_max_dps: Some(5.0),
        climb_min_m: Some(8.0),
        ..Limits::default()
    };
    s
}
