//! The processes of a trial: the HILSim and the bootstraps (with the flight processes they
//! start), each with every line it printed kept, and the signals the faults send them.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use heli_vehicle::ctl::Request;

use crate::FieldDayError;

/// Where the programs are.
#[derive(Clone, Debug)]
pub struct Programs {
    /// `heli` (for `heli hilsim`).
    pub heli: PathBuf,
    /// `heli-vehicle` (the bootstrap and the flight process).
    pub vehicle: PathBuf,
}

/// A running process whose standard output and error are kept line by line; killed when
/// dropped.
pub struct Proc {
    child: Child,
    stdin: Option<ChildStdin>,
    /// Standard output and error, as they came.
    lines: Arc<Mutex<Vec<String>>>,
    /// Standard output alone.
    out: Arc<Mutex<Vec<String>>>,
}

impl Proc {
    fn spawn(program: &Path, args: &[String]) -> Result<Self, FieldDayError> {
        let mut child = Command::new(program)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| FieldDayError::Io(format!("starting {}", program.display()), e))?;
        let lines = Arc::new(Mutex::new(Vec::new()));
        let out = Arc::new(Mutex::new(Vec::new()));
        let keep = |from: Box<dyn std::io::Read + Send>, only: Option<Arc<Mutex<Vec<String>>>>| {
            let sink = Arc::clone(&lines);
            std::thread::spawn(move || {
                for line in BufReader::new(from).lines().map_while(Result::ok) {
                    if let Some(only) = &only {
                        only.lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .push(line.clone());
                    }
                    sink.lock().unwrap_or_else(|e| e.into_inner()).push(line);
                }
            });
        };
        if let Some(stdout) = child.stdout.take() {
            keep(Box::new(stdout), Some(Arc::clone(&out)));
        }
        if let Some(err) = child.stderr.take() {
            keep(Box::new(err), None);
        }
        let stdin = child.stdin.take();
        Ok(Self {
            child,
            stdin,
            lines,
            out,
        })
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Every line so far.
    pub fn lines(&self) -> Vec<String> {
        self.lines.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Its standard output alone.
    pub fn stdout(&self) -> String {
        self.out
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .join("\n")
    }

    /// The first line containing `needle` at or after line `from`, waiting up to `timeout`.
    pub fn wait_for(
        &self,
        needle: &str,
        from: usize,
        timeout: Duration,
    ) -> Option<(usize, String)> {
        let end = Instant::now() + timeout;
        loop {
            let found = self
                .lines()
                .into_iter()
                .enumerate()
                .skip(from)
                .find(|(_, l)| l.contains(needle));
            if found.is_some() || Instant::now() > end {
                return found;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Writes one line to its standard input.
    pub fn tell(&mut self, line: &str) -> bool {
        self.stdin
            .as_mut()
            .is_some_and(|s| writeln!(s, "{line}").and_then(|()| s.flush()).is_ok())
    }

    /// Whether it has ended.
    pub fn ended(&mut self) -> bool {
        !matches!(self.child.try_wait(), Ok(None))
    }

    /// Waits up to `timeout` for it to end.
    pub fn wait_end(&mut self, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        while !self.ended() {
            if Instant::now() > end {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        true
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Sends `signal` to process `pid`.
pub fn signal(pid: u32, signal: nix::sys::signal::Signal) -> Result<(), FieldDayError> {
    let raw = i32::try_from(pid).map_err(|_| FieldDayError::Usage(format!("pid {pid}")))?;
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(raw), signal).map_err(|e| {
        FieldDayError::Io(
            format!("sending {signal} to {pid}"),
            std::io::Error::from(e),
        )
    })
}

/// `heli hilsim --ptys DEV --scenario SCENARIO --json --failures-stdin`, once its devices exist.
pub fn hilsim(
    programs: &Programs,
    dev: &Path,
    scenario: &str,
    seed: u64,
) -> Result<Proc, FieldDayError> {
    let args = [
        "hilsim",
        "--ptys",
        &dev.display().to_string(),
        "--scenario",
        scenario,
        "--seed",
        &seed.to_string(),
        "--duration",
        "900",
        "--json",
        "--failures-stdin",
    ]
    .map(str::to_string);
    let proc = Proc::spawn(&programs.heli, &args)?;
    proc.wait_for("hilsim: ready", 0, Duration::from_secs(15))
        .ok_or_else(|| {
            FieldDayError::Setup(format!(
                "the HILSim did not start:\n{}",
                proc.lines().join("\n")
            ))
        })?;
    Ok(proc)
}

/// Where a trial's vehicle keeps its things.
#[derive(Clone, Debug)]
pub struct VehiclePaths {
    /// The HILSim's devices.
    pub dev: PathBuf,
    /// The log directory.
    pub logs: PathBuf,
    /// The bootstrap's control socket.
    pub socket: PathBuf,
    /// The fallback directory (in RAM).
    pub fallback: PathBuf,
}

/// The bootstrap (`heli-vehicle`), as the init system starts it, with the documented
/// test-only shortening (1 s warm-up, 5 s calibration), once it listens.
pub fn bootstrap(programs: &Programs, paths: &VehiclePaths) -> Result<Proc, FieldDayError> {
    let args = [
        "--hilsim",
        &paths.dev.display().to_string(),
        "--log-dir",
        &paths.logs.display().to_string(),
        "--fallback-dir",
        &paths.fallback.display().to_string(),
        "--socket",
        &paths.socket.display().to_string(),
        "--warm-up-s",
        "1",
        "--calibration-s",
        "5",
        // A simulated field day flies the build under development: the bench's override.
        "--fly-untested",
    ]
    .map(str::to_string);
    let proc = Proc::spawn(&programs.vehicle, &args)?;
    proc.wait_for("bootstrap: listening", 0, Duration::from_secs(10))
        .ok_or_else(|| {
            FieldDayError::Setup(format!(
                "the bootstrap did not start:\n{}",
                proc.lines().join("\n")
            ))
        })?;
    Ok(proc)
}

/// One command to the bootstrap on `socket`; its reply in words (a refusal is an `Err`).
pub fn ctl(socket: &Path, line: &str) -> Result<String, String> {
    let request = Request::parse(line).map_err(|e| e.to_string())?;
    heli_vehicle::ctl::send(socket, &request).map_err(|e| e.to_string())
}

/// The flight process's pid, from the bootstrap's status.
pub fn flight_pid(socket: &Path) -> Option<u32> {
    let status = ctl(socket, "status").ok()?;
    let json: serde_json::Value = serde_json::from_str(status.strip_prefix("ok ")?).ok()?;
    json["pid"].as_u64().and_then(|p| u32::try_from(p).ok())
}
