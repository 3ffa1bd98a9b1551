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
pub fn replay(setup: &ReplaySetup, contents: &LogContents) -> Result<ReplayOutcome, String> {
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
        let logged = inputs::logged_from_json(&m.value)
            .map_err(|e| format!("device input at t={:.6} s: {e}", m.t_us as f64 * 1e-6))?;
        actions.clear();
        match logged {
            Logged::Start => {
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
        return Err(
            "the log holds no device inputs (channel 'device'): it was written without them and cannot be replayed"
                .into(),
        );
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
