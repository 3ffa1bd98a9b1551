//! Taking a flight back: the bootstrap is no single point of failure.
//!
//! When the bootstrap dies while the helicopter flies, the flight process flies on
//! ([`crate::flight::Supervision`]) and waits on its **adoption socket**, a Unix socket it
//! bound when it started. The init system starts the bootstrap again (the systemd unit in
//! `deploy/` keeps the flight process alive across that restart); the new bootstrap connects
//! to the socket, hears `ready V`, `adopted PID SUFFIX MODE [PLAN]` and `started LOG`, and from
//! then on speaks the usual line protocol ([`crate::supervisor`]) over the socket: telemetry,
//! events, Stop — the flight is never interrupted.
//!
//! The socket also says that a flight process lives: a flight process that finds another's
//! socket answering refuses to start (two processes would fight over the serial ports), and
//! a bootstrap that finds one it cannot take back starts no second one.
//!
//! The socket is `<control socket>.flight` ([`socket_for`]), made readable and writable by
//! its owner only.

use std::io::{BufRead, BufReader, Write};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use heli_link::StartParameters;

use crate::error::VehicleError;
use crate::supervisor::{FromFlight, VERSION};

/// The adoption socket of the bootstrap whose control socket is `control`.
pub fn socket_for(control: &Path) -> PathBuf {
    let mut name = control.as_os_str().to_owned();
    name.push(".flight");
    PathBuf::from(name)
}

/// How long a bootstrap waits for a flight process to answer on its socket: it answers once
/// it has noticed that its last bootstrap is gone, at once in practice.
pub const ANSWER_WAIT: Duration = Duration::from_secs(3);

/// The flight process's line to its bootstrap: standard output until a new bootstrap takes
/// the flight back over the adoption socket. A line that cannot be written (the bootstrap
/// is gone) is lost; what matters is in the log.
pub struct Outbox {
    out: Mutex<Box<dyn Write + Send>>,
}

impl Outbox {
    /// Standard output.
    pub fn stdout() -> Self {
        Self::to(Box::new(std::io::stdout()))
    }

    /// Any writer (a test's buffer).
    pub fn to(out: Box<dyn Write + Send>) -> Self {
        Self {
            out: Mutex::new(out),
        }
    }

    /// Writes one message and flushes; whether it was written.
    pub fn say(&self, message: &FromFlight) -> bool {
        let mut out = self.out.lock().unwrap_or_else(|e| e.into_inner());
        writeln!(out, "{message}")
            .and_then(|()| out.flush())
            .is_ok()
    }

    /// From now on the lines go to `out`.
    pub fn replace(&self, out: Box<dyn Write + Send>) {
        *self.out.lock().unwrap_or_else(|e| e.into_inner()) = out;
    }
}

/// How long a new flight process waits for another's socket to stop answering: the bootstrap
/// kills the running process just before it starts a new one (Connect), and the kernel
/// closes a killed process's socket a moment later.
pub const KILLED_WAIT: Duration = Duration::from_secs(1);

/// Binds the flight process's adoption socket at `path`. A socket there that still answers
/// after [`KILLED_WAIT`] is a live flight process's: an error (two flight processes would
/// fight over the devices). A stale one (its process died) is replaced.
pub fn listen(path: &Path) -> Result<UnixListener, VehicleError> {
    if path.exists() {
        let answers = || UnixStream::connect(path).is_ok();
        let since = std::time::Instant::now();
        while answers() && since.elapsed() < KILLED_WAIT {
            std::thread::sleep(Duration::from_millis(100));
        }
        if answers() {
            return Err(VehicleError::invalid(
                format!("adoption socket {}", path.display()),
                "another flight process is running (its socket answers): stop it first",
            ));
        }
        let _ = std::fs::remove_file(path);
    }
    let listener = UnixListener::bind(path).map_err(|e| VehicleError::Socket {
        path: path.to_path_buf(),
        source: Some(e),
    })?;
    // Only the flight computer's own user may take the flight over, whatever the umask.
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)).map_err(|e| {
        VehicleError::Socket {
            path: path.to_path_buf(),
            source: Some(e),
        }
    })?;
    Ok(listener)
}

/// What the flight process says to a bootstrap that connected: who it is, what it flies and
/// where it logs. Written straight to `stream`; `false` if the bootstrap is already gone.
pub fn introduce(stream: &mut UnixStream, start: &StartParameters, log: Option<String>) -> bool {
    let lines = [
        FromFlight::Ready { version: VERSION },
        FromFlight::Adopted {
            pid: std::process::id(),
            start: start.clone(),
        },
        FromFlight::Started { log },
    ];
    lines
        .iter()
        .try_for_each(|m| writeln!(stream, "{m}"))
        .and_then(|()| stream.flush())
        .is_ok()
}

/// A flight process a bootstrap took back.
#[derive(Debug)]
pub struct Adopted {
    /// Its process id.
    pub pid: u32,
    /// What it flies.
    pub start: StartParameters,
    /// Its log, if it keeps one.
    pub log: Option<String>,
    /// The line to it (write [`crate::supervisor::ToFlight`] lines).
    pub to_flight: UnixStream,
    /// Its lines, after the introduction.
    pub from_flight: BufReader<UnixStream>,
}

/// Why a flight process that lives could not be taken back.
#[derive(Debug)]
pub enum TakeBackError {
    /// It did not introduce itself within the wait.
    Silent(String),
    /// It said something else than the introduction.
    Unexpected(String),
    /// It speaks another protocol version.
    Version(u16),
}

impl std::fmt::Display for TakeBackError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TakeBackError::Silent(why) => write!(f, "it did not introduce itself ({why})"),
            TakeBackError::Unexpected(line) => write!(f, "it said '{line:.120}', not who it is"),
            TakeBackError::Version(v) => write!(
                f,
                "it speaks protocol version {v}, this bootstrap {VERSION} (was the program replaced under it?)"
            ),
        }
    }
}

/// Connects to the adoption socket at `path`: `Ok(None)` when no flight process listens there
/// (no socket, or a stale one), the flight taken back, or why a live one could not be.
pub fn take_back(path: &Path, wait: Duration) -> Result<Option<Adopted>, TakeBackError> {
    let Ok(stream) = UnixStream::connect(path) else {
        return Ok(None);
    };
    let silent = |e: std::io::Error| TakeBackError::Silent(e.to_string());
    stream.set_read_timeout(Some(wait)).map_err(silent)?;
    let to_flight = stream.try_clone().map_err(silent)?;
    let mut from_flight = BufReader::new(stream);
    let mut next = || -> Result<FromFlight, TakeBackError> {
        let mut line = String::new();
        match from_flight.read_line(&mut line) {
            Ok(0) => Err(TakeBackError::Silent("it closed the socket".into())),
            Ok(_) => FromFlight::parse(&line)
                .map_err(|_| TakeBackError::Unexpected(line.trim_end().to_string())),
            Err(e) => Err(silent(e)),
        }
    };
    match next()? {
        FromFlight::Ready { version } if version == VERSION => {}
        FromFlight::Ready { version } => return Err(TakeBackError::Version(version)),
        other => return Err(TakeBackError::Unexpected(other.to_line())),
    }
    let (pid, start) = match next()? {
        FromFlight::Adopted { pid, start } => (pid, start),
        other => return Err(TakeBackError::Unexpected(other.to_line())),
    };
    let log = match next()? {
        FromFlight::Started { log } => log,
        other => return Err(TakeBackError::Unexpected(other.to_line())),
    };
    from_flight
        .get_ref()
        .set_read_timeout(None)
        .map_err(silent)?;
    Ok(Some(Adopted {
        pid,
        start,
        log,
        to_flight,
        from_flight,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> StartParameters {
        let mut p = StartParameters::new("t1", "autonomous").unwrap();
        p.plan = Some("rolls".into());
        p
    }

    #[test]
    fn the_adoption_socket_sits_beside_the_control_socket() {
        assert_eq!(
            socket_for(Path::new("/run/heli/vehicle.sock")),
            PathBuf::from("/run/heli/vehicle.sock.flight")
        );
    }

    #[test]
    fn a_bootstrap_takes_back_a_flight_process_that_introduces_itself() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.sock.flight");
        let listener = listen(&path).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600, "owner only");
        let flight = std::thread::spawn(move || {
            let (mut stream, _) = listener.accept().unwrap();
            assert!(introduce(
                &mut stream,
                &start(),
                Some("/logs/f.mcap".into())
            ));
            writeln!(stream, "event warning-hi still flying").unwrap();
            let mut heard = String::new();
            BufReader::new(stream).read_line(&mut heard).unwrap();
            heard
        });
        let mut adopted = take_back(&path, ANSWER_WAIT).unwrap().unwrap();
        assert_eq!(adopted.pid, std::process::id());
        assert_eq!(adopted.start, start());
        assert_eq!(adopted.log.as_deref(), Some("/logs/f.mcap"));
        let mut line = String::new();
        adopted.from_flight.read_line(&mut line).unwrap();
        assert_eq!(line, "event warning-hi still flying\n");
        writeln!(adopted.to_flight, "stop").unwrap();
        assert_eq!(flight.join().unwrap(), "stop\n");
    }

    #[test]
    fn no_socket_or_a_stale_one_is_nothing_to_take_back_and_is_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.sock.flight");
        assert!(matches!(take_back(&path, ANSWER_WAIT), Ok(None)));
        // A socket whose process died: stale.
        drop(listen(&path).unwrap());
        assert!(path.exists());
        assert!(matches!(take_back(&path, ANSWER_WAIT), Ok(None)));
        let _again = listen(&path).unwrap();
    }

    #[test]
    fn a_live_flight_process_socket_refuses_a_second_flight_process() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.sock.flight");
        let _first = listen(&path).unwrap();
        let e = listen(&path).unwrap_err().to_string();
        assert!(e.contains("another flight process is running"), "{e}");
    }

    #[test]
    fn a_flight_process_killed_a_moment_ago_does_not_refuse_its_successor() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.sock.flight");
        let first = listen(&path).unwrap();
        let dying = std::thread::spawn(move || {
            std::thread::sleep(KILLED_WAIT / 3);
            drop(first);
        });
        assert!(listen(&path).is_ok());
        dying.join().unwrap();
    }

    #[test]
    fn a_flight_process_that_does_not_introduce_itself_is_not_taken_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.sock.flight");
        let listener = listen(&path).unwrap();
        let talk = |lines: &'static str| {
            let l = listener.try_clone().unwrap();
            std::thread::spawn(move || {
                let (mut s, _) = l.accept().unwrap();
                s.write_all(lines.as_bytes()).unwrap();
                std::thread::sleep(Duration::from_millis(300));
            })
        };
        let wait = Duration::from_millis(200);
        let cases = [
            ("", "did not introduce itself"),
            ("ready 1\n", "protocol version 1"),
            ("hello\n", "said 'hello'"),
            ("ready 4\nstarted (no log)\n", "said 'started (no log)'"),
            ("ready 4\nadopted 9 t1 manual\nnote x\n", "said 'note x'"),
        ];
        for (lines, why) in cases {
            let t = talk(lines);
            let e = take_back(&path, wait).unwrap_err().to_string();
            assert!(e.contains(why), "{lines:?}: {e}");
            t.join().unwrap();
        }
    }
}
