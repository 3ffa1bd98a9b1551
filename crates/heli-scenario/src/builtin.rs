//! The built-in scenarios, by name (`heli sim --list`).

use crate::flights::{augmented, demo, gps_outage, hover, manual_sweep, rc_loss, rolls};
use crate::scenario::Scenario;
use crate::{device_faults, engine_failures, power_scenarios};

/// All built-in scenarios, the default flight of `heli sim` first.
pub fn builtins() -> Vec<Scenario> {
    vec![
        demo(),
        hover(),
        rolls(),
        rc_loss(),
        gps_outage(),
        manual_sweep(),
        augmented(),
        device_faults::uplink_silent(),
        device_faults::imu_failure(),
        device_faults::baro_failure(),
        device_faults::compass_silent(),
        device_faults::no_gps_takeoff(),
        device_faults::roll_rc_loss(),
        device_faults::brownout(),
        device_faults::gps_lost(),
        engine_failures::engine_failure_hover(),
        engine_failures::engine_failure_low_hover(),
        engine_failures::engine_failure_forward(),
        engine_failures::engine_failure_roll(),
        power_scenarios::battery_swap(),
        power_scenarios::weak_battery(),
        power_scenarios::battery_drain(),
    ]
}

/// A built-in scenario by name.
pub fn builtin(name: &str) -> Option<Scenario> {
    builtins().into_iter().find(|s| s.name == name)
}
