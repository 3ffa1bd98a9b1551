//! The processes of a HIL test: `heli hilsim`, the onboard `heli-vehicle`, and readers of their output.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The log's flush interval (ms): heli-log closes a chunk at least this often.
pub const FLUSH_INTERVAL_MS: f64 = heli_log::FLUSH_EVERY_US as f64 / 1000.0;

/// Runs `heli ARGS` to completion.
pub fn heli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"))
}

/// `heli ARGS` as a process whose output is collected.
pub fn heli_process(args: &[&str]) -> Lines {
    Lines::spawn(&args.iter().map(|s| s.to_string()).collect::<Vec<_>>())
}

/// The onboard program, `heli-vehicle`, which the HIL tests fly: the binary of the
/// heli-vehicle package, built beside `heli` by `cargo test --workspace` (or `cargo build -p
/// heli-vehicle`; a test run of this package alone does not build it).
pub fn vehicle_program() -> PathBuf {
    let path = Path::new(env!("CARGO_BIN_EXE_heli")).with_file_name("heli-vehicle");
    assert!(
        path.exists(),
        "{} is missing: run the tests with --workspace (or cargo build -p heli-vehicle with the same profile)",
        path.display()
    );
    path
}

/// A process whose standard output and standard error are collected line by line (killed
/// when dropped).
pub struct Lines {
    child: Child,
    lines: Arc<Mutex<Vec<String>>>,
    errors: Arc<Mutex<Vec<String>>>,
}

thread_local! {
    /// The standard error of every process this test's thread started, to tell afterwards
    /// whether a HILSim among them was starved.
    static STARTED: std::cell::RefCell<Vec<Arc<Mutex<Vec<String>>>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// The latest a HILSim started by this test's thread said a device write of its left (ms),
/// from its `hilsim: behind: a device write left X ms late` lines.
fn worst_behind_ms() -> f64 {
    STARTED.with(|started| {
        started
            .borrow()
            .iter()
            .flat_map(|errors| errors.lock().unwrap().clone())
            .filter_map(|line| {
                let rest = line.strip_prefix("hilsim: behind: a device write left ")?;
                rest.split_whitespace().next()?.parse::<f64>().ok()
            })
            .fold(0.0, f64::max)
    })
}

/// Tries of a HIL test in all when the machine starves its HILSim: as `heli field-day`'s
/// trials.
const TRIES: usize = heli_fieldday::TRIES;

/// Runs `test`; when it fails and a HILSim it started was starved past
/// [`heli_sim::hil::STARVED`] (the IMU's silence limit), the machine stopped the world, not
/// the flight software: the run is void, said so, and the test runs again, up to [`TRIES`]
/// in all (as `heli field-day` does with its trials). The last try's verdict is final, a
/// failure through starvation included: a machine that never kept the HILSim in real time
/// judged nothing, and says so.
pub fn void_if_starved(test: impl Fn()) {
    let starved_ms = heli_sim::hil::STARVED.as_secs_f64() * 1e3;
    for tried in 1..=TRIES {
        STARTED.with(|started| started.borrow_mut().clear());
        let Err(failure) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(&test)) else {
            return;
        };
        let worst = worst_behind_ms();
        if worst <= starved_ms {
            std::panic::resume_unwind(failure);
        }
        if tried == TRIES {
            eprintln!(
                "each of {TRIES} tries failed with its HILSim starved (the last {worst:.0} ms): the machine could not keep the HILSim in real time"
            );
            std::panic::resume_unwind(failure);
        }
        eprintln!(
            "VOID (try {tried} of {TRIES}): a HILSim of this test was starved {worst:.0} ms by the machine (over the IMU's {starved_ms:.0} ms silence limit); the test runs again"
        );
    }
}

impl Lines {
    fn spawn(args: &[String]) -> Self {
        Self::spawn_program(Path::new(env!("CARGO_BIN_EXE_heli")), args)
    }

    fn spawn_program(program: &Path, args: &[String]) -> Self {
        let mut child = Command::new(program)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", program.display()));
        let collect = |from: Box<dyn std::io::Read + Send>, echo: bool| {
            let lines = Arc::new(Mutex::new(Vec::new()));
            let sink = Arc::clone(&lines);
            std::thread::spawn(move || {
                for line in BufReader::new(from).lines().map_while(Result::ok) {
                    if echo {
                        eprintln!("{line}");
                    }
                    sink.lock().unwrap().push(line);
                }
            });
            lines
        };
        let lines = collect(Box::new(child.stdout.take().unwrap()), false);
        // Standard error is shown as before, and kept to be searched.
        let errors = collect(Box::new(child.stderr.take().unwrap()), true);
        STARTED.with(|started| started.borrow_mut().push(Arc::clone(&errors)));
        Self {
            child,
            lines,
            errors,
        }
    }

    /// The first line containing `needle`, waiting up to `timeout` for it.
    pub fn wait_for(&self, needle: &str, timeout: Duration) -> String {
        let end = Instant::now() + timeout;
        while Instant::now() < end {
            for lines in [&self.lines, &self.errors] {
                if let Some(l) = lines.lock().unwrap().iter().find(|l| l.contains(needle)) {
                    return l.clone();
                }
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!(
            "no line with '{needle}' within {timeout:?}; got:\n{}",
            self.all()
        );
    }

    fn all(&self) -> String {
        let mut all = self.lines.lock().unwrap().clone();
        all.extend(self.errors.lock().unwrap().iter().cloned());
        all.join("\n")
    }

    fn stdout(&self) -> String {
        self.lines.lock().unwrap().join("\n")
    }
}

impl Drop for Lines {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A running `heli hilsim --ptys`.
pub struct Hilsim {
    proc: Lines,
    /// Its device directory.
    pub dev: PathBuf,
}

impl Hilsim {
    /// Starts the HILSim flying `scenario` for `duration_s` at `speed`, and waits until its
    /// devices exist.
    pub fn start(dir: &Path, scenario: &str, speed: f64, duration_s: f64) -> Self {
        Self::start_with(dir, scenario, speed, duration_s)
    }

    /// The same; kept apart so a faster-than-real-time run reads as such.
    pub fn start_with(dir: &Path, scenario: &str, speed: f64, duration_s: f64) -> Self {
        let (speed, duration) = (speed.to_string(), duration_s.to_string());
        Self::spawn(
            dir,
            &[
                "--scenario",
                scenario,
                "--speed",
                &speed,
                "--duration",
                &duration,
            ],
        )
    }

    /// Starts the HILSim in real time with `extra` arguments.
    pub fn start_args(dir: &Path, scenario: &str, duration_s: f64, extra: &[&str]) -> Self {
        let duration = duration_s.to_string();
        let mut args = vec!["--scenario", scenario, "--duration", &duration];
        args.extend_from_slice(extra);
        Self::spawn(dir, &args)
    }

    /// Starts `heli hilsim --replay FLIGHT --speed SPEED` (its comparison printed as JSON at
    /// the end), and waits until its devices exist.
    pub fn replay(dir: &Path, flight: &Path, speed: f64) -> Self {
        let (flight, speed) = (flight.display().to_string(), speed.to_string());
        Self::spawn(
            dir,
            &["--replay", &flight, "--wait-s", "30", "--speed", &speed],
        )
    }

    /// `heli hilsim --ptys DIR/dev ARGS --json`, once its devices exist.
    fn spawn(dir: &Path, extra: &[&str]) -> Self {
        let dev = dir.join("dev");
        let mut args = vec![
            "hilsim".to_string(),
            "--ptys".to_string(),
            dev.display().to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        args.push("--json".to_string());
        let proc = Lines::spawn(&args);
        proc.wait_for("hilsim: ready", Duration::from_secs(10));
        Self { proc, dev }
    }

    /// Everything the HILSim printed so far (standard output and error).
    pub fn output(&self) -> String {
        self.proc.all()
    }

    /// The HILSim's pid.
    pub fn pid(&self) -> u32 {
        self.proc.child.id()
    }

    /// Waits for the end of the run and returns its JSON truth summary.
    pub fn wait_json(self, timeout: Duration) -> serde_json::Value {
        self.wait_end(timeout).0
    }

    /// As [`Hilsim::wait_json`], with everything it printed (standard output and error).
    pub fn wait_end(mut self, timeout: Duration) -> (serde_json::Value, String) {
        let end = Instant::now() + timeout;
        loop {
            if let Some(status) = self.proc.child.try_wait().unwrap() {
                // Give the reader a moment to take the last lines.
                std::thread::sleep(Duration::from_millis(200));
                // With --json its standard output is the JSON document and nothing else.
                let json = self.proc.stdout();
                let summary = serde_json::from_str(&json).unwrap_or_else(|e| {
                    panic!(
                        "hilsim ended ({status}) without a JSON summary alone on its standard output ({e}):\n{json}\n{}",
                        self.proc.all()
                    )
                });
                return (summary, self.proc.all());
            }
            assert!(
                Instant::now() < end,
                "hilsim still running after {timeout:?}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// A running `heli-vehicle` (the bootstrap of the onboard program) against a HILSim.
pub struct Vehicle {
    proc: Lines,
    socket: PathBuf,
}

impl Vehicle {
    /// Starts the bootstrap with the test-only short calibration.
    pub fn start(dir: &Path, dev: &Path) -> Self {
        Self::start_with(dir, dev, 1.0)
    }

    /// Starts the bootstrap with its flight clock running `clock_speed` times real time.
    pub fn start_with(dir: &Path, dev: &Path, clock_speed: f64) -> Self {
        Self::start_full(dir, dev, clock_speed, &[])
    }

    /// Starts the bootstrap serving the MAVLink link on `link` (`udp:HOST:PORT`), signed
    /// with the key file `key` when one is given.
    pub fn start_linked(dir: &Path, dev: &Path, link: &str, key: Option<&Path>) -> Self {
        let mut extra = vec!["--link".to_string(), link.to_string()];
        if let Some(key) = key {
            extra.extend(["--key".to_string(), key.display().to_string()]);
        }
        Self::start_full(dir, dev, 1.0, &extra)
    }

    /// Starts the bootstrap linked as [`Vehicle::start_linked`], with `extra` arguments.
    pub fn start_linked_with(
        dir: &Path,
        dev: &Path,
        link: &str,
        key: &Path,
        extra: &[&str],
    ) -> Self {
        let mut args = vec![
            "--link".to_string(),
            link.to_string(),
            "--key".to_string(),
            key.display().to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        Self::start_full(dir, dev, 1.0, &args)
    }

    /// Starts the bootstrap as a vehicle in the field: linked and keyed, judging its build
    /// and parameters against the lab's attestation in its log directory, with no bench
    /// override (`--fly-untested`): an augmented or autonomous flight on a configuration
    /// that is not lab-tested needs the operator's override.
    pub fn start_in_the_field(dir: &Path, dev: &Path, link: &str, key: &Path) -> Self {
        let extra = [
            "--link".to_string(),
            link.to_string(),
            "--key".to_string(),
            key.display().to_string(),
        ];
        Self::start_args(dir, dev, 1.0, &extra, false)
    }

    /// The HIL tests fly the build under test: the bench's standing override of the
    /// lab-tested check (`--fly-untested`).
    fn start_full(dir: &Path, dev: &Path, clock_speed: f64, extra: &[String]) -> Self {
        Self::start_args(dir, dev, clock_speed, extra, true)
    }

    fn start_args(dir: &Path, dev: &Path, clock_speed: f64, extra: &[String], bench: bool) -> Self {
        let socket = dir.join("ctl.sock");
        let mut args: Vec<String> = [
            "--hilsim",
            &dev.display().to_string(),
            "--log-dir",
            &dir.display().to_string(),
            "--socket",
            &socket.display().to_string(),
            "--warm-up-s",
            "1",
            "--calibration-s",
            "5",
            "--clock-speed",
            &clock_speed.to_string(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        args.extend_from_slice(extra);
        if bench {
            args.push("--fly-untested".into());
        }
        let proc = Lines::spawn_program(&vehicle_program(), &args);
        proc.wait_for("bootstrap: listening", Duration::from_secs(10));
        Self { proc, socket }
    }

    /// Sends one control command; returns the reply (stdout, or stderr on failure).
    pub fn ctl(&self, words: &[&str]) -> String {
        let mut args = vec!["ctl"];
        args.extend_from_slice(words);
        let socket = self.socket.display().to_string();
        args.extend(["--socket", &socket]);
        let out = Command::new(vehicle_program())
            .args(&args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run heli-vehicle: {e}"));
        let text = if out.status.success() {
            out.stdout
        } else {
            out.stderr
        };
        String::from_utf8_lossy(&text).trim().to_string()
    }

    /// The bootstrap's own pid.
    pub fn pid(&self) -> u32 {
        self.proc.child.id()
    }

    /// The flight process's pid.
    pub fn child_pid(&self) -> u32 {
        let status = self.ctl(&["status"]);
        let json: serde_json::Value =
            serde_json::from_str(status.trim_start_matches("ok ")).unwrap();
        json["pid"]
            .as_u64()
            .unwrap_or_else(|| panic!("no pid in {status}")) as u32
    }

    /// Waits for a line of the bootstrap's output.
    pub fn wait_for_line(&self, needle: &str, timeout: Duration) -> String {
        self.proc.wait_for(needle, timeout)
    }

    /// Everything the bootstrap printed so far: its own lines and the flight process's
    /// notes and events, for a failing test to show why.
    pub fn output(&self) -> String {
        self.proc.all()
    }

    /// Ends the bootstrap.
    pub fn quit(self) {
        let reply = self.ctl(&["quit"]);
        assert!(reply.starts_with("ok"), "{reply}");
    }
}

impl Drop for Vehicle {
    /// The flight process outlives its bootstrap by design (the init system's new bootstrap
    /// takes it back), so a test that ends — passed, failed, or panicking with the
    /// helicopter in the air — ends every process of its vehicle: otherwise the flight process
    /// flies on at real-time priority beside the next tests and starves them.
    fn drop(&mut self) {
        kill_mentioning(&self.socket.display().to_string());
    }
}

/// `SIGKILL` to every process (but this one) whose command line mentions `needle`.
fn kill_mentioning(needle: &str) {
    let me = std::process::id();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return;
    };
    for entry in entries.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        if pid as u32 == me {
            continue;
        }
        let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) else {
            continue;
        };
        if String::from_utf8_lossy(&cmdline).contains(needle) {
            let _ = Command::new("kill").args(["-9", &pid.to_string()]).status();
        }
    }
}

/// Stops process `pid` (`SIGSTOP`) for `pause`, then lets it go on (`SIGCONT`): every device
/// line of a HILSim falls silent at once, and comes back.
pub fn stall(pid: u32, pause: Duration) {
    let signal = |name: &str| {
        let status = Command::new("kill")
            .args([name, &pid.to_string()])
            .status()
            .unwrap();
        assert!(status.success(), "kill {name} {pid}");
    };
    signal("-STOP");
    std::thread::sleep(pause);
    signal("-CONT");
}

/// `kill -9 PID`.
pub fn kill9(pid: u32) {
    let status = Command::new("kill")
        .args(["-9", &pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

/// `heli log info FILE`, which must succeed.
pub fn log_info(log: &Path) -> String {
    let out = heli(&["log", "info", &log.display().to_string()]);
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "heli log info {}: {}{}",
        log.display(),
        text,
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The rate (Hz) `heli log info` gives a channel.
pub fn channel_rate(info: &str, channel: &str) -> Option<f64> {
    info.lines().find_map(|l| {
        let words: Vec<&str> = l.split_whitespace().collect();
        match words.as_slice() {
            [name, _, "messages", rate, "Hz", ..] if *name == channel => rate.parse().ok(),
            _ => None,
        }
    })
}

/// The flight's wall-clock start (Unix ms) and the time of its last message (s of flight
/// clock), from `heli log info`.
pub fn log_span(log: &Path) -> (f64, f64) {
    let info = log_info(log);
    let start = info
        .lines()
        .find_map(|l| l.trim().strip_prefix("wall_clock_start_unix_ms"))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no wall-clock start in\n{info}"));
    let last = info
        .lines()
        .find_map(|l| {
            let words: Vec<&str> = l.split_whitespace().collect();
            match words.as_slice() {
                ["time", _, "s", "to", last, "s", ..] => last.parse::<f64>().ok(),
                _ => None,
            }
        })
        .unwrap_or_else(|| panic!("no time span in\n{info}"));
    (start, last)
}

/// The official Python `mcap` reader reads every message of the log (when `.ci/run` or the
/// developer installed it and named it in `HELI_MCAP_PYTHON`).
pub fn python_reads(log: &Path) {
    let Ok(python) = std::env::var("HELI_MCAP_PYTHON") else {
        eprintln!("note: HELI_MCAP_PYTHON not set; the official Python reader was not tried");
        return;
    };
    let n = heli_fieldday::judge::python_reads(std::path::Path::new(&python), log)
        .unwrap_or_else(|e| panic!("python mcap could not read {}: {e}", log.display()));
    assert!(
        n > 100,
        "python mcap read only {n} messages of {}",
        log.display()
    );
}

/// A free UDP port on the loopback (taken and let go: nothing else on this machine is
/// expected to grab it in between).
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .unwrap_or_else(|e| panic!("no UDP port: {e}"))
}

/// Runs `heli ground ARGS --link LINK [--key KEY]`; returns (success, stdout + stderr).
pub fn ground(link: &str, key: Option<&Path>, args: &[&str]) -> (bool, String) {
    let mut all: Vec<String> = vec!["ground".into()];
    all.extend(args.iter().map(|s| s.to_string()));
    all.extend(["--link".into(), link.into()]);
    if let Some(key) = key {
        all.extend(["--key".into(), key.display().to_string()]);
    }
    let refs: Vec<&str> = all.iter().map(String::as_str).collect();
    let out = heli(&refs);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// A running `heli ground --http` (the operator's display).
pub struct Display {
    proc: Lines,
    /// The operator's address, `http://127.0.0.1:PORT/?key=…`.
    pub url: String,
    /// An observer's address (watch only), with the observer's key.
    pub observer_url: String,
}

impl Display {
    /// Starts the display on a free port for the vehicle at `link`, saving logs below
    /// `save_root`.
    pub fn start(link: &str, key: Option<&Path>, save_root: &Path) -> Self {
        let mut args: Vec<String> = [
            "ground",
            "--link",
            link,
            "--http",
            "127.0.0.1:0",
            "--save-root",
            &save_root.display().to_string(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        if let Some(key) = key {
            args.extend(["--key".to_string(), key.display().to_string()]);
        }
        let proc = Lines::spawn(&args);
        let line = proc.wait_for("ground: display at ", Duration::from_secs(10));
        let url_in = |line: &str| {
            line.split_whitespace()
                .find(|w| w.starts_with("http://"))
                .unwrap_or_else(|| panic!("no address in {line}"))
                .to_string()
        };
        let url = url_in(&line);
        let observer_url = url_in(&proc.wait_for("ground: observers", Duration::from_secs(10)));
        Self {
            proc,
            url,
            observer_url,
        }
    }

    /// Stops it with SIGTERM, as Ctrl-C would; returns whether it said it stopped.
    pub fn stop(mut self) -> bool {
        let _ = Command::new("kill")
            .args(["-TERM", &self.proc.child.id().to_string()])
            .status();
        let end = Instant::now() + Duration::from_secs(10);
        while Instant::now() < end {
            if let Ok(Some(_)) = self.proc.child.try_wait() {
                std::thread::sleep(Duration::from_millis(100));
                return self.proc.all().contains("ground: stopped");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }
}
