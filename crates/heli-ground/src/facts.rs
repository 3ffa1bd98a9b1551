//! The ground's judge of the safety rule (`heli_control::safety`, thesis §4.3): every
//! condition read from telemetry. The ground observes every condition, so nothing is passed
//! as "not judged"; a condition with no telemetry behind it yet is false.

use heli_control::safety::{AUGMENTED, AUTOMATIC, Condition, Facts, Rule, Verdict};
use mavlink::MessageData;
use mavlink::dialects::common::*;
use serde::Serialize;

use crate::checks::gps_ok;
use crate::rows::{Latest, Rows, sensor_health};

/// The vehicle's heartbeat must be this recent (µs) for the link to be fresh.
pub const LINK_FRESH_US: u64 = 3_000_000;

/// Every condition's fact from the telemetry, the rows made from it, the link's age and the
/// battery meter's colour (green: more than a third of its life left).
pub fn facts(
    latest: &Latest,
    rows: &Rows,
    heartbeat_age_us: Option<u64>,
    battery_green: bool,
) -> Facts {
    let fresh = |row: &Option<crate::rows::Row>| row.as_ref().is_some_and(|r| !r.stale);
    let satellites = match latest.get(&GPS_RAW_INT_DATA::ID) {
        Some((_, MavMessage::GPS_RAW_INT(g))) => gps_ok(g.satellites_visible) && fresh(&rows.gps),
        _ => false,
    };
    let bypass = match latest.get(&RC_CHANNELS_DATA::ID) {
        Some((_, MavMessage::RC_CHANNELS(rc))) => rc.chan7_raw > 1500,
        _ => false,
    };
    let calibrated = sensor_health(latest, MavSysStatusSensor::MAV_SYS_STATUS_AHRS) == Some(true)
        && fresh(&rows.state);
    Facts::none()
        .with(Condition::Calibrated, calibrated)
        .with(Condition::Imu, fresh(&rows.imu))
        .with(Condition::Uplink, fresh(&rows.uplink))
        .with(Condition::Gps, fresh(&rows.gps))
        .with(Condition::Satellites, satellites)
        .with(Condition::Altimeter, fresh(&rows.bar))
        .with(Condition::Compass, fresh(&rows.cmps))
        .with(Condition::Battery, battery_green)
        .with(
            Condition::Link,
            heartbeat_age_us.is_some_and(|a| a < LINK_FRESH_US),
        )
        .with(Condition::Bypass, bypass)
}

/// One condition as the display lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConditionView {
    /// Short name (as in the rules).
    pub name: &'static str,
    /// What it means.
    pub meaning: &'static str,
    /// Its value now.
    pub value: bool,
    /// The value the rules want (false only for the bypass switch).
    pub wanted: bool,
}

/// One verdict as the display shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VerdictView {
    /// The rule as written.
    pub rule: String,
    /// Allowed now.
    pub allowed: bool,
    /// What fails, in words (empty when allowed).
    pub failing: String,
}

/// The safety panel: the conditions and the two verdicts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SafetyView {
    /// Every condition.
    pub conditions: Vec<ConditionView>,
    /// Safe for augmented flight.
    pub augmented: VerdictView,
    /// Safe for automatic flight.
    pub automatic: VerdictView,
}

fn verdict_view(rule: Rule, facts: Facts) -> VerdictView {
    let v: Verdict = rule.judge(facts);
    VerdictView {
        rule: rule.to_string(),
        allowed: v.allowed,
        failing: if v.allowed {
            String::new()
        } else {
            v.to_string()
        },
    }
}

/// The safety panel for `facts`.
pub fn safety_view(facts: Facts) -> SafetyView {
    SafetyView {
        conditions: Condition::ALL
            .into_iter()
            .map(|c| ConditionView {
                name: c.name(),
                meaning: c.meaning(),
                value: facts.get(c).unwrap_or(false),
                wanted: c != Condition::Bypass,
            })
            .collect(),
        augmented: verdict_view(AUGMENTED, facts),
        automatic: verdict_view(AUTOMATIC, facts),
    }
}
