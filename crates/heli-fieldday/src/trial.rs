//! One trial: a flight of the real processes against the HILSim, one fault at one moment,
//! and its verdict.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use nix::sys::signal::Signal;
use serde::Serialize;

use crate::FieldDayError;
use crate::fault::{self, Fault, Phase};
use crate::judge::{self, LOSS_ALLOWED_MS, LogCheck};
use crate::procs::{self, Proc, Programs, VehiclePaths};
use crate::storage::{Means, Storage};

/// What came of one trial.
#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    /// The fault's name.
    pub fault: String,
    /// The phase it struck in.
    pub phase: String,
    /// What was done, in words.
    pub injected: String,
    /// How the storage faults were made here.
    pub means: Option<Means>,
    /// Seconds of wall time the trial took.
    pub seconds: f64,
    /// The HILSim's truth: the crash, if the helicopter was lost (`null`: not lost).
    pub crash: serde_json::Value,
    /// The HILSim's truth summary was read.
    pub truth_read: bool,
    /// The logs as they were just after the fault (the live process's, copied through its
    /// open file), and the logs of killed processes: each opened by the official reader,
    /// each ending at most [`LOSS_ALLOWED_MS`] before the fault.
    pub at_fault: Vec<LogCheck>,
    /// Every log at the end.
    pub logs: Vec<LogCheck>,
    /// The flight process's resident memory while the disk was full (MiB): when it struck,
    /// the most, and at the end of the fault.
    pub memory_mib: Option<[f64; 3]>,
    /// What the operator should have been told and was not.
    pub untold: Vec<String>,
    /// Anything else that went wrong.
    pub problems: Vec<String>,
    /// Where the HILSim was starved by the machine (its device writes left past the IMU's
    /// silence limit), beyond a stall injected on purpose: a failed trial with any is void,
    /// as the machine stopped the world, and is run again ([`crate::run`]).
    pub starved: Vec<String>,
    /// Earlier tries of this trial that were void, and why.
    pub void_tries: Vec<String>,
    /// Not run on this machine, and why.
    pub skipped: Option<String>,
    /// The helicopter flew on or landed softly, every log opened, nothing lost beyond the
    /// allowance, the operator told.
    pub pass: bool,
}

fn unix_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// Copies the `.mcap` files process `pid` has open (through `/proc`, so that even a log
/// directory hidden by a read-only mount is reached) into `to`.
fn snapshot_open_logs(pid: u32, to: &Path) -> Vec<PathBuf> {
    let _ = std::fs::create_dir_all(to);
    let fds = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .into_iter()
        .flatten();
    fds.filter_map(|fd| {
        let fd = fd.ok()?.path();
        let target = std::fs::read_link(&fd).ok()?;
        let name = target.file_name()?.to_string_lossy().into_owned();
        if !name.ends_with(".mcap") {
            return None;
        }
        let copy = to.join(&name);
        std::fs::copy(&fd, &copy).ok()?;
        Some(copy)
    })
    .collect()
}

/// The IMU's terminal hung up for `seconds` (`TIOCVHANGUP`, again every 50 ms so that no
/// reopening gets through), with Python's `fcntl`, which this machine has for the reader.
fn hang_up(python: &Path, port: &Path, seconds: f64) -> Result<(), String> {
    const SCRIPT: &str = "import os, fcntl, sys, time\nend = time.time() + float(sys.argv[2])\nwhile time.time() < end:\n    fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)\n    fcntl.ioctl(fd, 0x5437)\n    os.close(fd)\n    time.sleep(0.05)\n";
    let out = std::process::Command::new(python)
        .args(["-c", SCRIPT])
        .arg(port)
        .arg(seconds.to_string())
        .output()
        .map_err(|e| e.to_string())?;
    if out.status.success() {
        Ok(())
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        Err(err.lines().last().unwrap_or("").trim().to_string())
    }
}

/// The resident memory of process `pid` (MiB), from `/proc/PID/status`.
fn resident_mib(pid: u32) -> Option<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let kib: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib / 1024.0)
}

/// The starved stretches of a HILSim summary (`hil.starved`) in words, less the one a
/// stall injected on purpose made (the longest, when it is as long as the stall).
fn starved(stretches: &serde_json::Value, fault: Fault) -> Vec<String> {
    let mut list: Vec<(f64, f64, f64)> = stretches
        .as_array()
        .into_iter()
        .flatten()
        .map(|s| {
            let get = |k: &str| s[k].as_f64().unwrap_or(0.0);
            (get("from_s"), get("to_s"), get("late_ms"))
        })
        .collect();
    if let Fault::Stall(ms) = fault {
        let longest = list
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.2.total_cmp(&b.1.2))
            .map(|(k, s)| (k, s.2));
        if let Some((k, late_ms)) = longest
            && late_ms >= 0.9 * f64::from(ms)
        {
            list.remove(k);
        }
    }
    list.iter()
        .map(|(from_s, to_s, late_ms)| {
            format!("the machine starved the HILSim {late_ms:.0} ms at t={from_s:.1}..{to_s:.1} s")
        })
        .collect()
}

/// A trial under way.
struct Run<'a> {
    programs: &'a Programs,
    python: &'a Path,
    dir: PathBuf,
    paths: VehiclePaths,
    boots: Vec<Proc>,
    problems: Vec<String>,
}

impl Run<'_> {
    fn boot(&self) -> Option<&Proc> {
        self.boots.last()
    }

    fn flight_pid(&mut self) -> Option<u32> {
        let pid = procs::flight_pid(&self.paths.socket);
        if pid.is_none() {
            self.problems
                .push("no flight process when the fault came".into());
        }
        pid
    }

    fn kill(&mut self, pid: u32) {
        if let Err(e) = procs::signal(pid, Signal::SIGKILL) {
            self.problems.push(e.to_string());
        }
    }

    /// A new bootstrap, as the init system starts one.
    fn boot_again(&mut self) {
        match procs::bootstrap(self.programs, &self.paths) {
            Ok(b) => self.boots.push(b),
            Err(e) => self
                .problems
                .push(format!("the bootstrap did not start again: {e}")),
        }
    }

    /// Every line every bootstrap said (the ground station's status texts).
    fn said(&self) -> Vec<String> {
        self.boots.iter().flat_map(Proc::lines).collect()
    }
}

/// Runs one trial in `out/<fault>-<phase>`; `mount`: the storage faults on a tmpfs where
/// this process may mount one.
pub fn run(
    programs: &Programs,
    python: &Path,
    out: &Path,
    fault: Fault,
    phase: Phase,
    seed: u64,
    mount: bool,
) -> Result<Outcome, FieldDayError> {
    let started = Instant::now();
    let dir = out.join(format!("{}-{}", fault.name(), phase.name()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)
        .map_err(|e| FieldDayError::Io(format!("creating {}", dir.display()), e))?;
    let ram = Path::new("/dev/shm");
    let fallback = if ram.is_dir() {
        ram.join(format!(
            "heli-fieldday-{}-{}",
            std::process::id(),
            dir.display().to_string().len()
        ))
    } else {
        dir.join("ram")
    };
    let paths = VehiclePaths {
        dev: dir.join("dev"),
        logs: dir.join("logs"),
        socket: dir.join("ctl.sock"),
        fallback: fallback.clone(),
    };
    let _ = std::fs::remove_dir_all(&fallback);
    let mut storage = if fault.storage() {
        Some(Storage::prepare(&paths.logs, mount)?)
    } else {
        std::fs::create_dir_all(&paths.logs)
            .map_err(|e| FieldDayError::Io(format!("creating {}", paths.logs.display()), e))?;
        None
    };
    let mut outcome = Outcome {
        fault: fault.name(),
        phase: phase.name().into(),
        injected: fault.injected(),
        means: storage.as_ref().map(|s| s.means),
        seconds: 0.0,
        crash: serde_json::Value::Null,
        truth_read: false,
        at_fault: Vec::new(),
        logs: Vec::new(),
        memory_mib: None,
        untold: Vec::new(),
        problems: Vec::new(),
        starved: Vec::new(),
        void_tries: Vec::new(),
        skipped: None,
        pass: false,
    };
    let mut hil = procs::hilsim(programs, &paths.dev, phase.name(), seed)?;
    let first = procs::bootstrap(programs, &paths)?;
    let mut run = Run {
        programs,
        python,
        dir: dir.clone(),
        paths,
        boots: vec![first],
        problems: Vec::new(),
    };
    let socket = run.paths.socket.clone();
    let started_flight = procs::ctl(&socket, "connect").and_then(|_| {
        procs::ctl(
            &socket,
            &format!("start-logging fd autonomous {}", phase.name()),
        )
    });
    let mut kills_ms = Vec::new();
    let mut fault_ms = unix_ms();
    let (cue, after) = phase.cue();
    let reached = started_flight.is_ok()
        && run
            .boot()
            .and_then(|b| b.wait_for(cue, 0, Duration::from_secs(150)))
            .is_some();
    if let Err(e) = &started_flight {
        run.problems.push(format!("the flight did not start: {e}"));
    } else if !reached {
        run.problems.push(format!("never reached '{cue}'"));
    }
    if reached {
        std::thread::sleep(after);
        fault_ms = unix_ms();
        let struck = Instant::now();
        let snapshot_after = if fault.storage() {
            Duration::from_secs(2)
        } else {
            Duration::from_millis(500)
        };
        let mut snapshot_pid = None;
        let mut memory_before = None;
        match fault {
            Fault::KillFlight => {
                for k in 0..3 {
                    if k > 0 {
                        std::thread::sleep(fault::KILL_EVERY);
                    }
                    if let Some(pid) = run.flight_pid() {
                        kills_ms.push(unix_ms());
                        run.kill(pid);
                    }
                }
            }
            Fault::KillBootstrap => {
                snapshot_pid = procs::flight_pid(&socket);
                if let Some(pid) = run.boot().map(Proc::pid) {
                    run.kill(pid);
                }
                std::thread::sleep(fault::INIT_RESTART);
                run.boot_again();
            }
            Fault::Brownout => {
                let flight = run.flight_pid();
                if let Some(pid) = run.boot().map(Proc::pid) {
                    run.kill(pid);
                }
                if let Some(pid) = flight {
                    kills_ms.push(unix_ms());
                    run.kill(pid);
                }
                let _ = std::fs::remove_dir_all(&run.paths.fallback);
                std::thread::sleep(fault::POWER_OFF);
                run.boot_again();
            }
            Fault::DiskFull | Fault::ReadOnly => {
                if let (Some(pid), Some(storage)) = (run.flight_pid(), storage.as_mut()) {
                    snapshot_pid = Some(pid);
                    memory_before = resident_mib(pid);
                    let made = if fault == Fault::DiskFull {
                        storage.fill(pid)
                    } else {
                        storage.read_only(pid)
                    };
                    if let Err(e) = made {
                        run.problems.push(format!("the storage fault: {e}"));
                    }
                }
            }
            Fault::PortHangup => {
                snapshot_pid = procs::flight_pid(&socket);
                if let Err(e) = hang_up(
                    run.python,
                    &run.paths.dev.join("imu"),
                    fault::HANGUP.as_secs_f64(),
                ) {
                    outcome.skipped =
                        Some(format!("TIOCVHANGUP refused ({e}): it needs CAP_SYS_ADMIN"));
                }
            }
            Fault::Stall(ms) => {
                snapshot_pid = procs::flight_pid(&socket);
                let stall = procs::signal(hil.pid(), Signal::SIGSTOP).and_then(|()| {
                    std::thread::sleep(Duration::from_millis(u64::from(ms)));
                    procs::signal(hil.pid(), Signal::SIGCONT)
                });
                if let Err(e) = stall {
                    run.problems.push(e.to_string());
                }
            }
            Fault::ServoSilent => {
                snapshot_pid = procs::flight_pid(&socket);
                let line = format!(
                    "{{\"kind\":\"servo-board-silent\",\"seconds\":{}}}",
                    fault::SERVO_SILENT_S
                );
                if !hil.tell(&line) {
                    run.problems.push("the HILSim took no failure".into());
                }
            }
        }
        if let Some(pid) = snapshot_pid {
            if let Some(wait) = snapshot_after.checked_sub(struck.elapsed()) {
                std::thread::sleep(wait);
            }
            for copy in snapshot_open_logs(pid, &run.dir.join("at-fault")) {
                outcome
                    .at_fault
                    .push(LogCheck::of(run.python, &copy, fault_ms));
            }
            if outcome.at_fault.is_empty() {
                run.problems
                    .push("no open log to look at just after the fault".into());
            }
        }
        if fault.storage() {
            let pid = procs::flight_pid(&socket);
            let mut memory: Vec<f64> = memory_before.into_iter().collect();
            while struck.elapsed() < fault.storage_fault() {
                if let Some(mib) = pid.and_then(resident_mib) {
                    memory.push(mib);
                }
                std::thread::sleep(
                    Duration::from_secs(1)
                        .min(fault.storage_fault().saturating_sub(struck.elapsed())),
                );
            }
            if fault == Fault::DiskFull
                && let (Some(&first), Some(&last)) = (memory.first(), memory.last())
            {
                let most = memory.iter().copied().fold(first, f64::max);
                outcome.memory_mib = Some([first, most, last]);
                if most - first > fault::MEMORY_GROWTH_MIB {
                    run.problems.push(format!(
                        "the flight process's memory grew {:.1} MiB while the disk was full",
                        most - first
                    ));
                }
            }
            if let (Some(pid), Some(storage)) = (pid, storage.as_mut()) {
                let undone = if fault == Fault::DiskFull {
                    storage.free(pid)
                } else {
                    storage.writable(pid)
                };
                if let Err(e) = undone {
                    run.problems.push(format!("undoing the storage fault: {e}"));
                }
            }
        }
        if let Some(wait) = fault.settle().checked_sub(struck.elapsed()) {
            std::thread::sleep(wait);
        }
    }
    // The truth: the HILSim ends on SIGTERM and prints its summary.
    let _ = procs::signal(hil.pid(), Signal::SIGTERM);
    if hil.wait_end(Duration::from_secs(10)) {
        std::thread::sleep(Duration::from_millis(200));
        match serde_json::from_str::<serde_json::Value>(&hil.stdout()) {
            Ok(summary) => {
                outcome.truth_read = true;
                outcome.crash = summary["crash"].clone();
                outcome.starved = starved(&summary["hil"]["starved"], fault);
            }
            Err(e) => run.problems.push(format!("the HILSim's summary: {e}")),
        }
    } else {
        run.problems
            .push("the HILSim did not end on SIGTERM".into());
    }
    let _ = procs::ctl(&socket, "kill confirmed");
    let _ = procs::ctl(&socket, "quit");
    for boot in &mut run.boots {
        boot.wait_end(Duration::from_secs(5));
    }
    // The logs of the processes killed by the fault, each timed against its kill.
    let final_dir = run.dir.join("final");
    let mut finals = match storage.take() {
        Some(storage) => storage.release(&final_dir).unwrap_or_else(|e| {
            run.problems.push(format!("giving the storage back: {e}"));
            Vec::new()
        }),
        None => judge::copy_logs(&run.paths.logs, &final_dir).unwrap_or_default(),
    };
    if run.paths.fallback.is_dir() {
        finals.extend(
            judge::copy_logs(&run.paths.fallback, &final_dir.join("fallback")).unwrap_or_default(),
        );
    }
    finals.sort();
    finals.dedup();
    let killed: Vec<PathBuf> = ["flight_fd.mcap", "flight_fd_r1.mcap", "flight_fd_r2.mcap"]
        .iter()
        .map(|n| final_dir.join(n))
        .collect();
    for (log, kill_ms) in killed.iter().zip(&kills_ms) {
        outcome
            .at_fault
            .push(LogCheck::of(run.python, log, *kill_ms));
    }
    outcome.logs = finals
        .iter()
        .map(|log| LogCheck::of(run.python, log, fault_ms))
        .collect();
    let _ = std::fs::remove_dir_all(&run.paths.fallback);
    outcome.untold = judge::untold(fault.told(), &run.said())
        .into_iter()
        .map(str::to_string)
        .collect();
    std::fs::write(run.dir.join("said.txt"), run.said().join("\n"))
        .map_err(|e| FieldDayError::Io("writing said.txt".into(), e))?;
    std::fs::write(run.dir.join("hilsim.txt"), hil.lines().join("\n"))
        .map_err(|e| FieldDayError::Io("writing hilsim.txt".into(), e))?;
    outcome.problems = run.problems;
    outcome.seconds = started.elapsed().as_secs_f64();
    outcome.pass = outcome.skipped.is_none()
        && outcome.problems.is_empty()
        && outcome.truth_read
        && outcome.crash.is_null()
        && !outcome.at_fault.is_empty()
        && outcome.at_fault.iter().all(|c| {
            c.readable()
                && c.ends_before_fault_ms
                    .is_some_and(|ms| ms <= LOSS_ALLOWED_MS)
        })
        && !outcome.logs.is_empty()
        && outcome.logs.iter().all(LogCheck::readable)
        && outcome.untold.is_empty();
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stall_injected_on_purpose_is_not_starvation_but_the_machine_s_is() {
        let stretches = serde_json::json!([
            {"from_s": 2.0, "to_s": 2.4, "late_ms": 420.0},
            {"from_s": 30.0, "to_s": 30.0, "late_ms": 3001.0},
        ]);
        assert_eq!(
            starved(&stretches, Fault::Stall(3000)),
            ["the machine starved the HILSim 420 ms at t=2.0..2.4 s"]
        );
        assert_eq!(starved(&stretches, Fault::KillFlight).len(), 2);
        // A stall shorter than the machine's starvation leaves the starvation said.
        let short = serde_json::json!([{"from_s": 2.0, "to_s": 2.4, "late_ms": 150.0}]);
        assert_eq!(starved(&short, Fault::Stall(3000)).len(), 1);
        assert!(starved(&serde_json::Value::Null, Fault::Brownout).is_empty());
    }
}
