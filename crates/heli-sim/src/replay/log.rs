//! Replay of a flight log: the device inputs it recorded (channel `device`) fed to a fresh
//! flight computer, whose servo commands and state estimates are compared, bit for bit, with
//! the ones the log recorded. A log from the vehicle and a log from the lockstep simulator
//! replay the same way, because both ran the same [`heli_fsw::FlightComputer`].

use std::collections::BTreeMap;

use heli_fsw::FlightComputer;
use heli_fsw::core::{Action, CoreConfig, FlightParams};
use heli_log::{LogContents, LoggedMessage};
use serde_json::Value;

use heli_log::inputs::{self, Logged};

/// The channels compared.
pub const COMPARED: [&str; 2] = ["servo", "state"];

/// How the flight computer of the flight was set up.
#[derive(Clone, Copy, Debug)]
pub struct ReplaySetup {
    /// Configuration.
    pub config: CoreConfig,
    /// The ground's parameters.
    pub params: FlightParams,
    /// Altimeter rate asked for (Hz).
    pub baro_rate_hz: u8,
    /// A flight process started again in the air: the record it resumed from.
    pub restart_from: Option<heli_fsw::core::WarmStart>,
}

/// Why a log cannot be replayed.
#[derive(Clone, Debug, PartialEq)]
pub enum ReplayError {
    /// The log holds no device inputs: it was written without them.
    NoInputs,
    /// A recorded servo command lacks a number.
    BadServo {
        /// Its time (s of the flight clock).
        t_s: f64,
        /// The field missing.
        field: String,
    },
    /// A recorded device input is malformed.
    BadInput {
        /// Its time (s of the flight clock).
        t_s: f64,
        /// What is wrong with it.
        why: String,
    },
}

impl std::fmt::Display for ReplayError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReplayError::NoInputs => write!(
                f,
                "the log holds no device inputs (channel 'device'): it was written without them and cannot be replayed"
            ),
            ReplayError::BadInput { t_s, why } => write!(f, "device input at t={t_s:.6} s: {why}"),
            ReplayError::BadServo { t_s, field } => {
                write!(f, "servo command at t={t_s:.6} s has no number '{field}'")
            }
        }
    }
}

impl std::error::Error for ReplayError {}

/// The first place where the replay and the log disagree.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    /// Channel.
    pub channel: String,
    /// Index of the message within its channel.
    pub index: usize,
    /// Time of the logged message (µs), if there is one.
    pub logged_t_us: Option<u64>,
    /// Time of the replayed message (µs), if there is one.
    pub replayed_t_us: Option<u64>,
    /// The fields that differ, `name: logged -> replayed`.
    pub fields: Vec<String>,
}

/// What a replay found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplayOutcome {
    /// Device inputs fed.
    pub inputs: u64,
    /// Messages compared per channel.
    pub compared: BTreeMap<String, usize>,
    /// The earliest difference (by time), if any.
    pub first_difference: Option<Difference>,
}

impl ReplayOutcome {
    /// True when every compared message matched.
    pub fn exact(&self) -> bool {
        self.first_difference.is_none() && self.compared.values().any(|n| *n > 0)
    }
}

/// Replays `contents` with `setup`. `Err` when the log holds no device inputs (it cannot
/// be replayed) or one of them is malformed.
pub fn replay(setup: &ReplaySetup, contents: &LogContents) -> Result<ReplayOutcome, ReplayError> {
    let mut computer = match setup.restart_from {
        Some(warm) => {
            FlightComputer::restarted(setup.config, setup.params, setup.baro_rate_hz, warm)
        }
        None => FlightComputer::new(setup.config, setup.params, setup.baro_rate_hz),
    };
    let mut replayed: BTreeMap<&str, Vec<(u64, Value)>> = BTreeMap::new();
    let mut outcome = ReplayOutcome::default();
    let mut actions = Vec::new();
    let mut started = false;
    for m in contents
        .messages
        .iter()
        .filter(|m| m.topic == inputs::CHANNEL)
    {
        let logged = inputs::logged_from_json(&m.value).map_err(|why| ReplayError::BadInput {
            t_s: m.t_us as f64 * 1e-6,
            why: why.to_string(),
        })?;
        actions.clear();
        match logged {
            Logged::Start => {
                started = true;
                computer.start(m.t_us, &mut |_, _| {});
            }
            Logged::Restart { warm_start } => {
                // A new computer in place of the one before (a brown-out's end in a lockstep
                // flight), from the record it started from, as the flight did.
                computer = match warm_start {
                    Some(text) => {
                        let warm = heli_vehicle::warm::WarmFile::parse(&text)
                            .map_err(|e| ReplayError::BadInput {
                                t_s: m.t_us as f64 * 1e-6,
                                why: format!("restart's warm_start: {e}"),
                            })?
                            .warm;
                        FlightComputer::restarted(
                            setup.config,
                            setup.params,
                            setup.baro_rate_hz,
                            warm,
                        )
                    }
                    None => FlightComputer::new(setup.config, setup.params, setup.baro_rate_hz),
                };
                started = true;
                computer.start(m.t_us, &mut |_, _| {});
            }
            Logged::Input(input) => {
                computer.receive(m.t_us, input.as_input(), &mut |_, _| {}, &mut actions);
                outcome.inputs = outcome.inputs.saturating_add(1);
            }
        }
        for a in &actions {
            if let Action::Publish(record) = a {
                let (topic, t_us, value) = heli_log::record_json(record);
                if let Some(channel) = COMPARED.iter().find(|c| **c == topic) {
                    replayed.entry(channel).or_default().push((t_us, value));
                }
            }
        }
    }
    if !started && outcome.inputs == 0 {
        return Err(ReplayError::NoInputs);
    }
    for channel in COMPARED {
        let logged: Vec<&LoggedMessage> = contents
            .messages
            .iter()
            .filter(|m| m.topic == channel)
            .collect();
        let ours = replayed.get(channel).map(Vec::as_slice).unwrap_or_default();
        // A log cut by a crash ends early: only what both have is compared, and anything the
        // log has that the replay does not is a difference.
        let n = logged.len().min(ours.len());
        outcome.compared.insert(channel.to_string(), n);
        let mismatch = (0..n).find(|i| {
            let (l, r) = (logged.get(*i), ours.get(*i));
            !matches!((l, r), (Some(l), Some(r)) if l.t_us == r.0 && l.value == r.1)
        });
        let index = match mismatch {
            Some(i) => Some(i),
            None if logged.len() > ours.len() => Some(n),
            None => None,
        };
        if let Some(i) = index {
            let l = logged.get(i);
            let r = ours.get(i);
            let diff = Difference {
                channel: channel.to_string(),
                index: i,
                logged_t_us: l.map(|m| m.t_us),
                replayed_t_us: r.map(|r| r.0),
                fields: differing_fields(l.map(|m| &m.value), r.map(|r| &r.1)),
            };
            let t = |d: &Difference| d.logged_t_us.or(d.replayed_t_us).unwrap_or(u64::MAX);
            if outcome
                .first_difference
                .as_ref()
                .is_none_or(|d| t(&diff) < t(d))
            {
                outcome.first_difference = Some(diff);
            }
        }
    }
    Ok(outcome)
}

fn differing_fields(logged: Option<&Value>, replayed: Option<&Value>) -> Vec<String> {
    match (logged, replayed) {
        (Some(Value::Object(l)), Some(Value::Object(r))) => l
            .iter()
            .filter(|(k, v)| r.get(*k) != Some(*v))
            .map(|(k, v)| format!("{k}: {v} -> {}", r.get(k).unwrap_or(&Value::Null)))
            .collect(),
        (Some(l), Some(r)) => vec![format!("{l} -> {r}")],
        (Some(_), None) => vec!["in the log, not produced by the replay".into()],
        (None, Some(_)) => vec!["produced by the replay, not in the log".into()],
        (None, None) => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_fsw::RecordedInput;
    use heli_proto::imu::ImuRepr;

    fn setup() -> ReplaySetup {
        ReplaySetup {
            config: CoreConfig {
                imu_warm_up_s: 0.1,
                calibration_s: 0.3,
                ..CoreConfig::default()
            },
            params: FlightParams::default(),
            baro_rate_hz: 5,
            restart_from: None,
        }
    }

    fn message(topic: &str, t_us: u64, value: Value) -> LoggedMessage {
        LoggedMessage {
            topic: topic.into(),
            t_us,
            sequence: 0,
            value,
        }
    }

    /// A second of IMU packets through a flight computer set up as `setup`, logged as the
    /// flight process logs them: the device inputs and the compared channels' records.
    fn flown(setup: &ReplaySetup) -> LogContents {
        let mut computer = FlightComputer::new(setup.config, setup.params, setup.baro_rate_hz);
        let mut contents = LogContents::default();
        contents
            .messages
            .push(message(inputs::CHANNEL, 0, inputs::start_json()));
        computer.start(0, &mut |_, _| {});
        let mut frame = [0u8; heli_proto::imu::FRAME_LEN];
        let n = ImuRepr {
            rate_rps: [0.01, 0.0, 0.0],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 30.0,
        }
        .emit(&mut frame)
        .unwrap_or(0);
        let mut actions = Vec::new();
        for k in 1..=100u64 {
            let input = RecordedInput::Bytes(heli_types::Port::Imu, frame[..n].to_vec());
            contents.messages.push(message(
                inputs::CHANNEL,
                k * 10_000,
                inputs::input_json(&input),
            ));
            actions.clear();
            computer.receive(k * 10_000, input.as_input(), &mut |_, _| {}, &mut actions);
            for a in &actions {
                if let Action::Publish(record) = a {
                    let (topic, t_us, value) = heli_log::record_json(record);
                    contents.messages.push(message(topic, t_us, value));
                }
            }
        }
        contents
    }

    fn index_of(contents: &LogContents, topic: &str, nth: usize) -> usize {
        contents
            .messages
            .iter()
            .enumerate()
            .filter(|(_, m)| m.topic == topic)
            .nth(nth)
            .map_or(usize::MAX, |(i, _)| i)
    }

    #[test]
    fn a_log_replays_exactly_on_the_software_that_wrote_it() {
        let contents = flown(&setup());
        let outcome = replay(&setup(), &contents).unwrap();
        assert_eq!(outcome.inputs, 100);
        assert_eq!(outcome.compared.get("servo"), Some(&50));
        let states = contents
            .messages
            .iter()
            .filter(|m| m.topic == "state")
            .count();
        assert!(states > 0);
        assert_eq!(outcome.compared.get("state"), Some(&states));
        assert_eq!(outcome.first_difference, None);
        assert!(outcome.exact());
    }

    #[test]
    fn a_changed_record_is_the_first_difference_with_its_fields() {
        let mut contents = flown(&setup());
        let i = index_of(&contents, "servo", 7);
        let t_us = contents.messages[i].t_us;
        let logged = contents.messages[i].value.clone();
        let field = logged
            .as_object()
            .and_then(|o| o.keys().next().cloned())
            .unwrap();
        contents.messages[i].value[&field] = serde_json::json!(12345);
        let outcome = replay(&setup(), &contents).unwrap();
        assert!(!outcome.exact());
        let d = outcome.first_difference.unwrap();
        assert_eq!((d.channel.as_str(), d.index), ("servo", 7));
        assert_eq!((d.logged_t_us, d.replayed_t_us), (Some(t_us), Some(t_us)));
        assert_eq!(
            d.fields,
            [format!("{field}: 12345 -> {}", logged[&field])],
            "only the changed field is named"
        );
    }

    #[test]
    fn the_earliest_difference_of_all_channels_is_reported() {
        let mut contents = flown(&setup());
        // A late servo record and an earlier state record changed: the state's is first.
        let late = index_of(&contents, "servo", 40);
        contents.messages[late].value = serde_json::json!({"changed": true});
        let early = index_of(&contents, "state", 2);
        let early_t = contents.messages[early].t_us;
        contents.messages[early].value = serde_json::json!(1);
        let d = replay(&setup(), &contents)
            .unwrap()
            .first_difference
            .unwrap();
        assert_eq!((d.channel.as_str(), d.index), ("state", 2));
        assert_eq!(d.logged_t_us, Some(early_t));
        assert_eq!(d.fields.len(), 1);
        assert!(d.fields[0].starts_with("1 -> {"), "{:?}", d.fields);
        // The same changes the other way round: the servo's is first.
        let mut contents = flown(&setup());
        let early = index_of(&contents, "servo", 1);
        contents.messages[early].value = serde_json::json!({"changed": true});
        let late = index_of(&contents, "state", 20);
        contents.messages[late].value = serde_json::json!(1);
        let d = replay(&setup(), &contents)
            .unwrap()
            .first_difference
            .unwrap();
        assert_eq!((d.channel.as_str(), d.index), ("servo", 1));
        // A servo and a state record of the same control step: the servo's, compared first.
        let mut contents = flown(&setup());
        let state = index_of(&contents, "state", 5);
        let t = contents.messages[state].t_us;
        let servo = contents
            .messages
            .iter()
            .position(|m| m.topic == "servo" && m.t_us == t)
            .unwrap();
        contents.messages[state].value = serde_json::json!(1);
        contents.messages[servo].value = serde_json::json!(2);
        let d = replay(&setup(), &contents)
            .unwrap()
            .first_difference
            .unwrap();
        assert_eq!((d.channel.as_str(), d.logged_t_us), ("servo", Some(t)));
    }

    #[test]
    fn a_log_cut_short_compares_what_it_has_and_one_with_more_differs() {
        // Cut by a crash: the last records missing; what is there matches.
        let mut contents = flown(&setup());
        let last_servo = index_of(&contents, "servo", 49);
        contents.messages.remove(last_servo);
        let outcome = replay(&setup(), &contents).unwrap();
        assert_eq!(outcome.compared.get("servo"), Some(&49));
        assert!(outcome.exact());
        // A record the replay never produces.
        let mut contents = flown(&setup());
        contents
            .messages
            .push(message("servo", 2_000_000, serde_json::json!({"extra": 1})));
        let d = replay(&setup(), &contents)
            .unwrap()
            .first_difference
            .unwrap();
        assert_eq!((d.channel.as_str(), d.index), ("servo", 50));
        assert_eq!((d.logged_t_us, d.replayed_t_us), (Some(2_000_000), None));
        assert_eq!(d.fields, ["in the log, not produced by the replay"]);
    }

    #[test]
    fn changed_software_is_seen_and_a_log_without_inputs_is_refused() {
        // The same inputs to a computer calibrating for longer: other servo records.
        let contents = flown(&setup());
        let longer = ReplaySetup {
            config: CoreConfig {
                calibration_s: 0.6,
                ..setup().config
            },
            ..setup()
        };
        assert!(!replay(&longer, &contents).unwrap().exact());
        // A log that ends right after the start replays, comparing nothing.
        let mut started = flown(&setup());
        started.messages.truncate(1);
        let outcome = replay(&setup(), &started).unwrap();
        assert_eq!((outcome.inputs, outcome.exact()), (0, false));
        // Nothing to feed.
        let mut bare = flown(&setup());
        bare.messages.retain(|m| m.topic != inputs::CHANNEL);
        let e = replay(&setup(), &bare).unwrap_err().to_string();
        assert!(e.contains("no device inputs"), "{e}");
        // An input that cannot be read is named with its time.
        let mut bad = flown(&setup());
        let i = index_of(&bad, inputs::CHANNEL, 3);
        bad.messages[i].value = serde_json::json!({"kind": "bytes", "port": "modem", "hex": ""});
        let e = replay(&setup(), &bad).unwrap_err().to_string();
        assert!(e.starts_with("device input at t=0.030000 s"), "{e}");
        // Compared nothing (no record of either channel): not exact.
        let mut silent = flown(&setup());
        silent.messages.retain(|m| m.topic == inputs::CHANNEL);
        let outcome = replay(&setup(), &silent).unwrap();
        assert_eq!(outcome.compared.get("servo"), Some(&0));
        assert!(!outcome.exact());
    }

    #[test]
    fn differing_fields_name_what_changed() {
        let l = serde_json::json!({"a": 1, "b": 2});
        let r = serde_json::json!({"a": 1, "b": 3});
        assert_eq!(differing_fields(Some(&l), Some(&r)), ["b: 2 -> 3"]);
        let r = serde_json::json!({"a": 1});
        assert_eq!(differing_fields(Some(&l), Some(&r)), ["b: 2 -> null"]);
        assert_eq!(
            differing_fields(Some(&serde_json::json!(1)), Some(&serde_json::json!(2))),
            ["1 -> 2"]
        );
        assert_eq!(
            differing_fields(None, Some(&l)),
            ["produced by the replay, not in the log"]
        );
        assert!(differing_fields(None, None).is_empty());
    }
}
