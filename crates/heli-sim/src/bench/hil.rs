//! `heli bench --hil SECONDS`: the end-to-end HIL path and the flight process's load, on this
//! machine. The HILSim runs in this process; the flight process (the onboard program's
//! `flight`, as the bootstrap would start it) runs beside it on the HILSim's
//! pseudo-terminals.
//!
//! - Latency: from the HILSim writing the last byte of an IMU packet to its terminal until a
//!   whole servo packet can be read back from the servo board's terminal, cut into its
//!   stages with the flight process's latency trace (`--latency-trace`,
//!   `heli_vehicle::latency`) on the clock both share.
//! - Load: the flight process's CPU time over the flight's wall time (from
//!   `/proc/PID/stat`), and its resident memory (`VmRSS`, peak `VmHWM`).

use std::ffi::OsString;
use std::io::{Error, Result, Write};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use heli_vehicle::supervisor::{FromFlight, ToFlight};
use serde::Serialize;

use crate::hil::{self, HilOptions};

/// What `heli bench --hil` measured.
#[derive(Serialize)]
pub struct HilBench {
    /// Flight length (s).
    pub seconds: f64,
    /// Whether the flight process ran under its real-time settings (`--no-realtime` not
    /// given), and what it said of each (memory locking, `SCHED_FIFO`, CPU wake-up latency).
    pub realtime: bool,
    /// The flight process's notes on its real-time settings.
    pub realtime_notes: Vec<String>,
    /// Whether the helicopter crashed in the HILSim (the bench's numbers then stop at the
    /// crash). The bench flies the hover for its timing, not to judge the flight.
    pub crashed: bool,
    /// Servo packets read back.
    pub servo_packets: u64,
    /// IMU write → servo packet readable, as the HILSim alone sees it (µs).
    pub latency_us: crate::summary::Percentiles,
    /// Each stage of the reaction (the HILSim's stamps joined with the flight process's
    /// latency trace).
    pub stages: super::stages::StageTable,
    /// CPU time the machine's hypervisor took from this virtual machine during the flight
    /// (`steal` in `/proc/stat`, ms over all CPUs): while a virtual CPU is not running,
    /// every thread on it (the HILSim's and the flight's real-time ones too) waits.
    pub steal_ms: f64,
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

/// The machine's stolen CPU time so far (ms over all CPUs: `/proc/stat`'s `cpu` line, its
/// eighth value, in clock ticks of 1/100 s); 0 where the kernel does not count it.
fn steal_ms() -> f64 {
    std::fs::read_to_string("/proc/stat")
        .ok()
        .and_then(|stat| {
            let line = stat.lines().find(|l| l.starts_with("cpu "))?;
            line.split_whitespace().nth(8)?.parse::<f64>().ok()
        })
        .map_or(0.0, |ticks| ticks * 10.0)
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

/// How long the flight process has to end after the kill before it is killed outright.
const KILL_WAIT: Duration = Duration::from_secs(10);

/// Flies the hover scenario for `seconds` in real time against the flight process that
/// `flight` starts (the program and its first arguments: `heli-vehicle flight`), under its
/// real-time settings unless `realtime` is false, and measures.
pub fn run(seconds: f64, flight: &[OsString], realtime: bool) -> Result<HilBench> {
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
    let trace = dir.join("latency.csv");
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
                stamps: true,
                cpu: None,
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
    let mut command = Command::new(program);
    command
        .args(first_args)
        .arg("--hilsim")
        .arg(&dev)
        .arg("--log-dir")
        .arg(&dir)
        .arg("--latency-trace")
        .arg(&trace)
        .args(["--calibration-s", "5", "--warm-up-s", "1", "--fly-untested"]);
    if !realtime {
        command.arg("--no-realtime");
    }
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| Error::new(e.kind(), format!("starting the flight process: {e}")))?;
    let pid = child.id();
    let notes = child.stdout.take().map(|out| {
        std::thread::spawn(move || {
            use std::io::BufRead;
            std::io::BufReader::new(out)
                .lines()
                .map_while(std::result::Result::ok)
                .filter_map(|l| match FromFlight::parse(&l) {
                    Ok(FromFlight::Note(n)) if is_realtime_note(&n) => Some(n),
                    _ => None,
                })
                .collect::<Vec<String>>()
        })
    });
    let mut stdin = child
        .stdin
        .take()
        .ok_or_else(|| Error::other("the flight process has no stdin"))?;
    let mut start = heli_link::StartParameters::new("bench", "autonomous").map_err(Error::other)?;
    start.plan = Some("hover".into());
    writeln!(stdin, "{}", ToFlight::Start(start))?;
    let started = Instant::now();
    let cpu_start = cpu_seconds(pid)?;
    let steal_start = steal_ms();
    let summary = sim
        .join()
        .map_err(|_| Error::other("the HILSim thread panicked"))?
        .map_err(Error::other)?;
    let wall = started.elapsed().as_secs_f64();
    let cpu = cpu_seconds(pid)? - cpu_start;
    let steal = steal_ms() - steal_start;
    let rss = status_mib(pid, "VmRSS:")?;
    let peak = status_mib(pid, "VmHWM:")?;
    // The helicopter is in the air: a Stop would land it first. The bench kills the flight
    // (as the bootstrap does), which writes the trace on the way out.
    let _ = writeln!(stdin, "{}", ToFlight::Kill);
    drop(stdin);
    let ended = Instant::now();
    while child.try_wait()?.is_none() {
        if ended.elapsed() > KILL_WAIT {
            let _ = child.kill();
            let _ = child.wait();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    stop.store(true, Ordering::Release);
    let realtime_notes = notes.and_then(|h| h.join().ok()).unwrap_or_default();
    let traced = heli_vehicle::latency::read(&trace).map_err(Error::other);
    let _ = std::fs::remove_dir_all(&dir);
    let hil = summary.hil.clone().unwrap_or_default();
    let stages = super::stages::table(&traced?, &hil.stamps.unwrap_or_default());
    Ok(HilBench {
        seconds,
        realtime,
        realtime_notes,
        crashed: summary.outcome == crate::summary::Outcome::Crash,
        servo_packets: hil.servo_packets,
        latency_us: hil.latency_us,
        stages,
        steal_ms: steal,
        flight_cpu_percent: 100.0 * cpu / wall.max(1e-9),
        flight_rss_mib: rss,
        flight_peak_rss_mib: peak,
    })
}

/// Whether a flight process's note is about its real-time settings.
fn is_realtime_note(note: &str) -> bool {
    [
        "memory",
        "SCHED_FIFO",
        "wake-up latency",
        "real-time settings",
    ]
    .iter()
    .any(|k| note.contains(k))
}

/// Prints the measurement as a table.
pub fn print(b: &HilBench) {
    println!(
        "HIL hover, {:.0} s in real time: {} servo packets{}",
        b.seconds,
        b.servo_packets,
        if b.crashed {
            " (THE HELICOPTER CRASHED: the numbers stop at the crash)"
        } else {
            ""
        }
    );
    println!(
        "flight process {} its real-time settings:",
        if b.realtime { "under" } else { "without" }
    );
    for n in &b.realtime_notes {
        println!("  {n}");
    }
    println!(
        "{:<16} {:>8} {:>8} {:>8} {:>8}   (us; {} servo commands, {} not matched)",
        "stage", "p50", "p99", "p99.9", "max", b.stages.matched, b.stages.unmatched
    );
    for s in &b.stages.stages {
        println!(
            "{:<16} {:>8.0} {:>8.0} {:>8.0} {:>8.0}   {}",
            s.name, s.us.p50, s.us.p99, s.us.p999, s.us.max, s.what
        );
    }
    let l = &b.latency_us;
    println!(
        "as the HILSim alone sees it (IMU written -> servo read): p50 {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us ({} samples)",
        l.p50, l.p99, l.p999, l.max, l.samples
    );
    println!(
        "flight process: {:.1} % of one core, RSS {:.1} MiB (peak {:.1} MiB)",
        b.flight_cpu_percent, b.flight_rss_mib, b.flight_peak_rss_mib
    );
    println!(
        "the machine: {:.0} ms of CPU time stolen by the hypervisor during the flight (all threads on a stolen CPU wait, real-time ones too)",
        b.steal_ms
    );
}
