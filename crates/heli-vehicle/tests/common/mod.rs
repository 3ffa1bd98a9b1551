//! What the bootstrap's tests share: a bootstrap running on a thread with stand-in flight
//! processes, and waiting for what it says.

#![allow(dead_code, clippy::unwrap_used, clippy::panic)]

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use heli_vehicle::bootstrap::{Bootstrap, BootstrapConfig, Said};
use heli_vehicle::ctl::{Request, send};

/// A flight process that says ready, answers start/restart with started, records what it
/// was told in `told`, and crashes (exit 3) a moment later.
pub fn crashing_child(told: &Path) -> Vec<std::ffi::OsString> {
    let script = format!(
        "echo ready 4; read line; echo \"$line\" >> {}; echo started /dev/null; sleep 0.3; exit 3",
        told.display()
    );
    vec!["sh".into(), "-c".into(), script.into()]
}

pub struct Running {
    pub socket: std::path::PathBuf,
    pub lines: Arc<Mutex<Vec<String>>>,
    pub thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    pub fn start(dir: &Path, child: Vec<std::ffi::OsString>, warm_file: Option<&Path>) -> Self {
        Self::start_with(dir, child, warm_file, |b| b)
    }

    /// Starts a bootstrap made by `build` from the plain one (timeouts, a link).
    pub fn start_with(
        dir: &Path,
        child: Vec<std::ffi::OsString>,
        warm_file: Option<&Path>,
        build: impl FnOnce(Bootstrap) -> Bootstrap + Send + 'static,
    ) -> Self {
        let config = BootstrapConfig {
            socket: dir.join("ctl.sock"),
            child,
            warm_files: warm_file.map(Path::to_path_buf).into_iter().collect(),
            adopt_socket: None,
        };
        Self::start_config(config, build)
    }

    /// Starts a bootstrap of `config`, made by `build` from the plain one.
    pub fn start_config(
        config: BootstrapConfig,
        build: impl FnOnce(Bootstrap) -> Bootstrap + Send + 'static,
    ) -> Self {
        let socket = config.socket.clone();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&lines);
        let report = Box::new(move |l: &Said| sink.lock().unwrap().push(l.to_string()));
        let thread =
            std::thread::spawn(move || build(Bootstrap::new(config, report)).run().unwrap());
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

    pub fn ctl(&self, line: &str) -> Result<String, String> {
        let request = Request::parse(line).map_err(|e| e.to_string())?;
        send(&self.socket, &request).map_err(|e| e.to_string())
    }

    pub fn count(&self, needle: &str) -> usize {
        self.lines
            .lock()
            .unwrap()
            .iter()
            .filter(|l| l.contains(needle))
            .count()
    }

    pub fn wait_count(&self, needle: &str, n: usize, timeout: Duration) {
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

pub fn status(boot: &Running) -> serde_json::Value {
    let reply = boot.ctl("status").unwrap();
    let json = reply
        .strip_prefix("ok ")
        .unwrap_or_else(|| panic!("{reply}"));
    serde_json::from_str(json).unwrap()
}

pub fn alive(pid: u64) -> bool {
    std::path::Path::new(&format!("/proc/{pid}")).exists()
}

pub fn wait_until(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let started = Instant::now();
    while !done() {
        assert!(
            started.elapsed() < timeout,
            "{what}: not within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}
