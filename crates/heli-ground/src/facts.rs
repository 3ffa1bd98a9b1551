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

/// Every condition's fact from the telemetry, the rows made from it, the link's age, the
/// battery meter's colour (green: more than a third of its life left) and whether the
/// vehicle's heartbeat says a flight process flies.
pub fn facts(
    latest: &Latest,
    rows: &Rows,
    heartbeat_age_us: Option<u64>,
    battery_green: bool,
    flying: bool,
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
    // The estimate runs only in a flight process that flies (the heartbeat, sent at once on
    // a change, says so before the last flight's telemetry has aged).
    let calibrated = flying
        && sensor_health(latest, MavSysStatusSensor::MAV_SYS_STATUS_AHRS) == Some(true)
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
    /// Why it is false, when the ground knows better than the rule's words (the data's
    /// age, a reading never received).
    pub why: Option<String>,
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
    /// The vehicle refuses this kind of flight now, whatever the conditions say (a refusal
    /// that stands until the pilot cycles the auto switch): its words.
    pub refused_by_vehicle: Option<String>,
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

/// What the ground knows beyond a condition's truth: why it is false, in the operator's
/// words, where the rule's own words would mislead ("a battery down to a third" for a
/// battery never read).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Why(pub Vec<(Condition, String)>);

impl Why {
    fn of(&self, c: Condition) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| *k == c)
            .map(|(_, w)| w.as_str())
    }
}

/// A refusal of the vehicle that stands: which rule's flight it refuses, and its words.
#[derive(Clone, Debug, PartialEq)]
pub struct Standing {
    /// The refused kind of flight: [`AUTOMATIC`] or [`AUGMENTED`].
    pub rule: Rule,
    /// What the vehicle said, and what clears it.
    pub text: String,
}

fn verdict_view(rule: Rule, facts: Facts, why: &Why, standing: Option<&Standing>) -> VerdictView {
    let v: Verdict = rule.judge(facts);
    let refused_by_vehicle = standing.filter(|s| s.rule == rule).map(|s| s.text.clone());
    let mut failing: Vec<String> = Vec::new();
    for c in v.wanted_true.iter() {
        failing.push(
            why.of(c)
                .map_or_else(|| c.missing().to_string(), str::to_string),
        );
    }
    for c in v.wanted_false.iter() {
        failing.push(c.meaning().to_string());
    }
    if let Some(r) = &refused_by_vehicle {
        failing.insert(0, r.clone());
    }
    VerdictView {
        rule: rule.to_string(),
        allowed: v.allowed && refused_by_vehicle.is_none(),
        failing: failing.join(", "),
        refused_by_vehicle,
    }
}

/// The safety panel for `facts`, with the ground's reasons and the vehicle's standing
/// refusal: a verdict never says safe while the vehicle refuses that flight.
pub fn safety_view(facts: Facts, why: &Why, standing: Option<&Standing>) -> SafetyView {
    SafetyView {
        conditions: Condition::ALL
            .into_iter()
            .map(|c| ConditionView {
                name: c.name(),
                meaning: c.meaning(),
                value: facts.get(c).unwrap_or(false),
                wanted: c != Condition::Bypass,
                why: why.of(c).map(str::to_string),
            })
            .collect(),
        augmented: verdict_view(AUGMENTED, facts, why, standing),
        automatic: verdict_view(AUTOMATIC, facts, why, standing),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all_good() -> Facts {
        Condition::ALL
            .into_iter()
            .fold(Facts::none(), |f, c| f.with(c, c != Condition::Bypass))
    }

    #[test]
    fn a_standing_refusal_makes_its_verdict_no_whatever_the_conditions() {
        let standing = Standing {
            rule: AUTOMATIC,
            text: "take-off refused: 4 satellites".into(),
        };
        let s = safety_view(all_good(), &Why::default(), Some(&standing));
        assert!(!s.automatic.allowed);
        assert!(s.automatic.failing.starts_with("take-off refused"));
        assert!(s.augmented.allowed, "only the refused flight");
        let s = safety_view(all_good(), &Why::default(), None);
        assert!(s.automatic.allowed && s.automatic.refused_by_vehicle.is_none());
    }

    #[test]
    fn the_grounds_reason_replaces_the_rules_words() {
        let facts = all_good().with(Condition::Battery, false);
        let s = safety_view(facts, &Why::default(), None);
        assert_eq!(s.augmented.failing, "a battery down to a third of its life");
        let why = Why(vec![(Condition::Battery, "no battery reading".into())]);
        let s = safety_view(facts, &why, None);
        assert_eq!(s.augmented.failing, "no battery reading");
        assert_eq!(s.conditions[7].why.as_deref(), Some("no battery reading"));
    }
}
