//! The bootstrap's supervision of the flight process, with a stand-in flight process (a
//! shell script speaking the same lines): a process that crashes in flight is started
//! again with `restart` and the same parameters, at most three times a minute; a fresh
//! warm-start record of a flying helicopter resumes the flight at power-on.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use heli_vehicle::bootstrap::{Bootstrap, BootstrapConfig, MAX_RESTARTS};
use heli_vehicle::ctl::{Request, send};

/// A flight process that says ready, answers start/restart with started, records what it
/// was told in `told`, and crashes (exit 3) a moment later.
fn crashing_child(told: &Path) -> Vec<std::ffi::OsString> {
    let script = format!(
        "echo ready; read line; echo \"$line\" >> {}; echo started /dev/null; sleep 0.3; exit 3",
        told.display()
    );
    vec!["sh".into(), "-c".into(), script.into()]
}

struct Running {
    socket: std::path::PathBuf,
    lines: Arc<Mutex<Vec<String>>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    fn start(dir: &Path, child: Vec<std::ffi::OsString>, warm_file: Option<&Path>) -> Self {
        let socket = dir.join("ctl.sock");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let config = BootstrapConfig {
            socket: socket.clone(),
            child,
            warm_file: warm_file.map(Path::to_path_buf),
        };
        let sink = Arc::clone(&lines);
        let report = Box::new(move |l: &str| sink.lock().unwrap().push(l.to_string()));
        let thread = std::thread::spawn(move || Bootstrap::new(config, report).run().unwrap());
        let started = Instant::now();
        while !socket.exists() && started.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(10));
        }
        Self {
            socket,
            lines,
            thread: Some(thread),
        }
    }

    fn ctl(&self, line: &str) -> Result<String, String> {
        send(&self.socket, &Request::parse(line)?)
    }

    fn count(&self, needle: &str) -> usize {
        self.lines
            .lock()
            .unwrap()
            .iter()
            .filter(|l| l.contains(needle))
            .count()
    }

    fn wait_count(&self, needle: &str, n: usize, timeout: Duration) {
        let started = Instant::now();
        while self.count(needle) < n {
            assert!(
                started.elapsed() < timeout,
                "{n} x '{needle}' not seen in {:#?}",
                self.lines.lock().unwrap()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.ctl("quit");
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn a_process_crashing_in_flight_is_restarted_with_its_parameters_three_times_a_minute() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let boot = Running::start(dir.path(), crashing_child(&told), None);
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    let reply = boot.ctl("start-logging crash1 autonomous hover").unwrap();
    assert!(reply.starts_with("ok flying"), "{reply}");
    boot.wait_count("not restarting", 1, Duration::from_secs(10));
    assert_eq!(boot.count("CRASHED"), MAX_RESTARTS + 1);
    assert_eq!(boot.count("restarting the flight process"), MAX_RESTARTS);
    let told = std::fs::read_to_string(&told).unwrap();
    let expected: Vec<String> = std::iter::once("start crash1 autonomous hover".to_string())
        .chain((0..MAX_RESTARTS).map(|_| "restart crash1 autonomous hover".to_string()))
        .collect();
    assert_eq!(told.lines().collect::<Vec<_>>(), expected);
}

#[test]
fn a_crash_before_start_logging_is_not_restarted() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let script = "echo ready; sleep 0.2; exit 3".to_string();
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    boot.wait_count("CRASHED", 1, Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(boot.count("restarting"), 0);
    assert!(!told.exists());
}

#[test]
fn power_on_with_a_fresh_record_of_a_flying_helicopter_resumes_the_flight() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let warm = dir.path().join("warm-start");
    std::fs::write(
        &warm,
        "start = bo1 autonomous hover\nairborne = true\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    let boot = Running::start(dir.path(), crashing_child(&told), Some(&warm));
    boot.wait_count("resuming the flight in the air", 1, Duration::from_secs(5));
    boot.wait_count("CRASHED", 1, Duration::from_secs(5));
    let text = std::fs::read_to_string(&told).unwrap();
    assert_eq!(text.lines().next(), Some("restart bo1 autonomous hover"));
    drop(boot);
    // A record of a helicopter on the ground is no reason to start anything.
    let dir = tempfile::tempdir().unwrap();
    let warm = dir.path().join("warm-start");
    std::fs::write(
        &warm,
        "start = bo1 autonomous hover\nairborne = false\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    let boot = Running::start(dir.path(), crashing_child(&told), Some(&warm));
    boot.wait_count("not resuming", 1, Duration::from_secs(5));
    assert_eq!(boot.count("flight process started"), 0);
}
