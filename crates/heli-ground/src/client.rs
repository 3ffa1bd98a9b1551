//! The ground station as a command-line client (`heli ground COMMAND`): one session on a UDP
//! socket to the vehicle's link, blocking until each request is answered. Its commands go
//! through [`crate::command::InFlight`] and its downloads through
//! [`crate::transfer::Transfer`], as the display's do: one retry and one download, whoever
//! asks.

use std::fmt;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use heli_link::GroundCommand;
use heli_link::ground::GroundLink;
use heli_link::signing::Key;
use mavlink::dialects::common::{LOG_ENTRY_DATA, MavResult, MavSeverity};

use crate::command::{InFlight, Progress};
use crate::transfer::{Transfer, Which};

/// The wall clock in µs since the Unix epoch: what the link's signatures and state machines
/// are given (they never read a clock themselves).
pub fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

/// Why a request got no answer it could use.
#[derive(Debug)]
pub enum ClientError {
    /// The socket could not be opened or connected.
    Socket(std::io::Error),
    /// The command cannot go over the link (its parameters do not fit).
    CannotSend(&'static str),
    /// No answer within the timeout.
    NoAnswer {
        /// What was asked.
        what: String,
        /// The vehicle's address.
        vehicle: SocketAddr,
        /// The timeout (s).
        seconds: f64,
        /// Whether any heartbeat came (without one, the link itself is in doubt).
        heard: bool,
        /// The vehicle's word on refusing this ground's frames, which names the cause.
        refused: Option<String>,
        /// Why the last frame sent could not go out, when it could not (no route, the
        /// interface down): then the vehicle never heard the question.
        send_failed: Option<String>,
    },
    /// The vehicle has no parameter of that name.
    NoSuchParameter(String),
    /// A log transfer failed; why.
    Transfer(String),
    /// The downloaded log could not be saved.
    Save {
        /// Where it was to go.
        path: PathBuf,
        /// Why not.
        why: crate::refusal::SaveError,
    },
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::Socket(e) => write!(f, "the link's socket: {e}"),
            ClientError::CannotSend(why) => {
                write!(f, "this command cannot go over the link: {why}")
            }
            ClientError::NoAnswer {
                what,
                vehicle,
                seconds,
                heard,
                refused,
                send_failed,
            } => match (refused, send_failed) {
                (Some(refusal), _) => write!(
                    f,
                    "{what}: the vehicle at {vehicle} refused this ground's frames: {refusal}"
                ),
                (None, Some(e)) => write!(
                    f,
                    "{what}: no answer from the vehicle at {vehicle} within {seconds:.0} s: \
                     sending to it failed ({e})"
                ),
                (None, None) => write!(
                    f,
                    "{what}: no answer from the vehicle at {vehicle} within {seconds:.0} s{}",
                    if *heard {
                        ""
                    } else {
                        " (no heartbeat either: is `heli vehicle --link` running there, with the same key?)"
                    }
                ),
            },
            ClientError::NoSuchParameter(name) => {
                write!(f, "param {name}: the vehicle has no such parameter")
            }
            ClientError::Transfer(why) => f.write_str(why),
            ClientError::Save { path, why } => write!(f, "saving {}: {why}", path.display()),
        }
    }
}

impl std::error::Error for ClientError {}

/// Where the vehicle's status texts go, with their severity.
pub type TextSink = Box<dyn FnMut(MavSeverity, &str)>;

/// A ground station session with the vehicle.
pub struct Client {
    socket: UdpSocket,
    vehicle: SocketAddr,
    /// The link's ground end (what the vehicle said so far).
    pub link: GroundLink,
    timeout: Duration,
    last_heartbeat: Option<Instant>,
    texts_shown: usize,
    on_text: TextSink,
    /// Why the last send failed, while sends fail.
    send_failed: Option<String>,
}

impl Client {
    /// A session with the vehicle at `vehicle`, signed with `key` on `link_id`; each request waits up to
    /// `timeout`, and the vehicle's status texts go to `on_text` as they arrive.
    pub fn open(
        vehicle: SocketAddr,
        key: Option<Key>,
        link_id: u8,
        timeout: Duration,
        on_text: TextSink,
    ) -> Result<Self, ClientError> {
        let bind: SocketAddr = if vehicle.is_ipv4() {
            SocketAddr::from(([0, 0, 0, 0], 0))
        } else {
            SocketAddr::from(([0u16; 8], 0))
        };
        let socket = UdpSocket::bind(bind).map_err(ClientError::Socket)?;
        // Datagrams from the vehicle's address only.
        socket.connect(vehicle).map_err(ClientError::Socket)?;
        socket
            .set_read_timeout(Some(Duration::from_millis(10)))
            .map_err(ClientError::Socket)?;
        Ok(Self {
            socket,
            vehicle,
            link: GroundLink::on_link(key, link_id),
            timeout,
            last_heartbeat: None,
            texts_shown: 0,
            on_text,
            send_failed: None,
        })
    }

    /// Sends `datagram` to the vehicle; a failure is kept for the error that says there was
    /// no answer.
    fn send(&mut self, datagram: &[u8]) {
        self.send_failed = self.socket.send(datagram).err().map(|e| e.to_string());
    }

    fn no_answer(&self, what: impl Into<String>) -> ClientError {
        ClientError::NoAnswer {
            what: what.into(),
            vehicle: self.vehicle,
            seconds: self.timeout.as_secs_f64(),
            heard: self.link.heartbeat.is_some(),
            refused: self.link.refusal_of_ours().map(str::to_string),
            send_failed: self.send_failed.clone(),
        }
    }

    /// One turn: the heartbeat when due, what came (waiting up to 10 ms for it), the new
    /// status texts.
    fn pump(&mut self) {
        if self
            .last_heartbeat
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(1))
        {
            let hb = self.link.heartbeat_frame(unix_us());
            self.send(&hb);
            self.last_heartbeat = Some(Instant::now());
        }
        let mut buf = [0u8; 2048];
        let _ = self.socket.set_nonblocking(false);
        while let Ok(n) = self.socket.recv(&mut buf) {
            self.link.receive(buf.get(..n).unwrap_or(&[]), unix_us());
            let _ = self.socket.set_nonblocking(true);
        }
        self.link.flush_texts(unix_us());
        for (severity, text) in self.link.texts.iter().skip(self.texts_shown) {
            (self.on_text)(*severity, text);
        }
        self.texts_shown = self.link.texts.len();
    }

    /// Sends `command` until the vehicle gives its final answer.
    pub fn command(&mut self, command: &GroundCommand) -> Result<MavResult, ClientError> {
        let timeout_us = u64::try_from(self.timeout.as_micros()).unwrap_or(u64::MAX);
        let (mut sent, frame) = InFlight::send(&mut self.link, command, timeout_us, unix_us())
            .ok_or(ClientError::CannotSend("a suffix is at most 15 characters"))?;
        self.send(&frame);
        loop {
            self.pump();
            let (progress, retry) = sent.tick(&mut self.link, unix_us());
            if let Some(frame) = retry {
                self.send(&frame);
            }
            match progress {
                Progress::Waiting => {}
                Progress::Answered(result) => return Ok(result),
                Progress::TimedOut => return Err(self.no_answer("command")),
            }
        }
    }

    /// Listens for `seconds`.
    pub fn listen(&mut self, seconds: f64) {
        let end = Instant::now() + Duration::from_secs_f64(seconds.clamp(0.0, 3600.0));
        while Instant::now() < end {
            self.pump();
        }
    }

    /// Asks until the vehicle's whole parameter list came (`link.params`).
    pub fn params(&mut self) -> Result<(), ClientError> {
        let start = Instant::now();
        let mut asked: Option<Instant> = None;
        while start.elapsed() < self.timeout {
            if asked.is_none_or(|t| t.elapsed() > Duration::from_secs(1)) {
                let frame = self.link.param_list_frame(unix_us());
                self.send(&frame);
                asked = Some(Instant::now());
            }
            self.pump();
            let count = self
                .link
                .params
                .values()
                .next()
                .map(|(_, _, n)| usize::from(*n));
            if count.is_some_and(|n| self.link.params.len() >= n) {
                return Ok(());
            }
        }
        Err(self.no_answer("the parameter list"))
    }

    /// Sets parameter `name` to `value`; returns the value the vehicle kept (its old one
    /// when it refused the new, with its reason among the status texts).
    pub fn param_set(&mut self, name: &str, value: f32) -> Result<f32, ClientError> {
        let start = Instant::now();
        let mut asked: Option<Instant> = None;
        let texts_before = self.link.texts.len();
        self.link.params.remove(name);
        while start.elapsed() < self.timeout {
            if asked.is_none_or(|t| t.elapsed() > Duration::from_secs(1)) {
                let frame = self.link.param_set_frame(name, value, unix_us());
                self.send(&frame);
                asked = Some(Instant::now());
            }
            self.pump();
            if let Some((kept, _, _)) = self.link.params.get(name) {
                return Ok(*kept);
            }
            if self
                .link
                .texts
                .iter()
                .skip(texts_before)
                .any(|(_, t)| t.contains("no such parameter"))
            {
                return Err(ClientError::NoSuchParameter(name.to_string()));
            }
        }
        Err(self.no_answer(format!("param {name}")))
    }

    /// The logs on the vehicle.
    pub fn logs(&mut self) -> Result<Vec<LOG_ENTRY_DATA>, ClientError> {
        let frame = self.link.log_list_frame(unix_us());
        self.send(&frame);
        let start = Instant::now();
        let mut asked = Instant::now();
        while start.elapsed() < self.timeout {
            self.pump();
            let want = self
                .link
                .log_entries
                .values()
                .next()
                .map(|e| usize::from(e.num_logs));
            let logs: Vec<LOG_ENTRY_DATA> = self
                .link
                .log_entries
                .values()
                .filter(|e| e.id > 0)
                .cloned()
                .collect();
            if want.is_some_and(|n| logs.len() >= n) {
                return Ok(logs);
            }
            if asked.elapsed() > Duration::from_secs(1) {
                let frame = self.link.log_list_frame(unix_us());
                self.send(&frame);
                asked = Instant::now();
            }
        }
        Err(self.no_answer("the log list"))
    }

    /// Downloads log `which` into `out` — or, when a file of that name exists, next to it as
    /// `NAME-2.mcap` and so on: a log is never overwritten — telling `progress` the bytes
    /// received and the log's size as they come; returns where it went and the bytes written.
    pub fn download(
        &mut self,
        which: Which,
        out: &Path,
        progress: &mut dyn FnMut(u64, u32),
    ) -> Result<(PathBuf, usize), ClientError> {
        let timeout_us = u64::try_from(self.timeout.as_micros()).unwrap_or(u64::MAX);
        let mut transfer = Transfer::of(which, out.to_path_buf(), timeout_us, unix_us());
        loop {
            self.pump();
            let step = transfer.tick(&mut self.link, unix_us());
            for frame in &step.frames {
                self.send(frame);
            }
            if let Some((received, size)) = transfer.progress(&self.link) {
                progress(received, size);
            }
            if let Some((path, bytes)) = step.save {
                return save_download(path, &bytes).map(|at| (at, bytes.len()));
            }
            if step.done {
                let why = step.notes.last().cloned().unwrap_or_default();
                return Err(ClientError::Transfer(why));
            }
        }
    }
}

/// Where a download goes: a file never overwritten ([`crate::transfer::save_new`]); a device
/// or pipe named (`/dev/stdout`) is written to as asked; a directory is refused.
fn save_download(path: PathBuf, bytes: &[u8]) -> Result<PathBuf, ClientError> {
    use crate::refusal::SaveError;
    match std::fs::metadata(&path) {
        Ok(m) if m.is_dir() => Err(ClientError::Save {
            path,
            why: SaveError::Write(std::io::Error::other(
                "is a directory: give the log's file name",
            )),
        }),
        Ok(m) if !m.is_file() => match std::fs::write(&path, bytes) {
            Ok(()) => Ok(path),
            Err(e) => Err(ClientError::Save {
                path,
                why: SaveError::Write(e),
            }),
        },
        _ => crate::transfer::save_new(&path, bytes).map_err(|why| ClientError::Save { path, why }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_download_goes_to_a_new_file_a_device_as_asked_and_never_to_a_directory() {
        let dir = std::env::temp_dir().join(format!("heli-client-save-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("f.mcap");
        assert_eq!(save_download(file.clone(), b"a").unwrap(), file);
        assert_eq!(
            save_download(file.clone(), b"b").unwrap(),
            dir.join("f-2.mcap")
        );
        let null = PathBuf::from("/dev/null");
        assert_eq!(save_download(null.clone(), b"c").unwrap(), null);
        let e = save_download(dir.clone(), b"d").unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn no_answer(refused: Option<&str>, send_failed: Option<&str>, heard: bool) -> String {
        ClientError::NoAnswer {
            what: "arm".into(),
            vehicle: "10.0.0.2:14550".parse().unwrap(),
            seconds: 5.0,
            heard,
            refused: refused.map(str::to_string),
            send_failed: send_failed.map(str::to_string),
        }
        .to_string()
    }

    #[test]
    fn no_answer_names_the_cause_it_knows() {
        let silent = no_answer(None, None, false);
        assert!(
            silent.starts_with("arm: no answer from the vehicle at 10.0.0.2:14550 within 5 s")
                && silent.contains("no heartbeat either"),
            "{silent}"
        );
        let unsent = no_answer(None, Some("Network is unreachable (os error 101)"), false);
        assert!(
            unsent.ends_with("sending to it failed (Network is unreachable (os error 101))"),
            "{unsent}"
        );
        let refused = no_answer(Some("unsigned"), Some("x"), true);
        assert!(
            refused.contains("refused this ground's frames: unsigned"),
            "{refused}"
        );
    }
}
