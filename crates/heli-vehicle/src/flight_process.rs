//! The flight process's program: what `heli-vehicle flight` (started by the bootstrap, not by
//! people) does around [`crate::flight::run`]. It says `ready`, waits for the start on its
//! standard input, reads the plan, the parameters and the warm-start record, names its log,
//! records the flight's setup in the log's metadata, flies until `stop` (or the end of its
//! input) and says `stopped` with its counts.

use std::io::BufRead;
use std::os::unix::net::UnixListener;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::{Result, bail};
use heli_fsw::core::{CoreConfig, FlightParams, StopAnswer};
use heli_link::StartParameters;

use crate::adopt::Outbox;
use crate::cli::FlightProcessArgs;
use crate::flight::{self, FlightSetup, Report};
use crate::rt;
use crate::supervisor::{FromFlight, ToFlight, VERSION};

/// The bootstrap's next message on `input` (standard input, or the adoption socket of a
/// bootstrap that took the flight back); `None` at its end. A line that is not a message is
/// answered, and skipped.
fn next_message(input: &mut dyn BufRead, say: &dyn Fn(FromFlight)) -> Option<ToFlight> {
    loop {
        let mut bytes = Vec::new();
        // A line longer than the protocol's is read whole and refused by the parser; one
        // that is not UTF-8 is refused as well, not taken for the bootstrap's end.
        match input.read_until(b'\n', &mut bytes) {
            Ok(0) | Err(_) => return None,
            Ok(_) => {}
        }
        let line = String::from_utf8_lossy(&bytes);
        match ToFlight::parse(&line) {
            Ok(message) => return Some(message),
            Err(e) => say(FromFlight::Refused(format!(
                "not understood: '{:.80}' ({e})",
                line.trim_end()
            ))),
        }
    }
}

/// Where the flight process's lines go: a printer thread, so that no flight thread (the
/// control loop least of all) ever waits on the pipe to the bootstrap. Lines that do not
/// fit are counted and the count said when there is room.
fn reporter(outbox: Arc<Outbox>) -> Result<impl Fn(FromFlight) + Send + Sync + Clone> {
    let (tx, rx) = std::sync::mpsc::sync_channel::<FromFlight>(4096);
    let dropped = Arc::new(Dropped::default());
    {
        let dropped = Arc::clone(&dropped);
        rt::thread("printer", rt::HELPER_STACK_BYTES).spawn(move || {
            for message in rx {
                if let Some(note) = dropped.note() {
                    outbox.say(&note);
                }
                outbox.say(&message);
            }
        })?;
    }
    Ok(move |message: FromFlight| {
        if tx.try_send(message).is_err() {
            dropped.count();
        }
    })
}

/// Report lines that found the printer's queue full: counted, and said when there is room.
#[derive(Debug, Default)]
struct Dropped(AtomicU64);

impl Dropped {
    /// One more line dropped.
    fn count(&self) {
        self.0.fetch_add(1, Ordering::AcqRel);
    }

    /// The note saying how many were dropped since the last one, if any were.
    fn note(&self) -> Option<FromFlight> {
        let lost = self.0.swap(0, Ordering::AcqRel);
        (lost > 0).then(|| {
            FromFlight::Note(format!(
                "{lost} report lines dropped (the bootstrap was not reading)"
            ))
        })
    }
}

/// The flight process: ready, the start, the flight, stopped.
pub fn run(process: &FlightProcessArgs) -> Result<ExitCode> {
    let args = &process.flight;
    args.validate()?;
    // A file-size limit (RLIMIT_FSIZE) must never kill a flight: with the signal caught, a
    // write past the limit fails (EFBIG) and the log writer treats it as a full disk.
    let file_too_large = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGXFSZ, Arc::clone(&file_too_large))?;
    let devices = args.devices()?;
    let compass = args.compass()?;
    let outbox = Arc::new(Outbox::stdout());
    let say = {
        let outbox = Arc::clone(&outbox);
        move |message: FromFlight| {
            outbox.say(&message);
        }
    };
    // The adoption socket (`crate::adopt`): bound now, so that it says a flight process
    // lives for as long as this one does. Another process's that answers stops this one
    // before it touches a device; one that cannot be bound costs only the adoption.
    let listener = match process.adopt_socket.as_deref().map(crate::adopt::listen) {
        None => None,
        Some(Ok(listener)) => Some(listener),
        Some(Err(e @ crate::error::VehicleError::Invalid { .. })) => {
            say(FromFlight::Refused(e.to_string()));
            bail!("{e}");
        }
        Some(Err(e)) => {
            say(FromFlight::Note(format!(
                "{e}: a bootstrap started again cannot take this flight back"
            )));
            None
        }
    };
    let _remove_socket = process.adopt_socket.clone().map(RemoveOnDrop);
    say(FromFlight::Ready { version: VERSION });
    // What the bootstrap says of its link: 0 nothing (no link), 1 a ground heard, 2 none.
    let ground_link = Arc::new(AtomicU8::new(0));
    let supervision = Arc::new(flight::Supervision::default());
    // The fallback directory (RAM): the log's second place and the warm-start record's.
    let fallback = args.fallback_dir();
    // A start this process cannot fly (a plan it does not know, a suffix already logged) is
    // refused before anything is opened, and the process waits for another: the operator
    // chooses again without connecting again.
    // The lab's attestation: judged at each start, on the program that runs this process and
    // the parameter file the start flies (`crate::lab`).
    let lab = args.lab()?;
    let program = std::env::current_exe().unwrap_or_default();
    let (restart, start, plan, lab_line, lab_override) = loop {
        let (restart, start) = match next_message(&mut std::io::stdin().lock(), &say) {
            Some(ToFlight::Start(p)) => (false, p),
            Some(ToFlight::Restart(p)) => (true, p),
            Some(ToFlight::Link { fresh }) => {
                ground_link.store(link_state(fresh), Ordering::Release);
                continue;
            }
            Some(ToFlight::Stop | ToFlight::Kill) | None => {
                say(FromFlight::Stopped(serde_json::json!({})));
                return Ok(ExitCode::SUCCESS);
            }
        };
        match startable(args, fallback.as_deref(), &start, restart) {
            Ok(plan) => {
                let verdict = match crate::lab::identity(&program, &args.log_dir) {
                    Ok(identity) => lab.check.judge(&identity),
                    Err(why) => heli_link::attest::Verdict::NotTested { why: vec![why] },
                };
                // A flight resumed in the air flies whatever the lab said.
                let allowed = match lab.start(&verdict, &start) {
                    Err(_) if restart => Ok(None),
                    other => other,
                };
                match allowed {
                    Ok(said) => {
                        let by = said.as_ref().and_then(|s| s.override_by).unwrap_or("none");
                        if let Some(said) = said {
                            say(FromFlight::Event {
                                severity: said.severity,
                                text: said.text,
                            });
                        }
                        break (restart, start, plan, verdict.line(), by);
                    }
                    Err(why) => say(FromFlight::Refused(why)),
                }
            }
            Err(why) => {
                say(FromFlight::Refused(why.clone()));
                // A restart the process cannot fly has nobody to choose again: it ends.
                if restart {
                    bail!("{why}");
                }
            }
        }
    };
    let mode = start.controller;
    // Under the real-time settings unless told otherwise; the log says which.
    let realtime = !args.no_realtime;
    let suffix = start.file_suffix.clone();
    let plan_legs = plan.legs_json();
    // The plan's legs, for the bootstrap to serve over the link's mission protocol.
    say(FromFlight::Plan(plan.legs.clone()));
    if let Some(dir) = &fallback
        && let Err(e) = std::fs::create_dir_all(dir)
    {
        say(FromFlight::Note(format!(
            "fallback directory {}: {e}",
            dir.display()
        )));
    }
    let warm_paths: Vec<std::path::PathBuf> = std::iter::once(crate::warm::path_in(&args.log_dir))
        .chain(fallback.as_deref().map(crate::warm::path_in))
        .collect();
    // Started again by the bootstrap after a crash or a brown-out: resume from the newest
    // record the process before left, if one can be read (otherwise start cold, and say so).
    // The flight clock starts here: a record's roll, seen on the wall clock by the process
    // before, is set against it.
    let clock = crate::threads::Clock::with_speed(args.clock_speed);
    let restart_from = if restart {
        crate::warm::newest(&warm_paths, &|text| say(FromFlight::Note(text)))
            .map(|file| file.rebased(&clock))
    } else {
        None
    };
    let log_path = next_free_log(&args.log_dir, fallback.as_deref(), &suffix, restart);
    let mut config = CoreConfig {
        calibration_s: args.calibration_s,
        imu_warm_up_s: args.warm_up_s,
        compass,
        ..CoreConfig::default()
    };
    // The parameters set over the link: a file that cannot be used stops the start, with
    // its reason, rather than flying on values nobody chose.
    // With no file the flight software's own defaults are flown, exactly.
    // Restarted in the air, the flight goes on whatever the storage says: on the flight
    // software's defaults if the file has become unreadable, raised as an event.
    let params = if crate::params::path_in(&args.log_dir).exists() {
        match crate::params::load(&args.log_dir) {
            Ok(table) => {
                crate::params::apply(&table, &mut config);
                Some(table)
            }
            Err(e) if restart => {
                say(FromFlight::Event {
                    severity: heli_fsw::core::Severity::WarningHi,
                    text: format!("{e}: resuming the flight on the default parameters"),
                });
                None
            }
            Err(e) => {
                // The bootstrap answers the pending Start Logging with this.
                say(FromFlight::Refused(e.to_string()));
                bail!("{e}");
            }
        }
    } else {
        None
    };
    let baro_rate = params
        .as_ref()
        .and_then(crate::params::baro_rate_hz)
        .unwrap_or(args.baro_rate);
    let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
    let parameters = [
        ("suffix".to_string(), suffix.clone()),
        ("mode".to_string(), mode.name().to_string()),
        ("plan".to_string(), plan.name),
        ("plan_legs_json".to_string(), plan_legs),
        ("calibration_s".to_string(), args.calibration_s.to_string()),
        ("warm_up_s".to_string(), args.warm_up_s.to_string()),
        ("baro_rate_hz".to_string(), baro_rate.to_string()),
        (
            "params".to_string(),
            params.as_ref().map(|t| t.to_text()).unwrap_or_default(),
        ),
        ("clock_speed".to_string(), args.clock_speed.to_string()),
        // Whether the flight flew under its real-time settings (`--no-realtime`), and pinned.
        ("realtime".to_string(), realtime.to_string()),
        (
            "rt_cpu".to_string(),
            args.rt_cpu.map(|c| c.to_string()).unwrap_or_default(),
        ),
        ("lab_tested".to_string(), lab_line),
        ("lab_override".to_string(), lab_override.to_string()),
        (
            "compass_bias_gauss".to_string(),
            format!("{:?}", compass.bias_gauss),
        ),
        ("compass_scale".to_string(), format!("{:?}", compass.scale)),
        ("devices".to_string(), format!("{devices:?}")),
        (
            "warm_start".to_string(),
            restart_from
                .as_ref()
                .map(|w| w.to_text())
                .unwrap_or_default(),
        ),
    ];
    let metadata = heli_log::metadata::flight(software, std::time::SystemTime::now(), parameters);
    let setup = FlightSetup {
        devices,
        config,
        params: FlightParams {
            mode,
            plan: plan.plan,
        },
        baro_rate_hz: baro_rate,
        log_path: Some(log_path.clone()),
        log_fallback_dir: fallback.clone(),
        metadata,
        clock,
        restart_from: restart_from.map(|w| w.warm),
        warm_file: Some((warm_paths, start.clone())),
        ground_link: Arc::clone(&ground_link),
        supervision: Arc::clone(&supervision),
        realtime,
        rt_cpu: args.rt_cpu,
        latency_trace: args.latency_trace.clone(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let log_name = Arc::new(Mutex::new(None::<String>));
    {
        let lines = BootstrapLines {
            stop: Arc::clone(&stop),
            ground_link: Arc::clone(&ground_link),
            supervision: Arc::clone(&supervision),
            outbox: Arc::clone(&outbox),
            listener,
            start: start.clone(),
            log_name: Arc::clone(&log_name),
        };
        rt::thread("bootstrap-lines", rt::HELPER_STACK_BYTES).spawn(move || lines.serve())?;
    }
    let line = reporter(Arc::clone(&outbox))?;
    let report = Arc::new(move |r: Report| {
        line(match r {
            Report::Started { log } => {
                let log = log.map(|p| p.display().to_string());
                *log_name.lock().unwrap_or_else(|e| e.into_inner()) = log.clone();
                FromFlight::Started { log }
            }
            Report::Note(text) => FromFlight::Note(text),
            Report::Event { severity, text, .. } => FromFlight::Event { severity, text },
            Report::Telemetry(v) => FromFlight::Telemetry(v),
            Report::Stop(StopAnswer::Landing, text) => FromFlight::Landing(text),
            // Refused, a landing given up (`Now` ends the flight: `stopped` says it).
            Report::Stop(_, text) => FromFlight::Refused(text),
        });
    });
    let summary = match flight::run(setup, stop, report) {
        Ok(s) => s,
        Err(e) => {
            // The bootstrap answers the pending Start Logging with this.
            say(FromFlight::Refused(e.to_string()));
            bail!("{e}");
        }
    };
    // A clean end leaves nothing in RAM: the fallback directory goes if it is empty (a log
    // that fell back there stays, for the operator to take).
    if let Some(dir) = &fallback {
        let _ = std::fs::remove_dir(dir);
    }
    let s = summary.stats;
    let json = serde_json::json!({
        "imu_samples": s.imu_samples,
        "watchdog_fires": s.watchdog_fires,
        "control_steps": s.control_steps,
        "uplinks": s.uplinks,
        "gps_fixes": s.gps_fixes,
        "baro_readings": s.baro_readings,
        "compass_readings": s.compass_readings,
        "inputs": summary.inputs,
        "log_messages": summary.log.as_ref().map(|l| l.messages),
        "log_error": summary.log.as_ref().and_then(|l| l.error.clone()),
        "log_storage_dropped": summary.log.as_ref().map(|l| l.dropped),
        "log_failed_writes": summary.log.as_ref().map(|l| l.failed_writes),
        "log_failed_syncs": summary.log.as_ref().map(|l| l.failed_syncs),
        "log_dropped": summary.log_dropped,
    });
    say(FromFlight::Stopped(json));
    Ok(ExitCode::SUCCESS)
}

/// What the bootstrap says of its link, as the flight loop keeps it: 1 a ground is heard,
/// 2 none (0, set before any word, is a vehicle without a link).
fn link_state(fresh: bool) -> u8 {
    if fresh { 1 } else { 2 }
}

/// Removes the adoption socket when the process ends cleanly (a killed process leaves it
/// stale; the next one replaces it).
struct RemoveOnDrop(std::path::PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// The flight process's side of its supervision while it flies: the bootstrap's lines (Stop,
/// the link's state) and, when they end without a Stop, a new bootstrap taking the flight
/// back on the adoption socket.
struct BootstrapLines {
    stop: Arc<AtomicBool>,
    ground_link: Arc<AtomicU8>,
    supervision: Arc<flight::Supervision>,
    outbox: Arc<Outbox>,
    listener: Option<UnixListener>,
    start: StartParameters,
    log_name: Arc<Mutex<Option<String>>>,
}

impl BootstrapLines {
    fn say(&self, message: FromFlight) {
        self.outbox.say(&message);
    }

    /// Serves standard input, then each bootstrap that takes the flight back, until a kill.
    fn serve(self) {
        let mut input: Box<dyn BufRead> = Box::new(std::io::stdin().lock());
        loop {
            if self.read_until_stop(&mut *input) {
                self.stop.store(true, Ordering::Release);
                return;
            }
            // The bootstrap is gone: the control loop decides (`flight::Supervision`).
            self.supervision.line_ended.store(true, Ordering::Release);
            match self.wait_for_a_bootstrap() {
                Some(stream) => input = Box::new(std::io::BufReader::new(stream)),
                None => return,
            }
        }
    }

    /// Whether the lines ended in a kill (not in the end of the input). A Stop goes to the
    /// flight computer, which ends the flight on the ground.
    fn read_until_stop(&self, input: &mut dyn BufRead) -> bool {
        let say = |m: FromFlight| self.say(m);
        while let Some(message) = next_message(input, &say) {
            match message {
                ToFlight::Kill => return true,
                ToFlight::Stop => {
                    self.supervision
                        .stop_requested
                        .store(true, Ordering::Release);
                }
                ToFlight::Link { fresh } => {
                    self.ground_link.store(link_state(fresh), Ordering::Release);
                }
                ToFlight::Start(_) | ToFlight::Restart(_) => self.say(FromFlight::Refused(
                    "already started: stop this flight first".into(),
                )),
            }
        }
        false
    }

    /// The next bootstrap that connects to the adoption socket and hears this process's
    /// introduction; from then on the lines go to it. `None` without a socket.
    fn wait_for_a_bootstrap(&self) -> Option<std::os::unix::net::UnixStream> {
        let listener = self.listener.as_ref()?;
        let mut errors = crate::control_socket::AcceptErrors::default();
        loop {
            // Said on standard error: no bootstrap hears this process now.
            let Some((mut stream, _)) = errors.take("adoption socket", listener.accept()) else {
                continue;
            };
            let log = self
                .log_name
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone();
            if !crate::adopt::introduce(&mut stream, &self.start, log) {
                continue;
            }
            let Ok(writer) = stream.try_clone() else {
                continue;
            };
            self.outbox.replace(Box::new(writer));
            self.supervision.line_ended.store(false, Ordering::Release);
            return Some(stream);
        }
    }
}

/// The flight log's path: `flight_<suffix>.mcap`, or for a process started again after a
/// crash `flight_<suffix>_r<N>.mcap` with the first N not taken in the log directory or
/// the fallback one (the crashed process's log is never overwritten).
/// The plan of a start this process can fly, or why it cannot: a plan it does not know, or
/// (a new flight, not a restart) a log of that suffix already in the log directory or the
/// fallback (a log is never replaced).
fn startable(
    args: &crate::cli::FlightArgs,
    fallback: Option<&std::path::Path>,
    start: &heli_link::StartParameters,
    restart: bool,
) -> Result<crate::plans::FlightPlan, String> {
    let dir = args.log_dir.as_path();
    let plan = crate::plans::named(start.plan.as_deref(), args.plans_dir.as_deref())
        .map_err(|e| e.to_string())?;
    let name = heli_log::file_name("flight", &start.file_suffix, "mcap");
    if !restart {
        // The parameters set over the link: a file that cannot be used refuses the start,
        // with its reason, rather than flying on values nobody chose.
        if crate::params::path_in(dir).exists() {
            crate::params::load(dir).map_err(|e| e.to_string())?;
        }
        for place in std::iter::once(dir).chain(fallback) {
            if place.join(&name).exists() {
                return Err(format!(
                    "a log {name} exists already in {} (a log is never replaced): choose another suffix",
                    place.display()
                ));
            }
        }
    }
    Ok(plan)
}

fn next_free_log(
    dir: &std::path::Path,
    fallback: Option<&std::path::Path>,
    suffix: &str,
    restart: bool,
) -> std::path::PathBuf {
    let first = dir.join(heli_log::file_name("flight", suffix, "mcap"));
    if !restart {
        return first;
    }
    let taken = |name: &std::path::Path| {
        dir.join(name).exists() || fallback.is_some_and(|f| f.join(name).exists())
    };
    (1..1000)
        .map(|n| heli_log::file_name("flight", &format!("{suffix}_r{n}"), "mcap"))
        .find(|name| !taken(std::path::Path::new(name)))
        .map_or(first, |name| dir.join(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bootstraps_word_on_its_link_is_kept_as_the_flight_loop_reads_it() {
        // 0 is a vehicle without a link (never said by the bootstrap), 1 a ground heard, 2
        // none: `flight::run` hands 1 and 2 to the flight software and leaves 0 unjudged.
        assert_eq!(link_state(true), 1);
        assert_eq!(link_state(false), 2);
    }

    #[test]
    fn dropped_report_lines_are_counted_and_said_once_with_their_number() {
        let dropped = Dropped::default();
        assert!(dropped.note().is_none(), "nothing dropped, nothing said");
        dropped.count();
        dropped.count();
        let note = dropped.note().map(|n| n.to_string()).unwrap_or_default();
        assert!(note.contains("2 report lines dropped"), "{note}");
        assert!(dropped.note().is_none(), "said once");
    }

    #[test]
    fn a_restarted_process_logs_beside_its_predecessors_never_over_them() {
        let dir = tempfile::tempdir().unwrap();
        let ram = tempfile::tempdir().unwrap();
        let (d, r) = (dir.path(), ram.path());
        assert_eq!(
            next_free_log(d, Some(r), "t1", false),
            d.join("flight_t1.mcap")
        );
        assert_eq!(
            next_free_log(d, Some(r), "t1", true),
            d.join("flight_t1_r1.mcap")
        );
        std::fs::write(d.join("flight_t1_r1.mcap"), b"").unwrap();
        assert_eq!(
            next_free_log(d, Some(r), "t1", true),
            d.join("flight_t1_r2.mcap")
        );
        // A name taken in the fallback directory is taken too.
        std::fs::write(r.join("flight_t1_r2.mcap"), b"").unwrap();
        assert_eq!(
            next_free_log(d, Some(r), "t1", true),
            d.join("flight_t1_r3.mcap")
        );
        assert_eq!(
            next_free_log(d, None, "t1", true),
            d.join("flight_t1_r2.mcap")
        );
    }
}
