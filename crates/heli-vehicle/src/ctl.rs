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

use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::Duration;

use heli_link::{GroundCommand, StartParameters};

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

impl Request {
    /// Parses a command line; the error says what is wrong.
    pub fn parse(line: &str) -> Result<Self, String> {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["connect"] => Ok(Request::Ground(GroundCommand::Connect)),
            ["stop"] => Ok(Request::Ground(GroundCommand::Stop)),
            ["status"] => Ok(Request::Ground(GroundCommand::TelemetryRequest)),
            ["quit"] => Ok(Request::Quit),
            ["start-logging", suffix, mode, rest @ ..] if rest.len() <= 1 => {
                let mut params = StartParameters::new(suffix, mode).map_err(|e| e.to_string())?;
                params.plan = rest.first().map(|p| (*p).to_string());
                Ok(Request::Ground(GroundCommand::StartLogging(params)))
            }
            ["start-logging", ..] => Err("usage: start-logging SUFFIX MODE [PLAN]".into()),
            [] => Err("empty command".into()),
            [other, ..] => Err(format!(
                "unknown command '{other}' (expected connect, start-logging, stop, status or quit)"
            )),
        }
    }

    /// The command line of this request.
    pub fn to_line(&self) -> String {
        match self {
            Request::Ground(GroundCommand::Connect) => "connect".into(),
            Request::Ground(GroundCommand::Stop) => "stop".into(),
            Request::Ground(GroundCommand::TelemetryRequest) => "status".into(),
            Request::Ground(GroundCommand::StartLogging(p)) => {
                let mut line = format!("start-logging {} {}", p.file_suffix, p.controller.name());
                if let Some(plan) = &p.plan {
                    line.push(' ');
                    line.push_str(plan);
                }
                line
            }
            Request::Ground(GroundCommand::Final(f)) => {
                format!("final {} {}", f.base_directory, f.file_suffix)
            }
            Request::Quit => "quit".into(),
        }
    }
}

/// Sends `request` to the bootstrap listening on `socket` and returns its reply. `Err` when
/// the bootstrap cannot be reached or answered `error`.
pub fn send(socket: &Path, request: &Request) -> Result<String, String> {
    let mut stream = UnixStream::connect(socket).map_err(|e| {
        format!(
            "control socket {}: {e} (is `heli vehicle` running with this --socket?)",
            socket.display()
        )
    })?;
    stream
        .set_read_timeout(Some(REPLY_TIMEOUT))
        .map_err(|e| e.to_string())?;
    writeln!(stream, "{}", request.to_line()).map_err(|e| e.to_string())?;
    let mut reply = String::new();
    BufReader::new(stream)
        .read_line(&mut reply)
        .map_err(|e| format!("no reply from the bootstrap: {e}"))?;
    let reply = reply.trim_end().to_string();
    match reply.strip_prefix("error") {
        Some(rest) => Err(rest.trim_start().to_string()),
        None if reply.is_empty() => Err("the bootstrap closed the connection".into()),
        None => Ok(reply),
    }
}

/// Accepts control connections on the bootstrap's socket: one request line, one reply line.
pub fn serve(
    listener: &std::os::unix::net::UnixListener,
    bootstrap: &crate::bootstrap::RequestHandle,
    written: &std::sync::mpsc::Sender<()>,
) {
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        // One thread a connection, with a read timeout: an idle client holds up no one.
        let bootstrap = bootstrap.clone();
        let written = written.clone();
        let _ = std::thread::Builder::new()
            .name("ctl-conn".into())
            .spawn(move || serve_one(stream, &bootstrap, &written));
    }
}

/// One control connection: one request line, one reply line.
fn serve_one(
    mut stream: UnixStream,
    bootstrap: &crate::bootstrap::RequestHandle,
    written: &std::sync::mpsc::Sender<()>,
) {
    let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
    let mut line = String::new();
    let read = stream
        .try_clone()
        .map(BufReader::new)
        .and_then(|mut r| r.read_line(&mut line));
    if read.is_err() {
        return;
    }
    let reply = match Request::parse(&line) {
        // The reply may wait for the flight process (connect, stop).
        Ok(request) => bootstrap
            .send(request)
            .recv()
            .unwrap_or_else(|_| "error the bootstrap is ending".into()),
        Err(e) => format!("error {e}"),
    };
    let _ = writeln!(stream, "{reply}");
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
        ] {
            assert_eq!(Request::parse(line).unwrap().to_line(), line);
        }
        assert!(
            Request::parse("start-logging ../x manual")
                .unwrap_err()
                .contains("suffix")
        );
        assert!(
            Request::parse("start-logging a loop")
                .unwrap_err()
                .contains("loop")
        );
        assert!(
            Request::parse("fly")
                .unwrap_err()
                .contains("unknown command")
        );
        for usage in [
            "start-logging",
            "start-logging f1",
            "start-logging f1 autonomous hover x",
        ] {
            assert!(
                Request::parse(usage).unwrap_err().contains("usage"),
                "{usage}"
            );
        }
        assert_eq!(Request::parse("  ").unwrap_err(), "empty command");
    }

    #[test]
    fn a_bootstrap_that_closes_without_a_reply_or_is_not_there_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let socket = dir.path().join("ctl.sock");
        let e = send(&socket, &Request::Quit).unwrap_err();
        assert!(e.contains("is `heli vehicle` running"), "{e}");
        let listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        let server = std::thread::spawn(move || {
            let (stream, _) = listener.accept().unwrap();
            let mut line = String::new();
            let _ = BufReader::new(&stream).read_line(&mut line);
            line
        });
        assert_eq!(
            send(&socket, &Request::Quit).unwrap_err(),
            "the bootstrap closed the connection"
        );
        assert_eq!(server.join().unwrap(), "quit\n");
    }
}
