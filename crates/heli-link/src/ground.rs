//! The ground's end of the link, sans-I/O: the client library of `heli ground` and of its
//! web display (`heli_ground::station`). It sends the ground's heartbeat, commands (resent until
//! acknowledged), message-interval requests and log requests; it keeps the vehicle's last
//! heartbeat, the newest telemetry message of each kind with counts, the status texts, and
//! downloads a log, asking again for whatever did not arrive.

use std::collections::BTreeMap;

use mavlink::dialects::common::*;

use crate::frame::{self, VEHICLE};
use crate::logs::LOG_DATA_LEN;
use crate::signing::{Key, Signer, Verifier, timestamp_from_unix_us};

pub use crate::frame::GROUND;
/// A command not acknowledged within this time (µs) is sent again.
pub const COMMAND_RETRY_US: u64 = 500_000;
/// Largest log the ground downloads (bytes): it holds the log in memory.
pub const MAX_DOWNLOAD_BYTES: u32 = 1 << 30;
/// A download with nothing new for this long (µs) asks again for what is missing.
pub const DOWNLOAD_RETRY_US: u64 = 300_000;

/// A log being downloaded.
#[derive(Clone, Debug)]
pub struct Download {
    /// Log id.
    pub id: u16,
    /// Its size (bytes).
    pub size: u32,
    /// The bytes so far.
    pub bytes: Vec<u8>,
    /// Which 90-byte blocks have arrived.
    have: Vec<bool>,
    last_progress_us: u64,
    /// Where the current request ends (bytes).
    request_end: u32,
    /// The current request's last packet has come: what is still missing was lost.
    request_done: bool,
    /// Requests sent (the first and each ask for a missing part).
    pub requests: u64,
    /// The vehicle's word that it cannot serve this log, and when it came (µs).
    vehicle_said: Option<(u64, String)>,
}

impl Download {
    fn new(id: u16, size: u32, now_us: u64) -> Self {
        let blocks = usize::try_from(size).unwrap_or(0).div_ceil(LOG_DATA_LEN);
        Self {
            id,
            size,
            bytes: vec![0; usize::try_from(size).unwrap_or(0)],
            have: vec![false; blocks],
            last_progress_us: now_us,
            request_end: size,
            request_done: false,
            requests: 0,
            vehicle_said: None,
        }
    }

    /// The vehicle's word that it cannot serve this log (a read that fails, no such log, a
    /// file cut since it was listed), and when it came (µs).
    pub fn vehicle_said(&self) -> Option<&(u64, String)> {
        self.vehicle_said.as_ref()
    }

    /// Bytes received.
    pub fn received(&self) -> u64 {
        let full = self.have.iter().filter(|h| **h).count();
        (full.saturating_mul(LOG_DATA_LEN) as u64).min(u64::from(self.size))
    }

    /// Whether every byte has arrived.
    pub fn complete(&self) -> bool {
        self.have.iter().all(|h| *h)
    }

    /// The first missing run of blocks: (offset, count) in bytes.
    fn first_gap(&self) -> Option<(u32, u32)> {
        let start = self.have.iter().position(|h| !h)?;
        let len = self
            .have
            .get(start..)
            .unwrap_or(&[])
            .iter()
            .take_while(|h| !**h)
            .count();
        let ofs = start.saturating_mul(LOG_DATA_LEN);
        let count = len.saturating_mul(LOG_DATA_LEN);
        Some((
            u32::try_from(ofs).unwrap_or(u32::MAX),
            u32::try_from(count).unwrap_or(u32::MAX),
        ))
    }

    fn accept(&mut self, d: &LOG_DATA_DATA, now_us: u64) {
        let ofs = usize::try_from(d.ofs).unwrap_or(usize::MAX);
        let n = usize::from(d.count).min(LOG_DATA_LEN);
        // The last packet of the current request (or the end-of-file marker): whatever is
        // still missing was lost, and can be asked for at once.
        if d.ofs.saturating_add(u32::from(d.count)) >= self.request_end
            || usize::from(d.count) < LOG_DATA_LEN
        {
            self.request_done = true;
        }
        if ofs % LOG_DATA_LEN != 0 || n == 0 {
            return;
        }
        let block = ofs / LOG_DATA_LEN;
        let end = ofs.saturating_add(n);
        let expected = self.bytes.len().saturating_sub(ofs).min(LOG_DATA_LEN);
        if n != expected {
            return;
        }
        if let (Some(dst), Some(src)) = (self.bytes.get_mut(ofs..end), d.data.get(..n)) {
            dst.copy_from_slice(src);
            if let Some(h) = self.have.get_mut(block).filter(|h| !**h) {
                *h = true;
                self.last_progress_us = now_us;
            }
        }
    }
}

/// The ground's link.
pub struct GroundLink {
    link_id: u8,
    out: crate::outgoing::Outgoing,
    verifier: Verifier,
    /// The vehicle's last heartbeat and when it came (µs).
    pub heartbeat: Option<(u64, HEARTBEAT_DATA)>,
    /// The newest message of each id.
    pub latest: BTreeMap<u32, (u64, MavMessage)>,
    /// Messages received, by id.
    pub counts: BTreeMap<u32, u64>,
    /// Status texts received (severity, text), oldest first.
    pub texts: Vec<(MavSeverity, String)>,
    /// Acknowledgements received (command, result), oldest first.
    pub acks: Vec<(MavCmd, MavResult)>,
    /// Log entries received, by id.
    pub log_entries: BTreeMap<u16, LOG_ENTRY_DATA>,
    /// The download under way.
    pub download: Option<Download>,
    /// Parameters received (`PARAM_VALUE`), by name: value, index and count.
    pub params: BTreeMap<String, (f32, u16, u16)>,
    /// The newest `BATTERY_STATUS` of each battery id (the flight battery and the servo
    /// board's two), with the time it came.
    pub batteries: BTreeMap<u8, (u64, BATTERY_STATUS_DATA)>,
    /// The newest `NAMED_VALUE_FLOAT` of each name (the power values,
    /// [`crate::telemetry::power_values`]), with the time it came.
    pub named: BTreeMap<String, (u64, f32)>,
    /// Frames that were not valid, or refused by the signing check.
    pub bad_frames: u64,
    /// The start of a status text continued in the next one: severity, text, when it came.
    partial_text: Option<(MavSeverity, String, u64)>,
    /// The flight plan being fetched over the mission protocol.
    pub mission: crate::mission::MissionClient,
}

/// A status text's continuation that has not come for this long (µs) is given up: the part
/// received is kept as it is.
pub const TEXT_JOIN_US: u64 = 1_000_000;

impl GroundLink {
    /// A ground link signing with `key` on link id 1 (and refusing what the vehicle did not
    /// sign with it).
    pub fn new(key: Option<Key>) -> Self {
        Self::on_link(key, 1)
    }

    /// A ground link signing with `key` on `link_id`: each ground process its own, so that
    /// two grounds signing at once are two streams, not one that looks replayed (the vehicle
    /// signs on link 0).
    pub fn on_link(key: Option<Key>, link_id: u8) -> Self {
        Self {
            link_id,
            out: crate::outgoing::Outgoing::new(
                GROUND,
                key.clone().map(|k| Signer::new(k, link_id)),
            ),
            verifier: Verifier::new(key),
            heartbeat: None,
            latest: BTreeMap::new(),
            counts: BTreeMap::new(),
            texts: Vec::new(),
            acks: Vec::new(),
            log_entries: BTreeMap::new(),
            download: None,
            params: BTreeMap::new(),
            batteries: BTreeMap::new(),
            named: BTreeMap::new(),
            bad_frames: 0,
            partial_text: None,
            mission: crate::mission::MissionClient::default(),
        }
    }

    /// The link id this ground signs on.
    pub fn link_id(&self) -> u8 {
        self.link_id
    }

    /// The vehicle's newest word on refusing this ground's own frames (its signing stream:
    /// system, component and link id), which names the cause: the key, or a clock.
    pub fn refusal_of_ours(&self) -> Option<&str> {
        let ours = format!(
            "from {}/{} link {} ",
            GROUND.system, GROUND.component, self.link_id
        );
        self.texts
            .iter()
            .rev()
            .map(|(_, t)| t.as_str())
            .find(|t| t.starts_with("refused ") && t.contains(&ours))
    }

    /// The bytes of `message`, signed if a key is set.
    pub fn encode(&mut self, message: &MavMessage, now_us: u64) -> Vec<u8> {
        self.out.encode(message, now_us)
    }

    /// The ground's heartbeat.
    pub fn heartbeat_frame(&mut self, now_us: u64) -> Vec<u8> {
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_GCS,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        });
        self.encode(&hb, now_us)
    }

    /// A command to the vehicle.
    pub fn command_frame(&mut self, mut command: COMMAND_LONG_DATA, now_us: u64) -> Vec<u8> {
        command.target_system = VEHICLE.system;
        command.target_component = VEHICLE.component;
        self.encode(&MavMessage::COMMAND_LONG(command), now_us)
    }

    /// The final acknowledgement of `command` received so far (not `IN_PROGRESS`).
    pub fn final_ack(&self, command: MavCmd) -> Option<MavResult> {
        self.acks
            .iter()
            .rev()
            .find(|(c, r)| *c == command && *r != MavResult::MAV_RESULT_IN_PROGRESS)
            .map(|(_, r)| *r)
    }

    /// Handles one datagram from the vehicle.
    pub fn receive(&mut self, datagram: &[u8], now_us: u64) {
        for result in frame::split(datagram) {
            let Ok(raw) = result else {
                self.bad_frames = self.bad_frames.saturating_add(1);
                continue;
            };
            // Only the vehicle's frames: a copy of our own reflected back, or another
            // ground's, is not the vehicle speaking.
            if raw.sender != VEHICLE
                || self
                    .verifier
                    .check(&raw, timestamp_from_unix_us(now_us))
                    .is_err()
            {
                self.bad_frames = self.bad_frames.saturating_add(1);
                continue;
            }
            let Ok(message) = raw.message() else {
                self.bad_frames = self.bad_frames.saturating_add(1);
                continue;
            };
            let id = mavlink::Message::message_id(&message);
            self.mission.receive(&message);
            let count = self.counts.entry(id).or_insert(0);
            *count = count.saturating_add(1);
            match &message {
                MavMessage::HEARTBEAT(hb) => self.heartbeat = Some((now_us, hb.clone())),
                MavMessage::STATUSTEXT(t) => {
                    self.status_text(t.severity, t.text.to_str().unwrap_or("(not UTF-8)"), now_us)
                }
                MavMessage::COMMAND_ACK(a) => self.acks.push((a.command, a.result)),
                MavMessage::BATTERY_STATUS(b) => {
                    self.batteries.insert(b.id, (now_us, b.clone()));
                }
                MavMessage::LOG_ENTRY(e) => {
                    self.log_entries.insert(e.id, e.clone());
                }
                MavMessage::NAMED_VALUE_FLOAT(v) => {
                    let name = v.name.to_str().unwrap_or("").to_string();
                    if !name.is_empty() {
                        self.named.insert(name, (now_us, v.value));
                    }
                }
                MavMessage::PARAM_VALUE(p) => {
                    self.params.insert(
                        crate::params::param_name(&p.param_id),
                        (p.param_value, p.param_index, p.param_count),
                    );
                }
                MavMessage::LOG_DATA(d) => {
                    if let Some(dl) = self.download.as_mut().filter(|dl| dl.id == d.id) {
                        dl.accept(d, now_us);
                    }
                }
                _ => {}
            }
            self.latest.insert(id, (now_us, message));
        }
    }

    /// A status text: joined to the one before when that one said it continues (it ended
    /// with a space, or was full).
    fn status_text(&mut self, severity: MavSeverity, text: &str, now_us: u64) {
        let mut whole = match self.partial_text.take() {
            Some((_, start, _)) => start,
            None => String::new(),
        };
        whole.push_str(text);
        // A piece cut inside a word is full (`status::chunks`).
        if text.ends_with(' ') || text.len() >= 50 {
            self.partial_text = Some((severity, whole, now_us));
        } else {
            self.text_whole(severity, whole, now_us);
        }
    }

    /// A whole status text: kept, and, when it says the log being downloaded cannot be
    /// served, noted on the download.
    fn text_whole(&mut self, severity: MavSeverity, text: String, now_us: u64) {
        if let Some(dl) = self.download.as_mut()
            && crate::logs::unservable(&text) == Some(dl.id)
        {
            dl.vehicle_said = Some((now_us, text.clone()));
        }
        self.texts.push((severity, text));
    }

    /// Keeps a status text whose continuation has not come within [`TEXT_JOIN_US`].
    pub fn flush_texts(&mut self, now_us: u64) {
        if let Some((severity, text, at)) = self.partial_text.take() {
            if now_us.saturating_sub(at) >= TEXT_JOIN_US {
                self.text_whole(severity, text.trim_end().to_string(), now_us);
            } else {
                self.partial_text = Some((severity, text, at));
            }
        }
    }

    /// Starts downloading log `id` of `size` bytes (at most [`MAX_DOWNLOAD_BYTES`]); returns
    /// the request to send.
    pub fn start_download(&mut self, id: u16, size: u32, now_us: u64) -> Vec<u8> {
        let size = size.min(MAX_DOWNLOAD_BYTES);
        let mut dl = Download::new(id, size, now_us);
        dl.requests = 1;
        self.download = Some(dl);
        let req = MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs: 0,
            count: size,
            id,
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
        });
        self.encode(&req, now_us)
    }

    /// The request for the download's first missing part, when its last request has ended
    /// with parts missing, or when nothing new has come for [`DOWNLOAD_RETRY_US`].
    pub fn download_tick(&mut self, now_us: u64) -> Option<Vec<u8>> {
        let dl = self.download.as_mut()?;
        if dl.complete() {
            return None;
        }
        let stalled = now_us.saturating_sub(dl.last_progress_us) >= DOWNLOAD_RETRY_US;
        if !(dl.request_done || stalled) {
            return None;
        }
        let (ofs, count) = dl.first_gap()?;
        dl.last_progress_us = now_us;
        dl.request_done = false;
        dl.request_end = ofs.saturating_add(count);
        dl.requests = dl.requests.saturating_add(1);
        let id = dl.id;
        let req = MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs,
            count,
            id,
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
        });
        Some(self.encode(&req, now_us))
    }

    /// The next request for the flight plan (mission protocol), if one is due.
    pub fn mission_tick(&mut self, now_us: u64) -> Option<Vec<u8>> {
        let request = self.mission.request(now_us)?;
        Some(self.encode(&request, now_us))
    }

    /// The request for the vehicle's log list.
    pub fn log_list_frame(&mut self, now_us: u64) -> Vec<u8> {
        let req = MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
            start: 0,
            end: 0xFFFF,
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
        });
        self.encode(&req, now_us)
    }

    /// The request for every parameter.
    pub fn param_list_frame(&mut self, now_us: u64) -> Vec<u8> {
        let req = MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
        });
        self.encode(&req, now_us)
    }

    /// Sets parameter `name` to `value`.
    pub fn param_set_frame(&mut self, name: &str, value: f32, now_us: u64) -> Vec<u8> {
        let req = MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: value,
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
            param_id: name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        });
        self.encode(&req, now_us)
    }

    /// The request that ends a log transfer on the vehicle.
    pub fn log_end_frame(&mut self, now_us: u64) -> Vec<u8> {
        let req = MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
            target_system: VEHICLE.system,
            target_component: VEHICLE.component,
        });
        self.encode(&req, now_us)
    }
}
