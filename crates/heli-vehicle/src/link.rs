//! The bootstrap's MAVLink link (`heli vehicle --link udp:HOST:PORT`): a thread that serves
//! [`heli_link::vehicle::VehicleLink`] on a UDP socket. Datagrams from any ground station
//! are taken; what the vehicle sends goes to every ground heard in the last
//! [`PEER_TIMEOUT`]. The thesis commands go to the bootstrap like the control socket's, and
//! their replies become the commands' acknowledgements; the bootstrap's and the flight
//! process's lines become status texts; the flight process's telemetry feeds the link's
//! messages. Losing the link changes nothing on board but a reported event.

use std::collections::{BTreeMap, VecDeque};
use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use heli_link::logs::{Listing, LogInfo, LogStore};
use heli_link::signing::Key;
use heli_link::telemetry::Telemetry;
use heli_link::vehicle::{BootstrapState, LinkEvent, VehicleLink, VehicleStatus};
use mavlink::dialects::common::MavSeverity;

use heli_fsw::core::Severity;
use heli_types::{FlightMode, Leg};
use serde::Deserialize;

use crate::bootstrap::{LinkPort, Said, State};
use crate::ctl::{Reply, Request, RequestHandle};
use crate::supervisor::FromFlight;

/// A ground not heard for this long is no longer sent to.
pub const PEER_TIMEOUT: Duration = Duration::from_secs(10);
/// Most ground stations sent to at once (the one heard longest ago makes room).
pub const MAX_PEERS: usize = 8;
/// The link thread's longest wait for a datagram.
const TICK: Duration = Duration::from_millis(10);
/// Most datagrams taken in one pass of the link's loop: a flood of them (garbage, frames
/// signed with another key) cannot keep the loop from its heartbeats, telemetry and
/// answers; what the kernel's buffer cannot hold meanwhile is dropped there.
pub const MAX_DATAGRAMS_PER_PASS: usize = 64;
/// Most status texts waiting to be sent (older ones are dropped first).
const MAX_QUEUED_TEXTS: usize = 200;

/// What the bootstrap shares with its link thread.
#[derive(Default)]
pub struct LinkShared {
    inner: Mutex<Shared>,
}

#[derive(Default)]
struct Shared {
    status: VehicleStatus,
    telemetry: Option<Telemetry>,
    texts: VecDeque<(MavSeverity, String)>,
    /// Why the flight process's telemetry could not be read (said once a flight process).
    telemetry_unreadable: Option<String>,
    /// A ground station heard recently (the link thread keeps it).
    ground_fresh: bool,
    /// The plan of the flight under way as mission items, when it changed (taken by the
    /// link thread).
    mission: Option<Vec<mavlink::dialects::common::MISSION_ITEM_INT_DATA>>,
}

impl LinkShared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether a ground station has been heard in the last few seconds (the link thread
    /// says so; the bootstrap tells the flight process).
    pub fn set_ground_fresh(&self, fresh: bool) {
        self.lock().ground_fresh = fresh;
    }

    /// What the bootstrap reported, to go to the ground as a status text.
    pub fn said(&self, said: &Said) {
        let severity = mav_severity(said);
        let text = said.to_string();
        let mut shared = self.lock();
        if shared.texts.len() >= MAX_QUEUED_TEXTS {
            shared.texts.pop_front();
        }
        shared.texts.push_back((severity, text));
    }
}

impl LinkPort for LinkShared {
    /// The bootstrap's state changed; `flying` is the mode of the flight under way.
    fn set_state(&self, state: State, flying: Option<FlightMode>) {
        let state = match state {
            State::Idle => BootstrapState::Idle,
            State::Connecting => BootstrapState::Connecting,
            State::Connected => BootstrapState::Connected,
            State::Starting => BootstrapState::Starting,
            State::Flying => BootstrapState::Flying,
            // Landing shows as stopping; the heartbeat's phase says `land`.
            State::Stopping | State::Landing => BootstrapState::Stopping,
        };
        let mode = flying.map_or(0, heli_link::status::mode_code);
        let mut shared = self.lock();
        let tested = shared.status.tested;
        shared.status = VehicleStatus {
            state,
            mode,
            tested,
            ..VehicleStatus::default()
        };
        // A flight process gone or not yet flying has no telemetry: the last one's values
        // must not go on being sent as if fresh.
        if matches!(state, BootstrapState::Idle | BootstrapState::Connecting) {
            shared.telemetry = None;
            shared.telemetry_unreadable = None;
            shared.mission = Some(Vec::new());
        }
    }

    /// Whether the configuration is lab-tested: in every heartbeat from now on.
    fn set_tested(&self, tested: heli_link::status::Tested) {
        self.lock().status.tested = tested;
    }

    /// Whether a ground station has been heard in the last few seconds.
    fn ground_fresh(&self) -> bool {
        self.lock().ground_fresh
    }

    /// The flight process's plan: served over the mission protocol.
    fn set_plan(&self, legs: &[Leg]) {
        self.lock().mission = Some(heli_link::mission::mission_items(legs));
    }

    /// The flight process's telemetry snapshot; one the link cannot read is said, once
    /// per flight process, and not sent.
    fn set_telemetry(&self, values: &serde_json::Value) {
        match Telemetry::deserialize(values) {
            Ok(t) => self.lock().telemetry = Some(t),
            Err(e) => {
                let mut shared = self.lock();
                if shared.telemetry_unreadable.is_none() {
                    shared.telemetry_unreadable = Some(e.to_string());
                    drop(shared);
                    self.said(&Said::Link {
                        severity: Severity::WarningLo,
                        text: format!("telemetry not sent: {e}"),
                    });
                }
            }
        }
    }
}

/// The MAVLink severity of what the bootstrap reported.
fn mav_severity(said: &Said) -> MavSeverity {
    match said.severity() {
        Severity::Fatal => MavSeverity::MAV_SEVERITY_CRITICAL,
        // The bootstrap's own trouble (a restart that failed, a refused flight process)
        // is an error of the vehicle; a flight's is a warning.
        Severity::WarningHi if !matches!(said, Said::Flight(FromFlight::Event { .. })) => {
            MavSeverity::MAV_SEVERITY_ERROR
        }
        Severity::WarningHi => MavSeverity::MAV_SEVERITY_WARNING,
        Severity::WarningLo => MavSeverity::MAV_SEVERITY_NOTICE,
        Severity::ActivityHi | Severity::ActivityLo => MavSeverity::MAV_SEVERITY_INFO,
    }
}

/// The flight logs of the vehicle's log directories (`*.mcap`, numbered from 1 by name):
/// the log directory and the fallback directory, where a flight logs when the log
/// directory refuses its log (a full or read-only disk) — a log there is downloaded as any
/// other, before a power-off loses it. A name in both is the log directory's.
pub struct DirStore {
    dirs: Vec<PathBuf>,
    /// The log being read, kept open between packets (a transfer reads it 90 bytes at a time).
    open: std::cell::RefCell<Option<(String, PathBuf, std::fs::File)>>,
}

impl DirStore {
    /// The logs of `dirs`, the first first where a name is in more than one.
    pub fn new(dirs: Vec<PathBuf>) -> Self {
        Self {
            dirs,
            open: std::cell::RefCell::new(None),
        }
    }

    /// Every log's name, directory and metadata, by name, and what could not be looked at
    /// (a directory that is not there is not a problem: the fallback directory exists only
    /// once a flight has fallen back to it).
    fn files(&self) -> (Vec<(String, &PathBuf, std::fs::Metadata)>, Vec<String>) {
        let mut files: BTreeMap<String, (&PathBuf, std::fs::Metadata)> = BTreeMap::new();
        let mut problems = Vec::new();
        for dir in &self.dirs {
            let entries = match std::fs::read_dir(dir) {
                Ok(entries) => entries,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => {
                    problems.push(format!("{}: {e}", dir.display()));
                    continue;
                }
            };
            for entry in entries {
                let entry = match entry {
                    Ok(entry) => entry,
                    Err(e) => {
                        problems.push(format!("{}: {e}", dir.display()));
                        continue;
                    }
                };
                let name = entry.file_name().to_string_lossy().to_string();
                if !name.ends_with(".mcap") {
                    continue;
                }
                match entry.metadata() {
                    Ok(meta) if meta.is_file() => {
                        files.entry(name).or_insert((dir, meta));
                    }
                    Ok(_) => {}
                    Err(e) => problems.push(format!("{}: {e}", dir.join(&name).display())),
                }
            }
        }
        let files = files
            .into_iter()
            .map(|(name, (dir, meta))| (name, dir, meta))
            .collect();
        (files, problems)
    }
}

impl LogStore for DirStore {
    fn list(&self) -> Listing {
        let (files, problems) = self.files();
        let logs = files
            .into_iter()
            .take(usize::from(u16::MAX))
            .enumerate()
            .map(|(i, (name, _, meta))| LogInfo {
                id: u16::try_from(i.saturating_add(1)).unwrap_or(u16::MAX),
                name,
                size: u32::try_from(meta.len()).unwrap_or(u32::MAX),
                time_utc: meta
                    .modified()
                    .ok()
                    .and_then(|m| m.duration_since(UNIX_EPOCH).ok())
                    .map_or(0, |d| u32::try_from(d.as_secs()).unwrap_or(u32::MAX)),
            })
            .collect();
        Listing { logs, problems }
    }

    fn read(&self, name: &str, ofs: u32, buf: &mut [u8]) -> Result<usize, String> {
        use std::io::{Read, Seek, SeekFrom};
        // Only a log of the directories, by its plain name.
        if name.is_empty() || name.contains('/') || !name.ends_with(".mcap") {
            return Err(format!("{name:?} is not a log's name"));
        }
        let mut open = self.open.borrow_mut();
        if open.as_ref().is_none_or(|(n, _, _)| n != name) {
            *open = None;
            let (files, _) = self.files();
            let Some((_, dir, _)) = files.into_iter().find(|(n, _, _)| n == name) else {
                return Err(format!("{name}: no longer in the log directories"));
            };
            let path = dir.join(name);
            let file =
                std::fs::File::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            *open = Some((name.to_string(), path, file));
        }
        let Some((_, path, file)) = open.as_mut() else {
            return Err(format!("{name}: not open"));
        };
        let failed = format!("{}: ", path.display());
        if let Err(e) = file.seek(SeekFrom::Start(u64::from(ofs))) {
            // The file is opened afresh for the next read.
            *open = None;
            return Err(format!("{failed}{e}"));
        }
        // Up to the buffer's length or the end of the file (an interrupted read is taken up
        // again by read_to_end).
        let mut bytes = Vec::with_capacity(buf.len());
        let limit = u64::try_from(buf.len()).unwrap_or(u64::MAX);
        if let Err(e) = file.by_ref().take(limit).read_to_end(&mut bytes) {
            *open = None;
            return Err(format!("{failed}{e}"));
        }
        let n = bytes.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), bytes.get(..n)) {
            dst.copy_from_slice(src);
        }
        Ok(n)
    }
}

/// How often an unauthenticated link says so to its grounds.
const UNSIGNED_WARNING_EVERY: Duration = Duration::from_secs(30);

/// Whether something last done at `last` (never: `None`) is due again at `now`, `every`
/// after it.
fn due_again(last: Option<Instant>, now: Instant, every: Duration) -> bool {
    last.is_none_or(|t| now.saturating_duration_since(t) >= every)
}

/// The ground stations the link sends to: each heard (a frame that passed the checks) in
/// the last [`PEER_TIMEOUT`], at most [`MAX_PEERS`] of them.
#[derive(Debug, Default)]
struct Peers {
    heard: BTreeMap<SocketAddr, Instant>,
}

impl Peers {
    /// `from` was heard at `now`; true if it is a new peer. A new one beyond
    /// [`MAX_PEERS`] takes the place of the one heard longest ago.
    fn heard(&mut self, from: SocketAddr, now: Instant) -> bool {
        if !self.heard.contains_key(&from) && self.heard.len() >= MAX_PEERS {
            let oldest = self.heard.iter().min_by_key(|(_, t)| **t).map(|(a, _)| *a);
            if let Some(a) = oldest {
                self.heard.remove(&a);
            }
        }
        self.heard.insert(from, now).is_none()
    }

    /// Forgets the peers not heard for [`PEER_TIMEOUT`] at `now`.
    fn expire(&mut self, now: Instant) {
        self.heard
            .retain(|_, heard| now.saturating_duration_since(*heard) < PEER_TIMEOUT);
    }

    /// The peers' addresses.
    fn addrs(&self) -> impl Iterator<Item = &SocketAddr> {
        self.heard.keys()
    }
}

/// The wall clock as Unix time (µs): MAVLink signing's time base. The link's runtime and
/// `heli ground` read the clock here; the link's state machines only take it as an argument.
pub fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

/// One pass's datagrams: waits for the first up to the socket's read timeout (a tick),
/// unless a log is going out (`sending_log`: then the loop must come round at the log's
/// pace); then takes what has arrived without waiting again, at most
/// [`MAX_DATAGRAMS_PER_PASS`], handing each to `take`. Returns how many it took.
fn receive_pass(
    socket: &UdpSocket,
    buf: &mut [u8],
    sending_log: bool,
    mut take: impl FnMut(&[u8], SocketAddr),
) -> usize {
    let _ = socket.set_nonblocking(sending_log);
    let mut taken = 0usize;
    while taken < MAX_DATAGRAMS_PER_PASS
        && let Ok((n, from)) = socket.recv_from(buf)
    {
        if taken == 0 {
            let _ = socket.set_nonblocking(true);
        }
        taken = taken.saturating_add(1);
        take(buf.get(..n).unwrap_or(&[]), from);
    }
    taken
}

/// Starts the link thread on `addr`, serving the parameters of `log_dir` and the logs of it
/// and of `fallback_dir`. `say` prints a line of the link's own (it is also sent to the
/// ground).
pub fn spawn(
    addr: SocketAddr,
    key: Option<Key>,
    (log_dir, fallback_dir): (PathBuf, Option<PathBuf>),
    shared: Arc<LinkShared>,
    requests: RequestHandle,
    say: Arc<dyn Fn(&Said) + Send + Sync>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    if key.is_some() && heli_link::signing::timestamp_from_unix_us(unix_us()) == 0 {
        return Err(std::io::Error::other(
            "the clock is before 2015: signed MAVLink needs the time (set the clock, or sync it by NTP or GPS, before serving a signed link)",
        ));
    }
    let socket = UdpSocket::bind(addr)?;
    socket.set_read_timeout(Some(TICK))?;
    let local = socket.local_addr()?;
    let signed = key.is_some();
    let note = |severity, text: String| Said::Link { severity, text };
    say(&note(
        if signed {
            Severity::ActivityHi
        } else {
            Severity::WarningHi
        },
        format!(
            "MAVLink 2 on udp {local}, {}",
            if signed {
                "commands must be signed"
            } else {
                "UNAUTHENTICATED: no signing key, anyone on the network can command the vehicle (heli link keygen)"
            }
        ),
    ));
    std::thread::Builder::new().name("link".into()).spawn(move || {
        // Below the flight's threads: a flooded link spends its own share, not theirs.
        let _ = crate::rt::background_thread();
        let params = match crate::params::load(&log_dir) {
            Ok(t) => t,
            Err(e) => {
                say(&note(
                    Severity::WarningHi,
                    format!("parameters not loaded ({e}); serving the defaults"),
                ));
                crate::params::defaults()
            }
        };
        let store = DirStore::new(std::iter::once(log_dir.clone()).chain(fallback_dir).collect());
        let mut link = VehicleLink::new(key, unix_us()).with_params(params);
        let mut peers = Peers::default();
        let mut held = held::Held::default();
        let mut pending: Vec<(heli_link::vehicle::CommandToken, Receiver<Reply>)> = Vec::new();
        let mut buf = [0u8; 2048];
        let mut last_unsigned_warning: Option<Instant> = None;
        // When each kind of refusal was last printed (one line per kind per second).
        let mut last_refusal_line: BTreeMap<&'static str, Instant> = BTreeMap::new();
        while !stop.load(Ordering::Acquire) {
            let mut events = Vec::new();
            // Wait for a datagram up to a tick (a socket timeout is only as fine as the
            // kernel's tick, a few ms); while a log is being sent, do not wait here but
            // sleep a millisecond below, so the log goes out at its pace. Then take all
            // that came without waiting again.
            let sending = link.sending_log();
            receive_pass(&socket, &mut buf, sending, |datagram, from| {
                let accepted_before = link.stats.frames_in;
                events.extend(link.receive(datagram, unix_us(), &store));
                // A key holder refused for its timestamp is told why, peer or not.
                for reply in link.take_replies() {
                    let _ = socket.send_to(&reply, from);
                }
                // Only a sender of a frame that passed the checks is sent to: a refused or
                // garbled datagram earns its sender nothing.
                if link.stats.frames_in > accepted_before && peers.heard(from, Instant::now()) {
                    // A ground just arrived is told at once, not at the next 30 s.
                    last_unsigned_warning = None;
                }
            });
            let (status, telemetry, texts, mission) = {
                let mut s = shared.lock();
                (
                    s.status,
                    s.telemetry.clone(),
                    std::mem::take(&mut s.texts),
                    s.mission.take(),
                )
            };
            if let Some(items) = mission {
                link.set_mission(items);
            }
            shared.set_ground_fresh(link.ground_fresh(unix_us()));
            // No ground heard: the warnings wait for one (a crash during a link outage is
            // told when the link comes back); a ground heard gets them first.
            peers.expire(Instant::now());
            if peers.addrs().next().is_none() {
                held.keep(texts);
            } else {
                for (severity, text) in held.release().into_iter().chain(texts) {
                    link.status_text(severity, &text, unix_us());
                }
            }
            if !signed && due_again(last_unsigned_warning, Instant::now(), UNSIGNED_WARNING_EVERY) {
                link.status_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "link unauthenticated: no signing key set",
                    unix_us(),
                );
                last_unsigned_warning = Some(Instant::now());
            }
            events.extend(link.tick(unix_us(), status, telemetry.as_ref(), &store));
            for event in events {
                match event {
                    LinkEvent::Command { token, command } => {
                        pending.push((token, requests.send(Request::Ground(command))));
                    }
                    // The link tells the ground itself (at most once a second); the
                    // console gets the same, no more often.
                    LinkEvent::Refused { reason, from, message_id } => {
                        let last = last_refusal_line.get(reason.text()).copied();
                        if due_again(last, Instant::now(), Duration::from_secs(1)) {
                            use std::io::Write;
                            let _ = writeln!(
                                std::io::stdout().lock(),
                                "link: refused a frame, {}: message {message_id} from {}/{}; {} refused so far",
                                reason.text(),
                                from.system,
                                from.component,
                                link.refused().total()
                            );
                            last_refusal_line.insert(reason.text(), Instant::now());
                        }
                    }
                    LinkEvent::ParamSet { table_text } => {
                        match crate::params::save(&log_dir, &table_text) {
                            Ok(None) => link.status_text(
                                MavSeverity::MAV_SEVERITY_INFO,
                                "param saved; a flight process takes it when it starts",
                                unix_us(),
                            ),
                            Ok(Some(warning)) => {
                                link.status_text(
                                    MavSeverity::MAV_SEVERITY_WARNING,
                                    &format!("param saved, but {warning}"),
                                    unix_us(),
                                );
                                say(&note(
                                    Severity::WarningHi,
                                    format!("parameter saved, but {warning}"),
                                ));
                            }
                            Err(e) => {
                                // Not kept on disk: not kept at all, and the ground is told.
                                let kept = crate::params::load(&log_dir)
                                    .unwrap_or_else(|_| crate::params::defaults());
                                link.replace_params(kept);
                                link.status_text(
                                    MavSeverity::MAV_SEVERITY_ERROR,
                                    &format!("param not saved, change undone: {e}"),
                                    unix_us(),
                                );
                                say(&note(
                                    Severity::WarningHi,
                                    format!("parameter not saved: {e}"),
                                ));
                            }
                        }
                    }
                    LinkEvent::LinkLost => say(&note(
                        Severity::WarningLo,
                        "lost (no ground heard for 5 s); flying on".into(),
                    )),
                    LinkEvent::LinkRegained => {
                        say(&note(Severity::ActivityHi, "ground heard again".into()));
                    }
                }
            }
            pending.retain(|(token, rx)| match rx.try_recv() {
                Ok(reply) => {
                    link.finish(*token, reply.outcome(), unix_us());
                    false
                }
                Err(std::sync::mpsc::TryRecvError::Empty) => true,
                Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                    link.finish(
                        *token,
                        heli_link::vehicle::CommandOutcome::Failed(
                            "the bootstrap did not answer".into(),
                        ),
                        unix_us(),
                    );
                    false
                }
            });
            peers.expire(Instant::now());
            for datagram in link.take_outgoing() {
                for peer in peers.addrs() {
                    let _ = socket.send_to(&datagram, peer);
                }
            }
            if sending {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    })
}

mod held;

#[cfg(test)]
mod tests;
