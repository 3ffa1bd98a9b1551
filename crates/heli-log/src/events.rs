//! The flight core's events as log messages: a text for people and a level for sorting the
//! routine from the alarming.
//!
//! [`event_text`] is the one place the event texts are made (`t=85.02 s phase takeoff`);
//! [`event_json`] is the `events` channel's message. An owner that kept only the text (the
//! simulator's event list today) gets the level back with [`event_json_from_text`], which
//! recognises every text [`event_text`] makes (tested for each kind of event).
//!
//! Levels follow Foxglove's `foxglove.Log` levels so that the same number serves its log
//! panel. They are the flight software's severities ([`CoreEvent::severity`]): routine and
//! notable activity is `info`; something off that the software absorbs (a watchdog fire, a
//! late device, an abandoned roll) is `warning`; something that changes what it does
//! (transmitter lost, GPS outage, a silent device) is `error`; an invalid estimate is `fatal`.

use heli_fsw::core::{CoreEvent, ReadingFault, Severity, StopAnswer, StopRefusal};
use heli_fsw::health::HealthState;
use heli_types::Device;
use serde_json::{Value, json};

/// How much an event matters (Foxglove's `foxglove.LogLevel` numbers).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EventLevel {
    /// Not known (an event kind this crate does not name yet, or an old log's event).
    Unknown = 0,
    /// Detail for debugging.
    Debug = 1,
    /// Routine or notable activity.
    Info = 2,
    /// Something off that the software handles without changing what it does.
    Warning = 3,
    /// Something off that changes what the software does.
    Error = 4,
    /// The flight cannot go on as planned.
    Fatal = 5,
}

impl EventLevel {
    /// Every level, lowest first.
    pub const ALL: [EventLevel; 6] = [
        EventLevel::Unknown,
        EventLevel::Debug,
        EventLevel::Info,
        EventLevel::Warning,
        EventLevel::Error,
        EventLevel::Fatal,
    ];

    /// The name written in the `events` channel's `level` field.
    pub const fn name(self) -> &'static str {
        match self {
            EventLevel::Unknown => "unknown",
            EventLevel::Debug => "debug",
            EventLevel::Info => "info",
            EventLevel::Warning => "warning",
            EventLevel::Error => "error",
            EventLevel::Fatal => "fatal",
        }
    }

    /// The level named `name` (as [`EventLevel::name`] writes it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Foxglove's number for this level.
    pub const fn foxglove(self) -> u8 {
        self as u8
    }

    /// Warning or worse: what `heli log info` lists as faults.
    pub fn is_fault(self) -> bool {
        self >= EventLevel::Warning
    }
}

/// The text of an event at `t_us`, beginning with its time (`t=85.02 s phase takeoff`).
pub fn event_text(t_us: u64, e: &CoreEvent) -> String {
    let t = t_us as f64 * 1e-6;
    match e {
        CoreEvent::CalibrationDone { gyro_bias_rps } => format!(
            "t={t:.2} s calibration done, gyro bias [{:.4}, {:.4}, {:.4}] rad/s",
            gyro_bias_rps[0], gyro_bias_rps[1], gyro_bias_rps[2]
        ),
        CoreEvent::CalibrationRestarted(m) => format!(
            "t={t:.2} s calibration restarted: the helicopter moved ({:.2} deg/s, {:.2} deg tilted, {:.1} deg turned)",
            m.rate_rps.to_degrees(),
            m.tilt_rad.to_degrees(),
            m.turn_rad.to_degrees()
        ),
        CoreEvent::CalibrationLeftOut(l) => format!(
            "t={t:.2} s calibration: the helicopter moved ({:.2} deg/s, {:.2} deg tilted); the second is left out of the average ({} s so far, the window as much longer)",
            l.motion.rate_rps.to_degrees(),
            l.motion.tilt_rad.to_degrees(),
            l.seconds
        ),
        CoreEvent::CalibrationHeldUp {
            restarts,
            left_out_s,
        } => format!(
            "t={t:.2} s calibration held up: the helicopter keeps moving on its skids ({restarts} restarts, {left_out_s} s left out of this window); hold it still or tie it down, turn its nose into the wind, or wait for the wind to drop"
        ),
        CoreEvent::CalibrationCompassMoved { moved_rad } => format!(
            "t={t:.2} s calibration: the compass heading moved {:.1} deg while the gyros saw the helicopter still (a magnetic disturbance near it, or a creep too slow for the gyros); the calibration goes on",
            moved_rad.to_degrees()
        ),
        CoreEvent::BatteryReading { battery, fault } => match fault {
            ReadingFault::Stuck { volts } => format!(
                "t={t:.2} s {} reading stuck at {volts:.2} V ({} readings the same): its charge is unknown, end the flight test",
                battery.name(),
                heli_fsw::core::battery_channel::STUCK_READINGS
            ),
            ReadingFault::Garbled { volts, refused } => format!(
                "t={t:.2} s {} reading refused: {volts:.2} V, more than {:.1} V from the readings before it ({refused} refused so far: an ADC or wiring fault?)",
                battery.name(),
                heli_fsw::core::battery_channel::JUMP_V
            ),
            ReadingFault::Late { age_s } => format!(
                "t={t:.2} s {} reading late: none for {age_s:.1} s",
                battery.name()
            ),
            ReadingFault::Back => format!("t={t:.2} s {} reading good again", battery.name()),
        },
        CoreEvent::PhaseChanged(p) => format!("t={t:.2} s phase {}", p.name()),
        CoreEvent::Stop(answer) => match answer {
            StopAnswer::Now => format!("t={t:.2} s stop: on the ground, the flight ends"),
            StopAnswer::Landing => format!(
                "t={t:.2} s stop in the air: landing where it is first, the flight ends on the ground"
            ),
            StopAnswer::Refused(why) => format!("t={t:.2} s stop refused: {}", why.text()),
            StopAnswer::Cancelled(why) => format!(
                "t={t:.2} s stop cancelled: the landing was given up ({}); Stop again once it is down",
                match why {
                    StopRefusal::PilotFlying => "the pilot took the helicopter",
                    StopRefusal::Blind => "the estimate was lost: descending blind",
                }
            ),
        },
        CoreEvent::EstimateDegraded { since_gps_s } => format!(
            "t={t:.2} s estimate degraded: no GPS fused for {since_gps_s:.0} s, landing where it is"
        ),
        CoreEvent::WatchdogFired => format!("t={t:.2} s watchdog fired"),
        CoreEvent::PilotSignalLost => format!("t={t:.2} s pilot signal lost"),
        CoreEvent::RollCompleted(n) => format!("t={t:.2} s roll {n} completed"),
        CoreEvent::RollAbandoned => format!("t={t:.2} s roll abandoned: took too long"),
        CoreEvent::PlanComplete => format!("t={t:.2} s flight plan complete"),
        CoreEvent::GpsLost => format!("t={t:.2} s GPS lost: estimate coasting on the IMU"),
        CoreEvent::GpsRegained => format!("t={t:.2} s GPS back"),
        CoreEvent::DeviceHealth { device, state } => {
            format!("t={t:.2} s {} {}", device.name(), state.name())
        }
        CoreEvent::EstimateInvalid => format!("t={t:.2} s estimate invalid: IMU silent"),
        CoreEvent::UplinkLost => format!("t={t:.2} s uplink lost: transmitter loss"),
        CoreEvent::GpsReset => {
            format!("t={t:.2} s GPS reset: position and velocity set to the GPS after a long coast")
        }
        CoreEvent::ModeRefused(refusal) => format!("t={t:.2} s {}", refusal.text()),
        CoreEvent::EngineFailure { rotor_rpm } => {
            format!("t={t:.2} s engine failure: rotor at {rotor_rpm} rpm, autorotation")
        }
        CoreEvent::BatteryLevel {
            battery,
            level,
            percent,
            minutes_left,
        } => {
            let action = match level {
                heli_power::Level::Good => "",
                heli_power::Level::Warning => ": return and land",
                heli_power::Level::Critical => ": land now",
            };
            format!(
                "t={t:.2} s {} {}: {percent} % left, {minutes_left} min at this drain{action}",
                battery.name(),
                level.name()
            )
        }
        CoreEvent::BatteryDrainingAbnormally { battery } => format!(
            "t={t:.2} s {} draining abnormally: end the flight test",
            battery.name()
        ),
        CoreEvent::PowerSource {
            source,
            flight_s,
            ground_s,
        } => format!(
            "t={t:.2} s power from the {} battery ({flight_s:.0} s on flight, {ground_s:.0} s on ground)",
            source.name()
        ),
        CoreEvent::TakeoffRefused(why) => {
            format!("t={t:.2} s take-off refused: {}", why.text())
        }
        CoreEvent::AidRefused { aid, test_ratio } => format!(
            "t={t:.2} s {} refused by the filter (test ratio {test_ratio:.1}): flying without it",
            aid.name()
        ),
        CoreEvent::AidAccepted(aid) => format!("t={t:.2} s {} fused again", aid.name()),
        CoreEvent::RestartedInAir => {
            format!("t={t:.2} s flight process restarted in the air: aligning, blind failsafe")
        }
        CoreEvent::RestartedInRoll {
            angle_rad: Some(angle),
            unseen_s,
        } => format!(
            "t={t:.2} s flight process restarted in a roll: {:.0} deg round after {unseen_s:.2} s \
             unseen; finishing it on the gyros, then aligning",
            angle.to_degrees()
        ),
        CoreEvent::RestartedInRoll {
            angle_rad: None,
            unseen_s,
        } => format!(
            "t={t:.2} s flight process restarted in a roll unseen for {unseen_s:.2} s, longer \
             than the servo board holds a command: aligning in the air, blind failsafe"
        ),
        CoreEvent::RollEndedBlind { finished: true } => format!(
            "t={t:.2} s roll finished without the estimate: cyclic levelled, blind failsafe"
        ),
        CoreEvent::RollEndedBlind { finished: false } => {
            format!("t={t:.2} s roll stopped without the estimate: cyclic levelled, blind failsafe")
        }
        CoreEvent::ImuBackInAir => format!(
            "t={t:.2} s IMU back after the estimate was declared invalid: aligning in the air, \
             blind failsafe"
        ),
        CoreEvent::AlignedInAir { gps: true } => {
            format!("t={t:.2} s aligned in the air: estimate running")
        }
        CoreEvent::AlignedInAir { gps: false } => {
            format!("t={t:.2} s aligned in the air without a GPS fix: estimate running")
        }
        CoreEvent::GpsImplausible(why) => match why {
            heli_fsw::core::Implausible::OffTheGlobe => {
                format!("t={t:.2} s GPS fix refused: off the globe")
            }
            heli_fsw::core::Implausible::Jump { distance_m } => {
                format!("t={t:.2} s GPS fix refused: jumped {distance_m:.0} m")
            }
        },
    }
}

/// How much an event matters: the flight software's severity as a log level (routine and
/// notable activity `info`, low warnings `warning`, high warnings `error`, fatal `fatal`).
pub fn event_level(e: &CoreEvent) -> EventLevel {
    match e.severity() {
        Severity::ActivityLo | Severity::ActivityHi => EventLevel::Info,
        Severity::WarningLo => EventLevel::Warning,
        Severity::WarningHi => EventLevel::Error,
        Severity::Fatal => EventLevel::Fatal,
    }
}

/// Every event whose text has no number in it, for recognising texts.
fn events_without_numbers() -> Vec<CoreEvent> {
    let mut events = vec![
        CoreEvent::WatchdogFired,
        CoreEvent::PilotSignalLost,
        CoreEvent::RollAbandoned,
        CoreEvent::PlanComplete,
        CoreEvent::GpsLost,
        CoreEvent::GpsRegained,
        CoreEvent::EstimateInvalid,
        CoreEvent::UplinkLost,
        CoreEvent::GpsImplausible(heli_fsw::core::Implausible::OffTheGlobe),
        CoreEvent::TakeoffRefused(heli_fsw::core::Refusal::NoGpsFix),
        CoreEvent::GpsReset,
        CoreEvent::TakeoffRefused(heli_fsw::core::Refusal::ImuNotHealthy),
        CoreEvent::RestartedInAir,
        CoreEvent::ImuBackInAir,
        CoreEvent::RollEndedBlind { finished: true },
        CoreEvent::RollEndedBlind { finished: false },
        CoreEvent::AlignedInAir { gps: true },
        CoreEvent::AlignedInAir { gps: false },
        CoreEvent::Stop(StopAnswer::Now),
        CoreEvent::Stop(StopAnswer::Landing),
        CoreEvent::Stop(StopAnswer::Refused(StopRefusal::PilotFlying)),
        CoreEvent::Stop(StopAnswer::Refused(StopRefusal::Blind)),
        CoreEvent::Stop(StopAnswer::Cancelled(StopRefusal::PilotFlying)),
        CoreEvent::Stop(StopAnswer::Cancelled(StopRefusal::Blind)),
        CoreEvent::AidAccepted(heli_fsw::core::Aid::Altimeter),
        CoreEvent::AidAccepted(heli_fsw::core::Aid::Compass),
    ];
    for battery in heli_fsw::core::power::Battery::ALL {
        events.push(CoreEvent::BatteryDrainingAbnormally { battery });
    }
    for device in Device::ALL {
        for state in [
            HealthState::Waiting,
            HealthState::Ok,
            HealthState::Late,
            HealthState::Silent,
            HealthState::Failed,
        ] {
            events.push(CoreEvent::DeviceHealth { device, state });
        }
    }
    events
}

/// The `events` channel's message for an event at `t_us`: `{"text": …, "level": …}`.
pub fn event_json(t_us: u64, e: &CoreEvent) -> Value {
    text_event_json(&event_text(t_us, e), event_level(e))
}

/// The `events` channel's message for an event known by its text and level.
pub fn text_event_json(text: &str, level: EventLevel) -> Value {
    json!({ "text": text, "level": level.name() })
}

/// The time (µs) and level of an event text made by [`event_text`]; `None` for a text that
/// does not begin with its time. A kind of event it does not know gets
/// [`EventLevel::Unknown`]. The time has the text's resolution (10 ms).
pub fn parse_event_text(text: &str) -> Option<(u64, EventLevel)> {
    let rest = text.strip_prefix("t=")?;
    let (seconds, what) = rest.split_once(" s ")?;
    let seconds: f64 = seconds
        .parse()
        .ok()
        .filter(|s: &f64| s.is_finite() && *s >= 0.0)?;
    let t_us = (seconds * 1e6).round() as u64;
    // The kinds whose texts carry numbers or names, by their fixed part.
    let with_numbers = [
        (
            "calibration done",
            CoreEvent::CalibrationDone {
                gyro_bias_rps: [0.0; 3],
            },
        ),
        (
            "phase ",
            CoreEvent::PhaseChanged(heli_fsw::phase::Phase::Manual),
        ),
        (
            "estimate degraded",
            CoreEvent::EstimateDegraded { since_gps_s: 0.0 },
        ),
        (
            "calibration restarted",
            CoreEvent::CalibrationRestarted(heli_fsw::core::Motion {
                rate_rps: 0.0,
                tilt_rad: 0.0,
                turn_rad: 0.0,
            }),
        ),
        (
            "calibration: the helicopter moved",
            CoreEvent::CalibrationLeftOut(heli_fsw::core::LeftOut {
                motion: heli_fsw::core::Motion {
                    rate_rps: 0.0,
                    tilt_rad: 0.0,
                    turn_rad: 0.0,
                },
                seconds: 0,
            }),
        ),
        (
            "calibration held up",
            CoreEvent::CalibrationHeldUp {
                restarts: 0,
                left_out_s: 0,
            },
        ),
        (
            "calibration: the compass heading moved",
            CoreEvent::CalibrationCompassMoved { moved_rad: 0.0 },
        ),
        (
            "flight battery reading stuck",
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Stuck { volts: 0.0 },
            },
        ),
        (
            "flight battery reading refused",
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Garbled {
                    volts: 0.0,
                    refused: 0,
                },
            },
        ),
        (
            "flight battery reading late",
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Late { age_s: 0.0 },
            },
        ),
        (
            "flight battery reading good again",
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Back,
            },
        ),
        ("roll ", CoreEvent::RollCompleted(1)),
        ("engine failure", CoreEvent::EngineFailure { rotor_rpm: 0 }),
        (
            "power from the",
            CoreEvent::PowerSource {
                source: heli_power::PowerSource::Flight,
                flight_s: 0.0,
                ground_s: 0.0,
            },
        ),
        (
            "altimeter refused",
            CoreEvent::AidRefused {
                aid: heli_fsw::core::Aid::Altimeter,
                test_ratio: 0.0,
            },
        ),
        (
            "compass refused",
            CoreEvent::AidRefused {
                aid: heli_fsw::core::Aid::Compass,
                test_ratio: 0.0,
            },
        ),
    ];
    // A battery's level: "<battery> <level>: ...".
    let battery_level = heli_fsw::core::power::Battery::ALL.iter().find_map(|b| {
        let rest = what.strip_prefix(b.name())?.strip_prefix(' ')?;
        let level = [
            heli_power::Level::Good,
            heli_power::Level::Warning,
            heli_power::Level::Critical,
        ]
        .into_iter()
        .find(|l| rest.starts_with(&format!("{}:", l.name())))?;
        Some(CoreEvent::BatteryLevel {
            battery: *b,
            level,
            percent: 0,
            minutes_left: 0,
        })
    });
    if let Some(e) = battery_level {
        return Some((t_us, event_level(&e)));
    }
    let level = events_without_numbers()
        .iter()
        .find(|e| event_text(0, e).strip_prefix("t=0.00 s ") == Some(what))
        .or_else(|| {
            with_numbers
                .iter()
                .find(|(start, e)| {
                    what.starts_with(start)
                        && (!matches!(e, CoreEvent::RollCompleted(_))
                            || what.ends_with(" completed"))
                })
                .map(|(_, e)| e)
        })
        .map_or(EventLevel::Unknown, event_level);
    Some((t_us, level))
}

/// The time (µs) and `events` message of an event text made by [`event_text`]; `None` if the
/// text does not begin with its time. Kinds of event it does not know get level `unknown`.
pub fn event_json_from_text(text: &str) -> Option<(u64, Value)> {
    let (t_us, level) = parse_event_text(text)?;
    Some((t_us, text_event_json(text, level)))
}

/// The level of an `events` message: its `level` field, or for a log written before events had
/// levels, the level of its text.
pub fn level_of(message: &Value) -> EventLevel {
    if let Some(level) = message["level"].as_str().and_then(EventLevel::from_name) {
        return level;
    }
    message["text"]
        .as_str()
        .and_then(parse_event_text)
        .map_or(EventLevel::Unknown, |(_, level)| level)
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_fsw::phase::Phase;

    fn every_kind() -> Vec<CoreEvent> {
        let mut events = vec![
            CoreEvent::CalibrationDone {
                gyro_bias_rps: [0.001, -0.002, 0.0005],
            },
            CoreEvent::PhaseChanged(Phase::Manual),
            CoreEvent::PhaseChanged(Phase::Landed),
            CoreEvent::CalibrationLeftOut(heli_fsw::core::LeftOut {
                motion: heli_fsw::core::Motion {
                    rate_rps: 0.12,
                    tilt_rad: 0.01,
                    turn_rad: 0.0,
                },
                seconds: 4,
            }),
            CoreEvent::CalibrationHeldUp {
                restarts: 3,
                left_out_s: 7,
            },
            CoreEvent::CalibrationCompassMoved { moved_rad: 0.1 },
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Stuck { volts: 12.3 },
            },
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Garbled {
                    volts: 3.1,
                    refused: 2,
                },
            },
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Late { age_s: 3.2 },
            },
            CoreEvent::BatteryReading {
                battery: heli_fsw::core::power::Battery::Flight,
                fault: ReadingFault::Back,
            },
            CoreEvent::RollCompleted(2),
            CoreEvent::EngineFailure { rotor_rpm: 1290 },
            CoreEvent::PowerSource {
                source: heli_power::PowerSource::Ground,
                flight_s: 12.0,
                ground_s: 300.0,
            },
        ];
        for battery in heli_fsw::core::power::Battery::ALL {
            for level in [heli_power::Level::Warning, heli_power::Level::Critical] {
                events.push(CoreEvent::BatteryLevel {
                    battery,
                    level,
                    percent: 30,
                    minutes_left: 12,
                });
            }
        }
        events.extend(events_without_numbers());
        events
    }

    #[test]
    fn every_event_text_is_recognised_with_its_time_and_level() {
        for e in every_kind() {
            let text = event_text(85_020_000, &e);
            assert!(text.starts_with("t=85.02 s "), "{text}");
            assert_ne!(event_level(&e), EventLevel::Unknown, "{text}");
            assert!(!text.contains('{'), "a text, not a Debug form: {text}");
            assert_eq!(
                parse_event_text(&text),
                Some((85_020_000, event_level(&e))),
                "{text}"
            );
            let message = event_json(85_020_000, &e);
            assert_eq!(message["text"], text.as_str());
            assert_eq!(level_of(&message), event_level(&e));
            assert_eq!(event_json_from_text(&text), Some((85_020_000, message)));
        }
    }

    #[test]
    fn levels_sort_the_routine_from_the_alarming() {
        assert_eq!(event_level(&CoreEvent::GpsLost), EventLevel::Error);
        assert_eq!(event_level(&CoreEvent::WatchdogFired), EventLevel::Warning);
        assert_eq!(event_level(&CoreEvent::PlanComplete), EventLevel::Info);
        assert_eq!(event_level(&CoreEvent::EstimateInvalid), EventLevel::Fatal);
        let silent_gps = CoreEvent::DeviceHealth {
            device: Device::Gps,
            state: HealthState::Silent,
        };
        assert_eq!(event_level(&silent_gps), EventLevel::Error);
        assert_eq!(
            parse_event_text("t=12.00 s gps silent"),
            Some((12_000_000, EventLevel::Error))
        );
        assert!(EventLevel::Warning.is_fault() && !EventLevel::Info.is_fault());
        assert_eq!(EventLevel::Error.foxglove(), 4);
        for level in EventLevel::ALL {
            assert_eq!(EventLevel::from_name(level.name()), Some(level));
        }
    }

    #[test]
    fn texts_it_did_not_make_are_not_given_a_level() {
        assert_eq!(parse_event_text("hello"), None);
        assert_eq!(parse_event_text("t=x s phase hold"), None);
        assert_eq!(parse_event_text("t=-1.00 s phase hold"), None);
        assert_eq!(
            parse_event_text("t=1.00 s something new"),
            Some((1_000_000, EventLevel::Unknown))
        );
        // An old log's event, without a level field: the level comes from its text.
        assert_eq!(
            level_of(&json!({"text": "t=3.00 s watchdog fired"})),
            EventLevel::Warning
        );
        assert_eq!(level_of(&json!({"other": 1})), EventLevel::Unknown);
    }
}
