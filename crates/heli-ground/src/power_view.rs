//! The batteries on the display: each pack's state as the vehicle's fuel gauge reports it
//! (`BATTERY_STATUS` per pack, the minutes left as `NAMED_VALUE_FLOAT`), the hot-swap's
//! source and the time on the flight and ground batteries (thesis §4.2.2: what the operator
//! used to log by hand), and the field rule (thesis §4.3): a pack draining abnormally ends
//! the flight test, so Start Logging of a new flight waits until the operator acknowledges.

use heli_link::ground::GroundLink;
use heli_link::telemetry::{
    FLIGHT_BATTERY_ID, RECEIVER_BATTERY_ID, SERVO_BATTERY_ID, level_of_code, level_of_percent,
};
use serde::Serialize;

/// One pack on the display.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PackView {
    /// `flight battery`, `receiver battery (RTXB)`, `servo battery (Sbat)`.
    pub name: &'static str,
    /// Volts.
    pub volts: f64,
    /// Charge left (%), when the vehicle's gauge gives it.
    pub percent: Option<f64>,
    /// Time left at the present drain (minutes), when given.
    pub minutes_left: Option<f64>,
    /// `good`, `warning` (a third or less), `critical` (15 % or less), or `unknown`.
    pub state: &'static str,
}

/// The batteries and the hot-swap.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PowerView {
    /// Each pack heard of.
    pub packs: Vec<PackView>,
    /// `flight` or `ground`, once the hot-swap's line is read.
    pub source: Option<&'static str>,
    /// Time on the flight batteries this flight (s).
    pub flight_s: Option<f64>,
    /// Time on the ground battery this flight (s).
    pub ground_s: Option<f64>,
    /// The field rule's message waiting for the operator's acknowledgement.
    pub field_rule: Option<String>,
    /// The packs' logbook: each named pack's time over every flight.
    pub logbook: Vec<crate::pack_log::PackTotalsView>,
}

/// The state word of a charge (%) alone, at the gauge's default levels
/// (`heli_link::telemetry::level_of_percent`): for a vehicle that sends no level.
pub fn state_of(percent: Option<f64>) -> &'static str {
    percent.map_or("unknown", level_of_percent)
}

/// The level the vehicle's gauge gives pack `value_name` (`FLT_LVL`, …), if one came within
/// the rows' staleness ([`crate::rows::STALE_AFTER_US`]) of `now_us`: a level from the last
/// flight is not this one's.
pub fn vehicle_level(link: &GroundLink, value_name: &str, now_us: u64) -> Option<&'static str> {
    let (at_us, code) = link.named.get(value_name)?;
    if now_us.saturating_sub(*at_us) > crate::rows::STALE_AFTER_US {
        return None;
    }
    level_of_code(f64::from(*code))
}

/// The packs and the hot-swap from what the link has heard by `now_us`. Each pack's state
/// is the level the vehicle's gauge sends with it (latched as the gauge latches it, at the
/// levels the vehicle is set to), not the whole percentage judged again: a good 33.46 %
/// arrives as 33. Only a vehicle that sends no level is judged by its number.
pub fn power_view(
    link: &GroundLink,
    field_rule: &FieldRule,
    logbook: &crate::pack_log::PackLog,
    now_us: u64,
) -> PowerView {
    let named = |name: &str| link.named.get(name).map(|(_, v)| f64::from(*v));
    let packs = [
        (FLIGHT_BATTERY_ID, "flight battery", "FLT_MIN", "FLT_LVL"),
        (
            RECEIVER_BATTERY_ID,
            "receiver battery (RTXB)",
            "RTXB_MIN",
            "RTXB_LVL",
        ),
        (
            SERVO_BATTERY_ID,
            "servo battery (Sbat)",
            "SBAT_MIN",
            "SBAT_LVL",
        ),
    ]
    .into_iter()
    .filter_map(|(id, name, minutes, level)| {
        let (_, b) = link.batteries.get(&id)?;
        let volts = f64::from(*b.voltages.first()?) / 1000.0;
        let percent = (b.battery_remaining >= 0).then(|| f64::from(b.battery_remaining));
        Some(PackView {
            name,
            volts,
            percent,
            minutes_left: named(minutes),
            state: vehicle_level(link, level, now_us).unwrap_or_else(|| state_of(percent)),
        })
    })
    .collect();
    let source = named("PWR_FLIGHT").map(|v| if v > 0.5 { "flight" } else { "ground" });
    PowerView {
        packs,
        source,
        flight_s: named("PWR_FLT_S"),
        ground_s: named("PWR_GND_S"),
        field_rule: field_rule.pending().map(str::to_string),
        logbook: logbook.view(),
    }
}

/// The field rule's state at the ground.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FieldRule {
    pending: Option<String>,
}

/// What marks the field rule in a vehicle's message.
pub const FIELD_RULE_MARK: &str = "draining abnormally";

impl FieldRule {
    /// A message from the vehicle: the field rule's is kept until acknowledged.
    pub fn see(&mut self, text: &str) {
        if text.contains(FIELD_RULE_MARK) {
            self.pending = Some(text.to_string());
        }
    }

    /// The message waiting for an acknowledgement.
    pub fn pending(&self) -> Option<&str> {
        self.pending.as_deref()
    }

    /// Why Start Logging is refused, while the message waits.
    pub fn blocks_start(&self) -> Option<String> {
        self.pending.as_ref().map(|t| {
            format!(
                "Start Logging is blocked by the field rule: \"{t}\". The flight test is over; acknowledge it (the Acknowledge button) to start another flight"
            )
        })
    }

    /// The operator acknowledges: `None` when nothing waited.
    pub fn acknowledge(&mut self) -> Option<String> {
        self.pending.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_field_rule_blocks_until_acknowledged() {
        let mut rule = FieldRule::default();
        rule.see("t=240.00 s phase land");
        assert!(rule.blocks_start().is_none());
        rule.see("t=241.00 s flight battery draining abnormally: end the flight test");
        let why = rule.blocks_start().unwrap();
        assert!(
            why.contains("end the flight test") && why.contains("acknowledge"),
            "{why}"
        );
        assert!(rule.acknowledge().is_some());
        assert!(rule.blocks_start().is_none());
        assert!(rule.acknowledge().is_none());
    }

    /// A link that has heard the flight pack at `percent` (whole, as sent) at `at_us`, and
    /// the vehicle's level for it `level_code` at `level_at_us`.
    fn heard(percent: i8, at_us: u64, level_code: Option<(f32, u64)>) -> GroundLink {
        let mut link = GroundLink::new(None);
        let mut voltages = [u16::MAX; 10];
        voltages[0] = 11_600;
        link.batteries.insert(
            FLIGHT_BATTERY_ID,
            (
                at_us,
                mavlink::dialects::common::BATTERY_STATUS_DATA {
                    voltages,
                    battery_remaining: percent,
                    ..Default::default()
                },
            ),
        );
        if let Some((code, level_at_us)) = level_code {
            link.named.insert("FLT_LVL".into(), (level_at_us, code));
        }
        link
    }

    #[test]
    fn a_pack_shows_the_vehicles_level_not_its_whole_percentage_judged_again() {
        let state = |link: &GroundLink, now_us: u64| {
            power_view(link, &FieldRule::default(), &Default::default(), now_us).packs[0].state
        };
        // The vehicle's good 33.46 % arrives as 33: good, as the vehicle says.
        assert_eq!(
            state(&heard(33, 1_000_000, Some((0.0, 1_000_000))), 1_200_000),
            "good"
        );
        // A warning latched while the charge bounced back to 40 %: a warning.
        assert_eq!(
            state(&heard(40, 1_000_000, Some((1.0, 1_000_000))), 1_200_000),
            "warning"
        );
        // No level sent (another vehicle), or only the last flight's: the number alone.
        assert_eq!(state(&heard(33, 1_000_000, None), 1_200_000), "warning");
        assert_eq!(
            state(&heard(40, 9_000_000, Some((1.0, 1_000_000))), 9_200_000),
            "good"
        );
    }

    #[test]
    fn the_state_words_follow_the_vehicle_levels() {
        assert_eq!(state_of(None), "unknown");
        assert_eq!(state_of(Some(80.0)), "good");
        assert_eq!(state_of(Some(33.0)), "warning");
        assert_eq!(state_of(Some(10.0)), "critical");
    }
}
