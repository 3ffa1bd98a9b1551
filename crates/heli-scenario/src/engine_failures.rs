//! Built-in engine-failure scenarios: the engine quits in a hover, in forward flight and in
//! the middle of an aileron roll, and the flight software must autorotate to a soft,
//! upright touchdown with the rotor kept in its speed range (docs/autorotation.md).
//!
//! The heights are above the model's height–velocity curve: from lower down there is not
//! the time to build the forward speed the flare turns into lift (the measured curve is in
//! docs/autorotation.md). Below the curve is its other side, a hover close to the ground,
//! where the rotor's energy alone cushions the drop (a hovering autorotation). Campaigns
//! over 100 seeds: `campaigns/autorotation/`.

use crate::faults::EngineFault;
use crate::flights::{hover, rolls};
use crate::scenario::{Limits, Scenario};

/// What every engine-failure scenario judges: a touchdown at most 1.5 m/s down, near level
/// (no rollover), the rotor above 60 % of its governed speed until the cushion.
fn autorotation_limits() -> Limits {
    Limits {
        touchdown_sink_max_mps: Some(1.5),
        touchdown_tilt_max_deg: Some(15.0),
        rotor_min_rpm: Some(960.0),
        ..Limits::default()
    }
}

/// The engine's power gone at `start_s`, for good.
fn engine_off(start_s: f64) -> Vec<EngineFault> {
    vec![EngineFault {
        start_s,
        end_s: 1.0e4,
        power: 0.0,
    }]
}

/// An engine-failure scenario flown from `base`: the library's plan of its name, the engine quitting at `fail_at_s`
/// for good, judged on the autorotation's limits; the failure and the phase expected.
fn engine_failure(
    base: Scenario,
    name: &str,
    description: &str,
    duration_s: f64,
    fail_at_s: f64,
) -> Scenario {
    let mut s = base;
    s.name = name.into();
    s.description = description.into();
    s.duration_s = duration_s;
    s.plan = crate::flights::library_plan(name);
    s.faults.engine = engine_off(fail_at_s);
    s.limits = autorotation_limits();
    s.expect_events = vec!["engine failure".into(), "phase autorotation".into()];
    s
}

/// `engine-failure-hover`: the engine quits in a hover at 80 m.
pub fn engine_failure_hover() -> Scenario {
    engine_failure(
        hover(),
        "engine-failure-hover",
        "the engine quits in a hover at 80 m: autorotation, a dive for speed, flare, soft touchdown",
        220.0,
        165.0,
    )
}

/// `engine-failure-low-hover`: the engine quits in a hover 1.5 m up (a take-off's or a
/// landing's height): a hovering autorotation. The rotor's speed is spent on the cushion
/// by design, so it is not judged.
pub fn engine_failure_low_hover() -> Scenario {
    let mut s = engine_failure(
        hover(),
        "engine-failure-low-hover",
        "the engine quits in a hover 1.5 m up: hovering autorotation, the rotor's energy cushions the drop",
        160.0,
        120.0,
    );
    s.limits.rotor_min_rpm = None;
    s
}

/// `engine-failure-forward`: the engine quits at 10 m/s, 60 m up.
pub fn engine_failure_forward() -> Scenario {
    engine_failure(
        hover(),
        "engine-failure-forward",
        "the engine quits flying north at 10 m/s, 60 m up: autorotation, glide, flare, soft touchdown",
        200.0,
        150.0,
    )
}

/// `engine-failure-roll`: the engine quits 1 s into the first of three rolls at 80 m, rolled
/// about 140 degrees; the helicopter is righted, then autorotates.
pub fn engine_failure_roll() -> Scenario {
    engine_failure(
        rolls(),
        "engine-failure-roll",
        "the engine quits in the first aileron roll at 80 m: righted, autorotation, soft touchdown",
        220.0,
        155.36,
    )
}
