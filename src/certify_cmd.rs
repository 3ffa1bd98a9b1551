//! `heli certify`: the lab's tests of a build and a parameter set, and the signed attestation
//! the vehicle checks (thesis §4.3; `heli_link::attest`).
//!
//! 1. The regression library: every recorded flight (`*.mcap`) is played back by the HILSim
//!    (`hilsim --replay`) to the onboard program under test, started as the recording's
//!    computer was (calibration, warm-up, mode, plan) with the parameters under test. The
//!    thesis's certification by replay: the flight process accepts every already-tested
//!    input — it answers each recorded command and is never lost. How far its commands
//!    differ from the recorded ones is recorded, not judged: a changed gain changes them.
//! 2. The robustness suite (`heli campaign suite`), flown with the parameters under test.
//! 3. When both pass, the attestation (build SHA-256, parameter SHA-256 and values, the
//!    results) signed with the link key goes where the vehicle reads it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use heli_link::attest::{self, Body, ReplayEvidence, SuiteEvidence};
use heli_sim::replay::compare::Tolerance;
use heli_sim::replay::hil::{self as hil_replay, Recording, ReplayOptions};

/// The arguments of `heli certify`.
#[derive(clap::Args)]
pub(crate) struct CertifyArgs {
    /// The vehicle's log directory: its parameter file (`params`; the defaults without one)
    /// is the set certified, and the attestation is written there (`attestation.json`).
    #[arg(long, value_name = "DIR")]
    log_dir: PathBuf,
    /// The link key file the vehicle holds (heli link keygen): it signs the attestation.
    #[arg(long, env = "HELI_LINK_KEY", value_name = "FILE")]
    key: PathBuf,
    /// The regression library: a directory of recorded flights (`*.mcap`).
    #[arg(long, default_value = "flights", value_name = "DIR")]
    library: PathBuf,
    /// The robustness suite: a directory of campaign files.
    #[arg(long, default_value = "campaigns/robustness", value_name = "DIR")]
    suite: PathBuf,
    /// Least share of the suite's flights that must pass (percent).
    #[arg(long, default_value_t = 99.0, value_name = "PERCENT")]
    min_pass_rate: f64,
    /// The onboard program under test [default: heli-vehicle beside this program].
    #[arg(long, value_name = "PATH")]
    vehicle: Option<PathBuf>,
    /// Play the recorded flights this many times as fast as they were flown (the onboard
    /// program's clock runs as fast).
    #[arg(long, default_value_t = 1.0, value_name = "X")]
    speed: f64,
    /// Worker threads for the suite [default: one per core].
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Write the attestation here instead of LOG_DIR/attestation.json.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

/// Runs the lab's tests; exit 0 and the attestation written when they pass.
pub(crate) fn certify(args: &CertifyArgs) -> Result<ExitCode> {
    if !(args.speed.is_finite() && args.speed > 0.0 && args.speed <= 8.0) {
        bail!("--speed {}: from above 0 to 8", args.speed);
    }
    if !(0.0..=100.0).contains(&args.min_pass_rate) {
        bail!("--min-pass-rate {}: from 0 to 100", args.min_pass_rate);
    }
    let key = heli_link::setup::load_key(Some(&args.key))?
        .ok_or_else(|| anyhow!("no key in {}", args.key.display()))?;
    let vehicle = match &args.vehicle {
        Some(p) => p.clone(),
        None => crate::onboard_program(" (or name one with --vehicle)")?,
    };
    // Both directories are checked before anything is flown (the replays take minutes);
    // the defaults are the repository's, relative to where the command runs.
    for (option, dir) in [("--library", &args.library), ("--suite", &args.suite)] {
        if !dir.is_dir() {
            bail!(
                "{option} {}: not a directory (the default is the repository's: run from its root, or name the directory)",
                dir.display()
            );
        }
    }
    let identity = heli_vehicle::lab::identity(&vehicle, &args.log_dir).map_err(|e| anyhow!(e))?;
    let table = if heli_vehicle::params::path_in(&args.log_dir).exists() {
        heli_vehicle::params::load(&args.log_dir)?
    } else {
        heli_vehicle::params::defaults()
    };
    println!(
        "certify    {} (build {}), parameters {} of {}",
        vehicle.display(),
        attest::short(&identity.build_sha256),
        attest::short(&identity.params_sha256),
        args.log_dir.display()
    );

    let flights = library(&args.library)?;
    let mut replays = Vec::new();
    for flight in &flights {
        let evidence = replay(flight, &vehicle, &table.to_text(), args.speed)
            .with_context(|| format!("replaying {}", flight.display()))?;
        println!(
            "replay     {}: {} of {} commands answered{}, {} differ from the recording (largest {} us): {}",
            evidence.flight,
            evidence.paired,
            evidence.recorded,
            if evidence.ran_through {
                ""
            } else {
                ", the flight process LOST"
            },
            evidence.out_of_tolerance,
            evidence.largest_difference_us,
            if evidence.accepted() {
                "accepted"
            } else {
                "NOT ACCEPTED"
            }
        );
        replays.push(evidence);
    }

    let mut software = heli_fsw::CoreConfig::default();
    heli_vehicle::params::apply(&table, &mut software);
    let reports = crate::campaign_cmd::fly_suite(&args.suite, args.jobs, &software)?;
    let sum = |f: fn(&heli_campaign::Report) -> u64| reports.iter().map(|(_, r)| f(r)).sum();
    let suite = SuiteEvidence {
        dir: args.suite.display().to_string(),
        flights: sum(|r| r.totals.flights),
        pass: sum(|r| r.totals.pass),
        crash: sum(|r| r.totals.crash),
        error: sum(|r| r.totals.error),
        min_pass_permille: (args.min_pass_rate * 10.0).round() as u64,
    };
    println!(
        "suite      {}: {} of {} passed, {} crashed, {} not flown (at least {} % to pass): {}",
        suite.dir,
        suite.pass,
        suite.flights,
        suite.crash,
        suite.error,
        args.min_pass_rate,
        if suite.passed() { "passed" } else { "FAILED" }
    );

    let body = Body {
        format: attest::FORMAT,
        identity,
        certified_unix_s: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
        certified_by: concat!("heli ", env!("CARGO_PKG_VERSION")).to_string(),
        replays,
        suite,
    };
    if !body.passed() {
        println!("outcome    NOT certified: no attestation written");
        return Ok(ExitCode::FAILURE);
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.log_dir.join(attest::FILE_NAME));
    let text = attest::to_text(&attest::sign(body, &key)?)?;
    let tmp = out.with_extension("json.tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, &out))
        .with_context(|| format!("writing {}", out.display()))?;
    println!("outcome    certified: attestation {}", out.display());
    Ok(ExitCode::SUCCESS)
}

/// The recorded flights of the library, in name order; an empty library is refused (it
/// would certify nothing).
fn library(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut flights: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("the regression library {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    flights.sort();
    if flights.is_empty() {
        bail!(
            "the regression library {} has no recorded flights (*.mcap)",
            dir.display()
        );
    }
    Ok(flights)
}

/// Plays `flight` to the onboard program `vehicle` flying the parameters `params_text`.
fn replay(flight: &Path, vehicle: &Path, params_text: &str, speed: f64) -> Result<ReplayEvidence> {
    let bytes = std::fs::read(flight)?;
    let flight_sha256 = attest::file_sha256(flight)?;
    let contents = heli_log::read(&bytes);
    let setup = heli_sim::replay::setup::setup_of(&contents)?;
    let rec = Recording::from_log(&contents).map_err(|e| anyhow!(e))?;
    let plan = contents
        .metadata
        .iter()
        .filter(|m| m.name == heli_log::metadata::FLIGHT)
        .find_map(|m| m.entries.get("plan").cloned());
    let dir = tempfile::tempdir()?;
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs)?;
    std::fs::write(logs.join("params"), params_text)?;
    let dev = dir.path().join("dev");
    let socket = dir.path().join("ctl.sock");
    let run = Bench {
        program: vehicle.to_path_buf(),
        socket: socket.clone(),
    };
    let args: Vec<String> = vec![
        "--hilsim".into(),
        dev.display().to_string(),
        "--log-dir".into(),
        logs.display().to_string(),
        "--fallback-dir".into(),
        "none".into(),
        "--socket".into(),
        socket.display().to_string(),
        "--calibration-s".into(),
        setup.config.calibration_s.to_string(),
        "--warm-up-s".into(),
        setup.config.imu_warm_up_s.to_string(),
        "--clock-speed".into(),
        speed.to_string(),
        // The lab bench: the configuration under test is not attested yet.
        "--fly-untested".into(),
    ];
    let mut start = format!("start-logging certify {}", setup.params.mode.name());
    if let Some(plan) = plan.filter(|p| heli_link::command::PLANS.contains(&p.as_str())) {
        start.push(' ');
        start.push_str(&plan);
    }
    let bootstrap: Arc<Mutex<Option<Running>>> = Arc::new(Mutex::new(None));
    let started: Arc<Mutex<Option<Result<u64, String>>>> = Arc::new(Mutex::new(None));
    let stop = Arc::new(AtomicBool::new(false));
    let options = ReplayOptions {
        speed,
        wait_s: 30.0,
        // The pairing window is recorded time: played faster, the same wall-clock jitter
        // spans more of it.
        tolerance: Tolerance {
            window_us: (Tolerance::default().window_us as f64 * speed.max(1.0)) as u64,
            ..Tolerance::default()
        },
    };
    let report = {
        let bootstrap = Arc::clone(&bootstrap);
        let starting = Arc::clone(&started);
        let run = run.clone();
        hil_replay::run(&rec, &dev, options, &stop, move |devices| {
            let cal = devices.dir.join(heli_vehicle::compass_file::HIL_FILE_NAME);
            if let Err(e) = heli_vehicle::compass_file::write(&cal, &setup.config.compass) {
                eprintln!("heli certify: {e:#}");
            }
            // The bootstrap starts, connects and starts the flight beside the replay, which
            // waits for the flight process's first write.
            std::thread::spawn(move || {
                let outcome = run.start(&args, &start, &bootstrap);
                if let Ok(mut s) = starting.lock() {
                    *s = Some(outcome);
                }
            });
        })
        .map_err(|e| {
            // The replay found no flight computer: the bootstrap's own reason comes first.
            match started.lock().ok().and_then(|s| s.clone()) {
                Some(Err(why)) => anyhow!("{why} ({e})"),
                _ => anyhow!(e),
            }
        })?
    };
    let pid_at_start = started
        .lock()
        .ok()
        .and_then(|s| s.clone())
        .unwrap_or_else(|| Err("the bootstrap never answered".into()))
        .map_err(|e| anyhow!(e))?;
    // Still the same flight process, still flying: never lost nor restarted.
    let status = run.ctl(&["status"]).unwrap_or_default();
    let ran_through = serde_json::from_str::<serde_json::Value>(status.trim_start_matches("ok "))
        .is_ok_and(|v| v["pid"].as_u64() == Some(pid_at_start) && v["state"] == "flying");
    if !ran_through
        && let Ok(b) = bootstrap.lock()
        && let Some((_, lines)) = b.as_ref()
        && let Ok(lines) = lines.lock()
    {
        eprintln!("heli certify: the bootstrap said:");
        for line in lines.iter().rev().take(20).rev() {
            eprintln!("  {line}");
        }
    }
    let _ = run.ctl(&["kill", "confirmed"]);
    let _ = run.ctl(&["quit"]);
    if let Ok(mut b) = bootstrap.lock()
        && let Some((mut child, _)) = b.take()
    {
        let deadline = Instant::now() + Duration::from_secs(5);
        while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    let c = &report.comparison;
    Ok(ReplayEvidence {
        flight: flight
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        flight_sha256,
        recorded: c.recorded as u64,
        paired: c.paired as u64,
        out_of_tolerance: c.out_of_tolerance as u64,
        largest_difference_us: c
            .channels
            .iter()
            .map(|ch| u64::from(ch.max_us))
            .max()
            .unwrap_or(0),
        ran_through,
    })
}

/// A bootstrap running on the bench, and the lines it printed.
type Running = (Child, Arc<Mutex<Vec<String>>>);

/// The onboard program on the lab bench: its bootstrap and control socket.
#[derive(Clone)]
struct Bench {
    program: PathBuf,
    socket: PathBuf,
}

impl Bench {
    /// One control command; its reply (`ok …`), or why not.
    fn ctl(&self, words: &[&str]) -> Result<String, String> {
        let out = Command::new(&self.program)
            .arg("ctl")
            .args(words)
            .arg("--socket")
            .arg(&self.socket)
            .output()
            .map_err(|e| format!("{}: {e}", self.program.display()))?;
        let text = String::from_utf8_lossy(if out.status.success() {
            &out.stdout
        } else {
            &out.stderr
        })
        .trim()
        .to_string();
        if out.status.success() {
            Ok(text)
        } else {
            Err(text)
        }
    }

    /// Starts the bootstrap with `args`, connects and sends `start`; the flight process's
    /// pid once it flies.
    fn start(
        &self,
        args: &[String],
        start: &str,
        keep: &Mutex<Option<Running>>,
    ) -> Result<u64, String> {
        let mut child = Command::new(&self.program)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("starting {}: {e}", self.program.display()))?;
        let lines = Arc::new(Mutex::new(Vec::new()));
        if let Some(out) = child.stdout.take() {
            let lines = Arc::clone(&lines);
            std::thread::spawn(move || {
                for line in BufReader::new(out).lines().map_while(Result::ok) {
                    if let Ok(mut l) = lines.lock() {
                        l.push(line);
                    }
                }
            });
        }
        if let Ok(mut k) = keep.lock() {
            *k = Some((child, Arc::clone(&lines)));
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        while !self.socket.exists() {
            if Instant::now() > deadline {
                return Err("the bootstrap did not listen within 10 s".into());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let connected = self.ctl(&["connect"])?;
        if !connected.starts_with("ok") {
            return Err(format!("connect: {connected}"));
        }
        let words: Vec<&str> = start.split(' ').collect();
        let reply = self.ctl(&words)?;
        if !reply.starts_with("ok flying") {
            return Err(format!("{start}: {reply}"));
        }
        let status = self.ctl(&["status"])?;
        serde_json::from_str::<serde_json::Value>(status.trim_start_matches("ok "))
            .ok()
            .and_then(|v| v["pid"].as_u64())
            .ok_or_else(|| format!("no flight process in {status}"))
    }
}
