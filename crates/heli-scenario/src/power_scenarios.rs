//! Built-in power scenarios (docs/power.md): the hot-swap from the ground battery to the
//! flight batteries before take-off, a weak flight pack that reaches its warning level in
//! the air (the return-and-land failsafe), and a drain no one planned (the field rule).

use crate::faults::{Battery, BatteryDrain, PackName};
use crate::flights::hover;
use crate::scenario::{Limits, Scenario};

/// `battery-swap`: the ground battery powers the avionics for the first minute of the
/// calibration, then the operator swaps to the flight batteries; both times are logged.
pub fn battery_swap() -> Scenario {
    let mut s = hover();
    s.name = "battery-swap".into();
    s.description =
        "on the ground battery for the first 60 s of the calibration, then the flight batteries: both times logged, then the hover"
            .into();
    s.power.ground_until_s = 60.0;
    s.expect_events = vec![
        "power from the ground battery".into(),
        "power from the flight battery".into(),
    ];
    s
}

/// `weak-battery`: a worn flight pack (35 % of its capacity, 70 % charged) drains three
/// times as fast as its type says: the field rule is raised, then the warning level with
/// the helicopter 60 m away, and it comes back and lands at the take-off point with the
/// avionics still powered.
pub fn weak_battery() -> Scenario {
    let mut s = hover();
    s.name = "weak-battery".into();
    s.description =
        "a worn flight pack: draining abnormally, then the warning level 60 m out: back to the take-off point and landed, still powered"
            .into();
    s.duration_s = 700.0;
    s.battery = Battery {
        charge: 0.7,
        health: 0.35,
        ..Battery::default()
    };
    s.plan = crate::flights::library_plan("weak-battery");
    s.limits = Limits {
        touchdown_distance_max_m: Some(3.0),
        touchdown_sink_max_mps: Some(1.0),
        flight_battery_soc_min: Some(0.1),
        ..Limits::default()
    };
    s.expect_events = vec![
        "flight battery draining abnormally: end the flight test".into(),
        "flight battery warning".into(),
        "return and land".into(),
        "phase landed".into(),
    ];
    s
}

/// `battery-drain`: 3 A more than planned from the flight pack, from the hover on: the
/// field rule tells the operator to end the flight test.
pub fn battery_drain() -> Scenario {
    let mut s = hover();
    s.name = "battery-drain".into();
    s.description =
        "3 A drawn from the flight pack that no one planned, from 100 s: draining abnormally, end the flight test"
            .into();
    s.duration_s = 200.0;
    s.faults.battery_drains = vec![BatteryDrain {
        battery: PackName::Flight,
        start_s: 100.0,
        end_s: 1.0e4,
        extra_a: 3.0,
    }];
    s.expect_events = vec!["flight battery draining abnormally: end the flight test".into()];
    s
}
