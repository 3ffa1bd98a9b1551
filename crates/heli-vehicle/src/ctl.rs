//! The bootstrap's local control socket: one command per connection, one line each way and
//! back, so a shell, a test or a future link bridge can drive the vehicle.
//!
//! Commands (the thesis's ground buttons, plus two for the operator at the vehicle):
//!
//! | line | what |
//! |---|---|
//! | `connect` | start the flight process (a running one is killed first) |
//! | `start-logging SUFFIX MODE [PLAN]` | begin the flight: log `flight_SUFFIX.mcap`, controller `MODE` (`manual`, `autonomous`, `rate`, `attitude`, `velocity`), flight plan `PLAN` |
//! | `stop` | stop the flight process cleanly |
//! | `status` | bootstrap state, the child's pid and last exit, the freshest telemetry |
//! | `quit` | stop the flight process and end the bootstrap |
//!
//! The reply is one line starting `ok` or `error`, then whatever the command reports.
//! Everything but `quit` maps onto the link's [`GroundCommand`], so the MAVLink bridge hands
//! the bootstrap the same values.

use std::fmt;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Duration;

use heli_link::vehicle::CommandOutcome;
use heli_link::{GroundCommand, StartParameters};

use crate::control_socket;

/// How long a client waits for the bootstrap's reply (a Connect waits for the flight
/// process to confirm it is up).
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(20);

/// A request on the control socket.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    /// A ground-station command.
    Ground(GroundCommand),
    /// End the bootstrap.
    Quit,
}

/// A command line that is not a request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RequestError {
    /// Nothing in it.
    Empty,
    /// Not one of the commands.
    Unknown(String),
    /// `start-logging` without its words, or with too many.
    Usage,
    /// Start Logging's parameters are refused (the link's check).
    Parameters(heli_link::LinkError),
    /// `kill` without its confirmation.
    KillUnconfirmed,
}

impl fmt::Display for RequestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RequestError::Empty => write!(f, "empty command"),
            RequestError::Unknown(word) => write!(
                f,
                "unknown command '{word}' (expected connect, start-logging, stop, kill confirmed, status or quit)"
            ),
            RequestError::Usage => write!(
                f,
                "usage: start-logging SUFFIX MODE [PLAN] [override-untested]"
            ),
            RequestError::Parameters(e) => write!(f, "{e}"),
            RequestError::KillUnconfirmed => write!(
                f,
                "kill ends the flight process now, in the air too: the helicopter falls. Stop \
                 lands it first (or is refused while the pilot flies); to kill, send 'kill confirmed'"
            ),
        }
    }
}

impl std::error::Error for RequestError {}

impl Request {
    /// Parses a command line; the error says what is wrong.
    pub fn parse(line: &str) -> Result<Self, RequestError> {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["connect"] => Ok(Request::Ground(GroundCommand::Connect)),
            ["stop"] => Ok(Request::Ground(GroundCommand::Stop)),
            ["kill", "confirmed"] => Ok(Request::Ground(GroundCommand::Kill)),
            ["kill", ..] => Err(RequestError::KillUnconfirmed),
            ["status"] => Ok(Request::Ground(GroundCommand::TelemetryRequest)),
            ["quit"] => Ok(Request::Quit),
            ["start-logging", suffix, mode, rest @ ..] => {
                let (override_untested, rest) = match rest {
                    [plan @ .., last] if *last == crate::supervisor::OVERRIDE_WORD => (true, plan),
                    _ => (false, rest),
                };
                if rest.len() > 1 {
                    return Err(RequestError::Usage);
                }
                let mut params =
                    StartParameters::new(suffix, mode).map_err(RequestError::Parameters)?;
                params.plan = rest.first().map(|p| (*p).to_string());
                params.override_untested = override_untested;
                Ok(Request::Ground(GroundCommand::StartLogging(params)))
            }
            ["start-logging", ..] => Err(RequestError::Usage),
            [] => Err(RequestError::Empty),
            [other, ..] => Err(RequestError::Unknown((*other).to_string())),
        }
    }

    /// The command line of this request.
    pub fn to_line(&self) -> String {
        match self {
            Request::Ground(GroundCommand::Connect) => "connect".into(),
            Request::Ground(GroundCommand::Stop) => "stop".into(),
            Request::Ground(GroundCommand::Kill) => "kill confirmed".into(),
            Request::Ground(GroundCommand::TelemetryRequest) => "status".into(),
            Request::Ground(GroundCommand::StartLogging(p)) => {
                format!("start-logging {}", crate::supervisor::start_words(p))
            }
            Request::Ground(GroundCommand::Final(f)) => {
                format!("final {} {}", f.base_directory, f.file_suffix)
            }
            Request::Quit => "quit".into(),
        }
    }
}

/// The bootstrap's answer to a request: what happened, or why it was refused. On the socket
/// it is one line, `ok …` or `error …`; the link turns it into a command's acknowledgement.
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// Connect: the flight process is up.
    Connected {
        /// Its process id.
        pid: u32,
    },
    /// Start Logging: flying, and logging there.
    Flying {
        /// The log (`(no log)` without one).
        log: String,
    },
    /// Stop: the flight process exited.
    Stopped {
        /// How (`exit code 0`).
        how: String,
    },
    /// Stop: the flight process was not listening and was killed.
    Killed,
    /// Stop in the air: the flight computer lands first (what it said); the flight ends on
    /// the ground.
    Landing(String),
    /// Stop with no flight process.
    NothingToStop,
    /// Status: the bootstrap's state, the flight process's, the freshest telemetry.
    Status(serde_json::Value),
    /// Quit: the bootstrap is ending.
    Quitting,
    /// The request was refused or failed; why.
    Refused(String),
}

impl Reply {
    /// A refusal with `why`.
    pub fn refused(why: impl Into<String>) -> Self {
        Reply::Refused(why.into())
    }

    /// What the reply says, without its `ok` or `error`.
    pub fn text(&self) -> String {
        match self {
            Reply::Connected { pid } => format!("connected (pid {pid})"),
            Reply::Flying { log } => format!("flying, logging to {log}"),
            Reply::Stopped { how } => format!("stopped ({how})"),
            Reply::Killed => "stopped (the flight process was not listening; killed)".into(),
            Reply::Landing(what) => format!(
                "{} ({})",
                heli_link::messages::LANDING_FIRST,
                what.replace(['\n', '\r'], " ")
            ),
            Reply::NothingToStop => "nothing to stop".into(),
            Reply::Status(v) => v.to_string(),
            Reply::Quitting => "quitting".into(),
            Reply::Refused(why) => why.replace(['\n', '\r'], " "),
        }
    }

    /// What was done, or why not: the link's acknowledgement.
    pub fn outcome(&self) -> CommandOutcome {
        match self {
            Reply::Refused(_) => CommandOutcome::Failed(self.text()),
            _ => CommandOutcome::Accepted(self.text()),
        }
    }

    /// The reply's line on the control socket.
    pub fn to_line(&self) -> String {
        match self {
            Reply::Refused(_) => format!("error {}", self.text()),
            _ => format!("ok {}", self.text()),
        }
    }
}

/// Why a request to the bootstrap got no `ok`.
#[derive(Debug)]
pub enum CtlError {
    /// The socket cannot be reached.
    Unreachable {
        /// The socket.
        socket: PathBuf,
        /// The system's answer.
        error: std::io::Error,
    },
    /// The request could not be sent, or no reply came in time.
    NoReply(std::io::Error),
    /// The bootstrap closed the connection without a reply.
    Closed,
    /// The bootstrap answered `error`: why.
    Refused(String),
}

impl fmt::Display for CtlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CtlError::Unreachable { socket, error } => write!(
                f,
                "control socket {}: {error} (is `heli vehicle` running with this --socket?)",
                socket.display()
            ),
            CtlError::NoReply(e) => write!(f, "no reply from the bootstrap: {e}"),
            CtlError::Closed => write!(f, "the bootstrap closed the connection"),
            CtlError::Refused(why) => f.write_str(why),
        }
    }
}

impl std::error::Error for CtlError {}

/// Sends requests to a running bootstrap from another thread (the control socket's, the
/// link's); each reply arrives on the receiver [`RequestHandle::send`] returns.
#[derive(Clone)]
pub struct RequestHandle {
    send: std::sync::Arc<dyn Fn(Request, std::sync::mpsc::Sender<Reply>) + Send + Sync>,
}

impl RequestHandle {
    /// A handle that hands each request, with where its reply goes, to `send`.
    pub fn new(
        send: impl Fn(Request, std::sync::mpsc::Sender<Reply>) + Send + Sync + 'static,
    ) -> Self {
        Self {
            send: std::sync::Arc::new(send),
        }
    }

    /// Sends `request`; its reply comes on the receiver.
    pub fn send(&self, request: Request) -> std::sync::mpsc::Receiver<Reply> {
        let (tx, rx) = std::sync::mpsc::channel();
        (self.send)(request, tx);
        rx
    }
}

/// Sends `request` to the bootstrap listening on `socket` and returns its reply line. An
/// error when the bootstrap cannot be reached or answered `error`.
pub fn send(socket: &Path, request: &Request) -> Result<String, CtlError> {
    let mut stream = UnixStream::connect(socket).map_err(|error| CtlError::Unreachable {
        socket: socket.to_path_buf(),
        error,
    })?;
    stream
        .set_read_timeout(Some(REPLY_TIMEOUT))
        .map_err(CtlError::NoReply)?;
    writeln!(stream, "{}", request.to_line()).map_err(CtlError::NoReply)?;
    let mut reply = String::new();
    BufReader::new(stream)
        .read_line(&mut reply)
        .map_err(CtlError::NoReply)?;
    let reply = reply.trim_end().to_string();
    match reply.strip_prefix("error") {
        Some(rest) => Err(CtlError::Refused(rest.trim_start().to_string())),
        None if reply.is_empty() => Err(CtlError::Closed),
        None => Ok(reply),
    }
}

/// Accepts control connections on the bootstrap's socket: one request line, one reply line.
/// A peer of another user, or one past [`control_socket::MAX_CONNECTIONS`], is answered with
/// the refusal at once and closed.
pub fn serve(
    listener: &std::os::unix::net::UnixListener,
    bootstrap: &RequestHandle,
    written: &std::sync::mpsc::Sender<()>,
) {
    let live = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut errors = control_socket::AcceptErrors::default();
    for stream in listener.incoming() {
        let Some(mut stream) = errors.take("control socket", stream) else {
            continue;
        };
        let _ = stream.set_write_timeout(Some(Duration::from_secs(1)));
        let refusal = match control_socket::peer_allowed(&stream) {
            Err(why) => Some(why),
            Ok(()) if live.load(Ordering::Acquire) >= control_socket::MAX_CONNECTIONS => {
                Some(format!(
                    "busy: {} control connections open",
                    control_socket::MAX_CONNECTIONS
                ))
            }
            Ok(()) => None,
        };
        if let Some(why) = refusal {
            let _ = writeln!(stream, "{}", Reply::refused(why).to_line());
            continue;
        }
        let bootstrap = bootstrap.clone();
        let written = written.clone();
        let live_here = live.clone();
        live.fetch_add(1, Ordering::AcqRel);
        let spawned = std::thread::Builder::new()
            .name("ctl-conn".into())
            .spawn(move || {
                serve_one(stream, &bootstrap, &written);
                live_here.fetch_sub(1, Ordering::AcqRel);
            });
        if spawned.is_err() {
            live.fetch_sub(1, Ordering::AcqRel);
        }
    }
}

/// One control connection: one request line (bounded in length and in time), one reply
/// line — for every line, a malformed one included.
fn serve_one(
    mut stream: UnixStream,
    bootstrap: &RequestHandle,
    written: &std::sync::mpsc::Sender<()>,
) {
    let line = control_socket::read_line(
        &mut stream,
        std::time::Instant::now(),
        control_socket::REQUEST_DEADLINE,
    );
    let reply = match line.and_then(|l| Request::parse(&l).map_err(|e| e.to_string())) {
        // The reply may wait for the flight process (connect, stop).
        Ok(request) => bootstrap
            .send(request)
            .recv()
            .unwrap_or_else(|_| Reply::refused("the bootstrap is ending")),
        Err(why) => Reply::refused(why),
    };
    let _ = writeln!(stream, "{}", reply.to_line());
    let _ = stream.flush();
    let _ = written.send(());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse_round_trip_and_bad_ones_say_why() {
        for line in [
            "connect",
            "stop",
            "status",
            "quit",
            "start-logging f1 autonomous hover",
            "start-logging f2 manual",
            "start-logging f3 autonomous rolls override-untested",
            "start-logging f4 velocity override-untested",
        ] {
            assert_eq!(Request::parse(line).unwrap().to_line(), line);
        }
        let Ok(Request::Ground(GroundCommand::StartLogging(p))) =
            Request::parse("start-logging f3 autonomous rolls override-untested")
        else {
            panic!("not a start")
        };
        assert!(p.override_untested);
        assert_eq!(p.plan.as_deref(), Some("rolls"));
        assert!(
            Request::parse("start-logging ../x manual")
                .unwrap_err()
                .to_string()
                .contains("suffix")
        );
        assert!(
            Request::parse("start-logging a loop")
                .unwrap_err()
                .to_string()
                .contains("loop")
        );
        assert!(
            Request::parse("fly")
                .unwrap_err()
                .to_string()
                .contains("unknown command")
        );
        for usage in [
            "start-logging",
            "start-logging f1",
            "start-logging f1 autonomous hover x",
            "start-logging f1 autonomous hover x override-untested",
        ] {
            assert!(
                Request::parse(usage)
                    .unwrap_err()
                    .to_string()
                    .contains("usage"),
                "{usage}"
            );
        }
        assert_eq!(
            Request::parse("  ").unwrap_err().to_string(),
            "empty command"
        );
    }

    #[test]
    fn a_bootstrap_that_closes_without_a_reply_or_is_not_there_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let socket = dir.path().join("ctl.sock");
        let e = send(&socket, &Request::Quit).unwrap_err().to_string();
        assert!(e.contains("is `heli vehicle` running"), "{e}");
        let listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        let server = std::thread::spawn(move || {
            let (stream, _) = listener.accept().unwrap();
            let mut line = String::new();
            let _ = BufReader::new(&stream).read_line(&mut line);
            line
        });
        assert_eq!(
            send(&socket, &Request::Quit).unwrap_err().to_string(),
            "the bootstrap closed the connection"
        );
        assert_eq!(server.join().unwrap(), "quit\n");
    }

    #[test]
    fn replies_are_one_line_of_ok_or_error() {
        let cases = [
            (Reply::Connected { pid: 42 }, "ok connected (pid 42)"),
            (
                Reply::Flying {
                    log: "/l/flight_a.mcap".into(),
                },
                "ok flying, logging to /l/flight_a.mcap",
            ),
            (
                Reply::Stopped {
                    how: "exit code 0".into(),
                },
                "ok stopped (exit code 0)",
            ),
            (
                Reply::Killed,
                "ok stopped (the flight process was not listening; killed)",
            ),
            (Reply::NothingToStop, "ok nothing to stop"),
            (
                Reply::Status(serde_json::json!({"state": "idle"})),
                r#"ok {"state":"idle"}"#,
            ),
            (Reply::Quitting, "ok quitting"),
            (Reply::refused("busy\n(flying)"), "error busy (flying)"),
        ];
        for (reply, line) in cases {
            assert_eq!(reply.to_line(), line);
            let text = line.split_once(' ').unwrap().1.to_string();
            match reply {
                Reply::Refused(_) => assert_eq!(reply.outcome(), CommandOutcome::Failed(text)),
                _ => assert_eq!(reply.outcome(), CommandOutcome::Accepted(text)),
            }
        }
    }
}
