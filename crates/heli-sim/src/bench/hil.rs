//! `heli bench --hil SECONDS`: the end-to-end HIL path and the flight process's load, on this
//! machine. The HILSim runs in this process; the flight process (the onboard program's
//! `flight`, as the bootstrap would start it) runs beside it on the HILSim's
//! pseudo-terminals.
//!
//! - Latency: from the HILSim writing the last byte of an IMU packet to its terminal until a
//!   whole servo packet can be read back from the servo board's terminal.
//! - Load: the flight process's CPU time over the flight's wall time (from
//!   `/proc/PID/stat`), and its resident memory (`VmRSS`, peak `VmHWM`).

use std::ffi::OsString;
use std::io::{Error, Result, Write};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use heli_vehicle::supervisor::ToFlight;
use serde::Serialize;

use crate::hil::{self, HilOptions};

/// What `heli bench --hil` measured.
#[derive(Serialize)]
pub struct HilBench {
    /// Flight length (s).
    pub seconds: f64,
    /// The HIL run's truth outcome.
    pub outcome: String,
    /// Servo packets read back.
    pub servo_packets: u64,
    /// IMU write → servo packet readable (µs).
    pub latency_us: crate::summary::Percentiles,
    /// The flight process's CPU time over wall time (%, of one core).
    pub flight_cpu_percent: f64,
    /// Its resident memory at the end (MiB).
    pub flight_rss_mib: f64,
    /// Its peak resident memory (MiB).
    pub flight_peak_rss_mib: f64,
}

/// CPU time (s) of a process from `/proc/PID/stat` (utime + stime, in clock ticks of 1/100 s).
fn cpu_seconds(pid: u32) -> Result<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))?;
    // Fields after the command name, which is in parentheses and may hold spaces.
    let rest = stat
        .rsplit_once(')')
        .map(|(_, r)| r)
        .ok_or_else(|| Error::other("odd /proc stat"))?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| -> Result<f64> {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .map(|t| t / 100.0)
            .ok_or_else(|| Error::other("short /proc stat"))
    };
    // utime and stime are fields 14 and 15 of stat, 11 and 12 after the name.
    Ok(tick(11)? + tick(12)?)
}

/// A `/proc/PID/status` memory line, in MiB.
fn status_mib(pid: u32, key: &str) -> Result<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))?;
    let kb = status
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .ok_or_else(|| Error::other(format!("no {key} in /proc/{pid}/status")))?;
    Ok(kb / 1024.0)
}

/// Flies the hover scenario for `seconds` in real time against the flight process that
/// `flight` starts (the program and its first arguments: `heli-vehicle flight`), and
/// measures.
pub fn run(seconds: f64, flight: &[OsString]) -> Result<HilBench> {
    if !(seconds.is_finite() && (10.0..=3600.0).contains(&seconds)) {
        return Err(Error::other(format!(
            "--hil {seconds}: give 10 to 3600 seconds"
        )));
    }
    let (program, first_args) = flight
        .split_first()
        .ok_or_else(|| Error::other("no flight process program"))?;
    let dir = std::env::temp_dir().join(format!("heli-bench-hil-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let dev = dir.join("dev");
    let scenario = heli_scenario::load("hover").map_err(Error::other)?;
    let stop = Arc::new(AtomicBool::new(false));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let sim = {
        let dev = dev.clone();
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let options = HilOptions {
                speed: 1.0,
                duration_s: Some(seconds),
            };
            hil::run(
                scenario,
                &dev,
                options,
                &stop,
                |_| {
                    let _ = ready_tx.send(());
                },
                |_| {},
            )
        })
    };
    ready_rx
        .recv_timeout(Duration::from_secs(10))
        .map_err(|_| Error::other("the HILSim did not start"))?;
    let mut child = Command::new(program)
        .args(first_args)
        .arg("--hilsim")
        .arg(&dev)
        .arg("--log-dir")
        .arg(&dir)
        .args(["--calibration-s", "5", "--warm-up-s", "1", "--fly-untested"])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| Error::new(e.kind(), format!("starting the flight process: {e}")))?;
    let pid = child.id();
    let mut stdin = child
        .stdin
        .take()
        .ok_or_else(|| Error::other("the flight process has no stdin"))?;
    let mut start = heli_link::StartParameters::new("bench", "autonomous").map_err(Error::other)?;
    start.plan = Some("hover".into());
    writeln!(stdin, "{}", ToFlight::Start(start))?;
    let started = Instant::now();
    let cpu_start = cpu_seconds(pid)?;
    let summary = sim
        .join()
        .map_err(|_| Error::other("the HILSim thread panicked"))?
        .map_err(Error::other)?;
    let wall = started.elapsed().as_secs_f64();
    let cpu = cpu_seconds(pid)? - cpu_start;
    let rss = status_mib(pid, "VmRSS:")?;
    let peak = status_mib(pid, "VmHWM:")?;
    let _ = writeln!(stdin, "{}", ToFlight::Stop);
    drop(stdin);
    let _ = child.wait();
    stop.store(true, Ordering::Release);
    let _ = std::fs::remove_dir_all(&dir);
    let hil = summary.hil.clone().unwrap_or_default();
    Ok(HilBench {
        seconds,
        outcome: format!("{:?}", summary.outcome).to_lowercase(),
        servo_packets: hil.servo_packets,
        latency_us: hil.latency_us,
        flight_cpu_percent: 100.0 * cpu / wall.max(1e-9),
        flight_rss_mib: rss,
        flight_peak_rss_mib: peak,
    })
}

/// Prints the measurement as a table.
pub fn print(b: &HilBench) {
    let l = &b.latency_us;
    println!(
        "HIL hover, {:.0} s real time ({}): {} servo packets",
        b.seconds, b.outcome, b.servo_packets
    );
    println!(
        "  IMU byte written -> servo packet readable: p50 {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us ({} samples)",
        l.p50, l.p99, l.p999, l.max, l.samples
    );
    println!(
        "  flight process: {:.1} % of one core, RSS {:.1} MiB (peak {:.1} MiB)",
        b.flight_cpu_percent, b.flight_rss_mib, b.flight_peak_rss_mib
    );
}
