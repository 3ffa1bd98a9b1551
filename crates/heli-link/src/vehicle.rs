//! The vehicle's end of the link, sans-I/O: datagrams and the time go in, datagrams and the
//! thesis commands for the bootstrap come out. It sends the heartbeat (1 Hz) with the
//! bootstrap's state and the control mode, the telemetry at each message's interval, status
//! texts, command acknowledgements and the logs; it refuses and counts what the signing key
//! does not allow, and tells the ground; it notices the ground falling silent.

use std::collections::BTreeMap;

use mavlink::MessageData;
use mavlink::dialects::common::*;

use crate::command::{CMD_CONNECT, CMD_START_LOGGING, CMD_STOP, ground_command};
use crate::frame::{self, Sender};
use crate::logs::{LogServer, LogStore};
use crate::messages::GroundCommand;
use crate::mission::MissionServer;
use crate::params::{ParamTable, param_name};
use crate::signing::{Key, Refusal, Signer, Verifier, timestamp_from_unix_us};
use crate::telemetry::{self, DEFAULT_INTERVAL_US, TELEMETRY_MESSAGES, Telemetry};

pub use crate::status::{BootstrapState, VehicleStatus, chunks, heartbeat};

pub use crate::frame::VEHICLE;

mod commands;
pub use commands::autopilot_version;
/// Heartbeat period (µs).
pub const HEARTBEAT_US: u64 = 1_000_000;
/// A ground silent this long (µs) has lost the link.
pub const LINK_LOST_AFTER_US: u64 = 5_000_000;
/// Log packets sent per [`VehicleLink::tick`].
pub const LOG_PACKETS_PER_TICK: usize = 40;
/// A signed command or parameter write older than this (10 µs units: 10 s) is refused as
/// held back.
pub const COMMAND_MAX_AGE: u64 = 1_000_000;
/// The messages that change the vehicle (commands and parameter writes): a signed one is
/// obeyed only within [`COMMAND_MAX_AGE`] of its timestamp.
pub const AGE_LIMITED: [u32; 3] = [
    COMMAND_LONG_DATA::ID,
    COMMAND_INT_DATA::ID,
    PARAM_SET_DATA::ID,
];
/// A retried command (`confirmation` > 0) this soon (µs) after one finished gets its result
/// again instead of being carried out twice.
const RESULT_KEPT_US: u64 = 10_000_000;
/// Status texts about refused frames, at most one of each kind per this period (µs).
const REFUSAL_NOTICE_US: u64 = 1_000_000;

/// Something the runtime must act on.
#[derive(Clone, Debug, PartialEq)]
pub enum LinkEvent {
    /// A thesis command to carry out; answer it with [`VehicleLink::finish`].
    Command {
        /// Which command to acknowledge.
        token: CommandToken,
        /// The command.
        command: GroundCommand,
    },
    /// A frame was refused by the signing check.
    Refused {
        /// Why.
        reason: Refusal,
        /// Who sent it.
        from: Sender,
        /// Its message id.
        message_id: u32,
    },
    /// The ground fell silent.
    LinkLost,
    /// The ground is heard again.
    LinkRegained,
    /// A parameter was set (already checked); the runtime keeps the table.
    ParamSet {
        /// The whole table after the change, as its file's text.
        table_text: String,
    },
}

/// How a command the vehicle took ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CommandOutcome {
    /// Carried out; what was done.
    Accepted(String),
    /// Not carried out; why.
    Failed(String),
}

/// A command awaiting its final acknowledgement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandToken {
    command: MavCmd,
}

/// Counters of the link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames accepted.
    pub frames_in: u64,
    /// Bytes or frames that were not valid MAVLink 2 of the common dialect.
    pub malformed: u64,
    /// Frames sent.
    pub frames_out: u64,
    /// Commands received (accepted by the signing check).
    pub commands: u64,
}

/// The vehicle's link.
pub struct VehicleLink {
    out: crate::outgoing::Outgoing,
    verifier: Verifier,
    started_us: u64,
    intervals: BTreeMap<u32, Option<u64>>,
    next_due: BTreeMap<u32, u64>,
    heard_us: Option<u64>,
    lost: bool,
    /// When each kind of refusal was last told to the ground.
    last_refusal_notice_us: BTreeMap<&'static str, u64>,
    logs: LogServer,
    params: ParamTable,
    mission: MissionServer,
    /// The last status the runtime gave ([`VehicleLink::tick`]).
    status: VehicleStatus,
    /// The thesis command being carried out.
    pending: Option<MavCmd>,
    /// The last thesis command answered: which, its result, when.
    last_result: Option<(MavCmd, MavResult, u64)>,
    outbox: Vec<Vec<u8>>,
    replies: Vec<Vec<u8>>,
    /// Counters.
    pub stats: LinkStats,
}

impl VehicleLink {
    /// A link signing with `key` (and refusing what is not signed with it), or open without.
    pub fn new(key: Option<Key>, now_us: u64) -> Self {
        let intervals = TELEMETRY_MESSAGES
            .iter()
            .filter(|&&id| id != HEARTBEAT_DATA::ID)
            .map(|&id| (id, Some(DEFAULT_INTERVAL_US)))
            .collect();
        Self {
            out: crate::outgoing::Outgoing::new(VEHICLE, key.clone().map(|k| Signer::new(k, 0))),
            verifier: Verifier::new(key),
            started_us: now_us,
            intervals,
            next_due: BTreeMap::new(),
            heard_us: None,
            lost: false,
            last_refusal_notice_us: BTreeMap::new(),
            logs: LogServer::default(),
            params: ParamTable::new(&[]),
            mission: MissionServer::default(),
            status: VehicleStatus::default(),
            pending: None,
            last_result: None,
            outbox: Vec::new(),
            replies: Vec::new(),
            stats: LinkStats::default(),
        }
    }

    /// The link serves `params` with the parameter protocol.
    pub fn with_params(mut self, params: ParamTable) -> Self {
        self.params = params;
        self
    }

    /// Puts back `params` (the runtime could not keep a change).
    pub fn replace_params(&mut self, params: ParamTable) {
        self.params = params;
    }

    /// The parameters as they are now.
    pub fn params(&self) -> &ParamTable {
        &self.params
    }

    /// Whether a log is being sent (the runtime should tick often meanwhile).
    pub fn sending_log(&self) -> bool {
        self.logs.busy()
    }

    /// Whether commands must be signed.
    pub fn signed(&self) -> bool {
        self.verifier.has_key()
    }

    /// Frames refused by the signing check, by reason.
    pub fn refused(&self) -> crate::signing::RefusalCounts {
        self.verifier.refused
    }

    /// The datagrams to send, taken.
    pub fn take_outgoing(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.outbox)
    }

    /// The datagrams for the sender of the datagram just received, taken: a ground that
    /// holds the key but whose frame was refused for its timestamp (its clock, or another
    /// ground on its stream) is told why, though it is no peer; at most one answer of each
    /// kind a second. A sender without the key is told nothing.
    pub fn take_replies(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.replies)
    }

    /// Queues `message`.
    pub fn send(&mut self, message: &MavMessage, now_us: u64) {
        let bytes = self.out.encode(message, now_us);
        self.stats.frames_out = self.stats.frames_out.saturating_add(1);
        self.outbox.push(bytes);
    }

    /// Queues a status text, cut into pieces of a STATUSTEXT's 50 bytes that join back to it
    /// exactly ([`chunks`]: after a space, or full).
    pub fn status_text(&mut self, severity: MavSeverity, text: &str, now_us: u64) {
        let frames = self.status_frames(severity, text, now_us);
        self.outbox.extend(frames);
    }

    /// A status text's frames (see [`VehicleLink::status_text`]).
    fn status_frames(&mut self, severity: MavSeverity, text: &str, now_us: u64) -> Vec<Vec<u8>> {
        chunks(text, 50)
            .into_iter()
            .map(|chunk| {
                let msg = MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                    severity,
                    text: chunk.as_str().into(),
                });
                self.stats.frames_out = self.stats.frames_out.saturating_add(1);
                self.out.encode(&msg, now_us)
            })
            .collect()
    }

    /// Handles one datagram; returns what the runtime must act on.
    pub fn receive(
        &mut self,
        datagram: &[u8],
        now_us: u64,
        store: &dyn LogStore,
    ) -> Vec<LinkEvent> {
        let mut events = Vec::new();
        for result in frame::split(datagram) {
            let raw = match result {
                Ok(raw) => raw,
                Err(_) => {
                    self.stats.malformed = self.stats.malformed.saturating_add(1);
                    continue;
                }
            };
            if raw.sender == VEHICLE {
                // Our own frames come back only by reflection: never a ground's.
                self.stats.malformed = self.stats.malformed.saturating_add(1);
                continue;
            }
            let now_ts = timestamp_from_unix_us(now_us);
            let signed_ts = match self.verifier.check(&raw, now_ts) {
                Ok(ts) => ts,
                Err(reason) => {
                    self.refuse(reason, &raw, now_us, &mut events);
                    continue;
                }
            };
            // A signed command or parameter write held back and let go later (an operator's
            // Stop delivered in the middle of the next flight; a recorded PARAM_SET sent as
            // the first frame after a restart) is too old to obey.
            let clock = self.verifier.clock(now_ts);
            let held_back = signed_ts.is_some_and(|ts| ts.saturating_add(COMMAND_MAX_AGE) < clock)
                && AGE_LIMITED.contains(&raw.message_id);
            if held_back {
                self.verifier.refused.count(Refusal::Stale);
                self.refuse(Refusal::Stale, &raw, now_us, &mut events);
                continue;
            }
            let Ok(message) = raw.message() else {
                self.stats.malformed = self.stats.malformed.saturating_add(1);
                continue;
            };
            self.stats.frames_in = self.stats.frames_in.saturating_add(1);
            self.heard_us = Some(now_us);
            if self.lost {
                self.lost = false;
                events.push(LinkEvent::LinkRegained);
            }
            self.handle(message, now_us, store, &mut events);
        }
        events
    }

    fn refuse(
        &mut self,
        reason: Refusal,
        raw: &frame::RawFrame,
        now_us: u64,
        events: &mut Vec<LinkEvent>,
    ) {
        self.note_refusal(reason, raw, now_us);
        events.push(LinkEvent::Refused {
            reason,
            from: raw.sender,
            message_id: raw.message_id,
        });
    }

    fn note_refusal(&mut self, reason: Refusal, raw: &frame::RawFrame, now_us: u64) {
        // One status text per kind of refusal per second: a flood of bad frames does not
        // flood the ground, and one kind does not hide another.
        let due = self
            .last_refusal_notice_us
            .get(reason.text())
            .is_none_or(|t| now_us.saturating_sub(*t) >= REFUSAL_NOTICE_US);
        if due {
            let text = format!(
                "refused {} msg {} from {}/{} link {} (#{}): {}",
                reason.text(),
                raw.message_id,
                raw.sender.system,
                raw.sender.component,
                raw.signing_link_id()
                    .map_or_else(|| "-".to_string(), |l| l.to_string()),
                self.verifier.refused.total(),
                reason.cause()
            );
            self.status_text(MavSeverity::MAV_SEVERITY_WARNING, &text, now_us);
            if reason.keyed() {
                let frames = self.status_frames(MavSeverity::MAV_SEVERITY_WARNING, &text, now_us);
                self.replies.extend(frames);
            }
            self.last_refusal_notice_us.insert(reason.text(), now_us);
        }
    }

    fn handle(
        &mut self,
        message: MavMessage,
        now_us: u64,
        store: &dyn LogStore,
        events: &mut Vec<LinkEvent>,
    ) {
        match message {
            MavMessage::COMMAND_LONG(cmd) => {
                if !for_us(cmd.target_system) {
                    return;
                }
                self.stats.commands = self.stats.commands.saturating_add(1);
                self.command(&cmd, now_us, events);
            }
            MavMessage::LOG_REQUEST_LIST(r) if for_us(r.target_system) => {
                let listing = store.list();
                for entry in LogServer::entries(&listing.logs, r.start, r.end) {
                    self.send(&entry, now_us);
                }
                // What the list lacks, and why, after it.
                for problem in &listing.problems {
                    self.status_text(
                        MavSeverity::MAV_SEVERITY_ERROR,
                        &format!("log list: {problem}"),
                        now_us,
                    );
                }
            }
            MavMessage::LOG_REQUEST_DATA(r) if for_us(r.target_system) => {
                let listing = store.list();
                if let Some(said) = self.logs.request(&listing.logs, r.id, r.ofs, r.count) {
                    self.status_text(MavSeverity::MAV_SEVERITY_ERROR, &said, now_us);
                }
            }
            MavMessage::LOG_REQUEST_END(r) if for_us(r.target_system) => self.logs.end(),
            MavMessage::PARAM_REQUEST_LIST(r) if for_us(r.target_system) => {
                let all: Vec<MavMessage> = (0..self.params.iter().count())
                    .filter_map(|i| self.params.value_message(i))
                    .collect();
                for m in all {
                    self.send(&m, now_us);
                }
            }
            MavMessage::PARAM_REQUEST_READ(r) if for_us(r.target_system) => {
                let msg = match usize::try_from(r.param_index) {
                    Ok(i) => self.params.value_message(i),
                    Err(_) => self.params.value_message_named(&param_name(&r.param_id)),
                };
                match msg {
                    Some(m) => self.send(&m, now_us),
                    None => self.status_text(
                        MavSeverity::MAV_SEVERITY_ERROR,
                        &format!("param {}: no such parameter", param_name(&r.param_id)),
                        now_us,
                    ),
                }
            }
            MavMessage::PARAM_SET(p) if for_us(p.target_system) => {
                self.param_set(&param_name(&p.param_id), p.param_value, now_us, events)
            }
            // The mission protocol: the flight's plan, for a ground to draw.
            other if mavlink::Message::target_system_id(&other).is_some_and(for_us) => {
                if let Some(answer) = self.mission.answer(&other) {
                    self.send(&answer, now_us);
                }
            }
            // Heartbeats keep the link alive (above); everything else is not for us.
            _ => {}
        }
    }

    /// Whether a ground station has been heard in the last [`LINK_LOST_AFTER_US`] at `now_us`.
    pub fn ground_fresh(&self, now_us: u64) -> bool {
        self.heard_us
            .is_some_and(|heard| now_us.saturating_sub(heard) <= LINK_LOST_AFTER_US)
    }

    /// The plan of the flight under way, served over the mission protocol (empty: none).
    pub fn set_mission(&mut self, items: Vec<MISSION_ITEM_INT_DATA>) {
        self.mission.set(items);
    }

    /// Time passes: heartbeat, telemetry due, log packets, link-loss check.
    pub fn tick(
        &mut self,
        now_us: u64,
        status: VehicleStatus,
        telemetry: Option<&Telemetry>,
        store: &dyn LogStore,
    ) -> Vec<LinkEvent> {
        let mut events = Vec::new();
        // The phase flown, from the flight process's telemetry (none without a flight): the
        // flight core's now, whether or not its estimate is current.
        let status = VehicleStatus {
            phase: telemetry
                .and_then(telemetry::phase_now)
                .map_or(0, crate::status::phase_code),
            ..status
        };
        // A change of state, mode or phase goes out at once, not at the next beat: the
        // ground's display follows the vehicle within the link's latency (the beat's 1 Hz
        // cadence starts again from it).
        let changed = status != self.status;
        self.status = status;
        if changed {
            self.next_due
                .insert(HEARTBEAT_DATA::ID, now_us.saturating_add(HEARTBEAT_US));
            // And the sensors' state with it (when streamed): a flight process that ended or
            // has only begun has no devices to speak for, and the ground must not go on
            // showing the last one's as healthy until their messages age.
            if self.next_due.contains_key(&SYS_STATUS_DATA::ID) {
                self.next_due.insert(SYS_STATUS_DATA::ID, now_us);
            }
        }
        if changed || self.due(HEARTBEAT_DATA::ID, Some(HEARTBEAT_US), now_us) {
            let hb = heartbeat(status);
            self.send(&hb, now_us);
        }
        let boot_ms = u32::try_from(now_us.saturating_sub(self.started_us) / 1000).unwrap_or(0);
        let ids: Vec<(u32, Option<u64>)> = self.intervals.iter().map(|(k, v)| (*k, *v)).collect();
        for (id, interval) in ids {
            if !self.due(id, interval, now_us) {
                continue;
            }
            let msg = telemetry
                .and_then(|t| telemetry::message(id, t, boot_ms))
                .or_else(|| {
                    (id == SYS_STATUS_DATA::ID)
                        .then(|| telemetry::message(id, &Telemetry::default(), boot_ms))
                        .flatten()
                });
            if let Some(mut msg) = msg {
                if let MavMessage::SYS_STATUS(st) = &mut msg {
                    // The link's own health: frames refused by the signing check, and
                    // datagrams that were not valid MAVLink.
                    let errors = self
                        .verifier
                        .refused
                        .total()
                        .saturating_add(self.stats.malformed);
                    st.errors_comm = u16::try_from(errors).unwrap_or(u16::MAX);
                }
                self.send(&msg, now_us);
                if id == BATTERY_STATUS_DATA::ID {
                    let with = telemetry
                        .map(|t| {
                            let mut m = telemetry::board_batteries(t);
                            m.extend(telemetry::power_values(t, boot_ms));
                            m
                        })
                        .unwrap_or_default();
                    for board in with {
                        self.send(&board, now_us);
                    }
                }
            }
        }
        let (packets, said) = self.logs.next_packets(store, LOG_PACKETS_PER_TICK);
        for packet in packets {
            self.send(&packet, now_us);
        }
        if let Some(text) = said {
            self.status_text(MavSeverity::MAV_SEVERITY_ERROR, &text, now_us);
        }
        let silent = self
            .heard_us
            .is_some_and(|heard| now_us.saturating_sub(heard) > LINK_LOST_AFTER_US);
        if silent && !self.lost {
            self.lost = true;
            events.push(LinkEvent::LinkLost);
        }
        events
    }

    /// Whether message `id` with `interval` is due at `now_us` (and books the next time).
    fn due(&mut self, id: u32, interval: Option<u64>, now_us: u64) -> bool {
        let Some(interval) = interval else {
            return false;
        };
        let next = self.next_due.get(&id).copied().unwrap_or(now_us);
        if now_us < next {
            return false;
        }
        // Keep the cadence; after a long pause start again from now.
        let following = next.saturating_add(interval);
        self.next_due.insert(
            id,
            if following <= now_us {
                now_us.saturating_add(interval)
            } else {
                following
            },
        );
        true
    }
}

/// Whether a message addressed to `target_system` is for this vehicle (0: for all).
fn for_us(target_system: u8) -> bool {
    target_system == VEHICLE.system || target_system == 0
}

#[cfg(test)]
#[path = "vehicle_tests.rs"]
mod tests;
