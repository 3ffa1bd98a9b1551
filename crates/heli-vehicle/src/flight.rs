//! The flight process (thesis §2.3.2, the main control process and its children): driver
//! threads on the serial ports and the compass ADC, the control loop woken by what they read
//! (the IMU above all) with its watchdogs on the monotonic clock, the streams, the battery and
//! telemetry servers, and the logger. The control loop runs the same
//! [`heli_fsw::FlightComputer`] the lockstep simulator runs.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::Duration;

use heli_fsw::core::{
    Action, CoreConfig, CoreEvent, CoreStats, FlightParams, Severity, StopAnswer,
};
use heli_fsw::{FlightComputer, Phase, RecordedInput};
use heli_types::Port;
use serde_json::Value;

use crate::device_writes::WriteTally;
use crate::devices::Devices;
use crate::error::VehicleError;
use crate::logger::{self, LogItem, LogReport, LogSender};
use crate::rt;
use crate::streams::LiveStreams;
use crate::telemetry;
use crate::threads::{self, Clock, LoopMsg, Writers};
use crate::warm_keeper::WarmKeeper;

/// Longest the loop sleeps without looking at the stop flag.
const LOOP_WAKE: Duration = Duration::from_millis(20);

/// What a flight needs.
#[derive(Clone, Debug)]
pub struct FlightSetup {
    /// Where the devices are.
    pub devices: Devices,
    /// Flight software configuration.
    pub config: CoreConfig,
    /// The ground's parameters.
    pub params: FlightParams,
    /// Altimeter readings per second (1..=10).
    pub baro_rate_hz: u8,
    /// Where to write the flight log, if anywhere.
    pub log_path: Option<PathBuf>,
    /// Where the log goes when `log_path` cannot be created (a full or read-only disk): a
    /// directory, RAM-backed on a vehicle (`/dev/shm`). Failing both, the flight flies
    /// without a log: storage never keeps a helicopter from flying.
    pub log_fallback_dir: Option<PathBuf>,
    /// What to record in the log's `flight` metadata (parameters, version, wall clock).
    pub metadata: BTreeMap<String, String>,
    /// The flight clock (started when the process started): at wall-clock speed on a
    /// vehicle; faster only against a HILSim run at `--speed` above 1.
    pub clock: Clock,
    /// Started again after a crash or a brown-out: the record the process before left
    /// (`heli_fsw::core::restart`).
    pub restart_from: Option<heli_fsw::core::WarmStart>,
    /// Where to keep this process's own record for a successor, with the start it flies
    /// (`crate::warm`): the first path, and a second one (RAM-backed) kept the same, so
    /// that a full or read-only log disk does not lose it.
    pub warm_file: Option<(Vec<PathBuf>, heli_link::StartParameters)>,
    /// What the flight and its supervisor know of each other.
    pub supervision: Arc<Supervision>,
    /// What the bootstrap says of its link: 0 nothing (no link), 1 a ground is heard, 2 no
    /// ground is heard. The control loop hands each change to the flight software.
    pub ground_link: Arc<std::sync::atomic::AtomicU8>,
    /// Under the real-time settings ([`crate::rt`]: memory locked, `SCHED_FIFO`, CPUs kept
    /// awake), each where the machine allows; false flies as an unprivileged process would.
    pub realtime: bool,
    /// The CPU the real-time threads (loop, drivers) are pinned to, if any.
    pub rt_cpu: Option<usize>,
    /// Where to write the stage-by-stage latency of every servo command when the flight
    /// process ends ([`crate::latency`]), if anywhere.
    pub latency_trace: Option<PathBuf>,
}

pub use crate::supervision::Supervision;

/// What the flight process reports while it runs.
#[derive(Clone, Debug)]
pub enum Report {
    /// The log is open and the loop is about to start.
    Started {
        /// The log file, if any.
        log: Option<PathBuf>,
    },
    /// A note from the runtime (real-time settings, a port error, a restarted thread).
    Note(String),
    /// An event of the flight computer.
    Event {
        /// Flight clock (µs).
        t_us: u64,
        /// How much it matters.
        severity: Severity,
        /// What happened.
        text: String,
    },
    /// A telemetry snapshot.
    Telemetry(Value),
    /// The flight computer's answer to a Stop that does not end the flight now (landing
    /// first, refused, a landing given up), with its text.
    Stop(StopAnswer, String),
}

/// What a flight did.
#[derive(Clone, Debug)]
pub struct FlightSummary {
    /// The main loop's counters.
    pub stats: CoreStats,
    /// Inputs handed to the flight computer.
    pub inputs: u64,
    /// The logger's account, if there was a log.
    pub log: Option<LogReport>,
    /// Log items dropped because the logger fell behind.
    pub log_dropped: u64,
}

/// The flight's log: at its path, else in the fallback directory, else none; each failure
/// raised as an event with its cause. Returns the logger and the path it writes.
fn open_log(
    setup: &FlightSetup,
    clock: Clock,
    report: &Arc<dyn Fn(Report) + Send + Sync>,
) -> (
    Option<LogSender>,
    Option<std::thread::JoinHandle<LogReport>>,
    Option<PathBuf>,
) {
    let Some(path) = &setup.log_path else {
        return (None, None, None);
    };
    let fallback = setup
        .log_fallback_dir
        .as_ref()
        .zip(path.file_name())
        .map(|(dir, name)| dir.join(name));
    let mut tries = std::iter::once(path.clone()).chain(fallback).peekable();
    while let Some(path) = tries.next() {
        let note = {
            let report = Arc::clone(report);
            Arc::new(move |text: String| report(Report::Note(text)))
                as Arc<dyn Fn(String) + Send + Sync>
        };
        match logger::spawn(&path, &setup.metadata, note) {
            Ok((sender, handle)) => return (Some(sender), Some(handle), Some(path)),
            Err(e) => {
                let then = match tries.peek() {
                    Some(next) => format!("logging to {} instead", next.display()),
                    None => "FLYING WITHOUT A LOG".to_string(),
                };
                report(Report::Event {
                    t_us: clock.now_us(),
                    severity: Severity::WarningHi,
                    text: format!("{e}: {then}"),
                });
            }
        }
    }
    (None, None, None)
}

/// Runs a flight until `stop` is set (a kill, or the end of the process), or a Stop asked
/// through `setup.supervision` ends it on the ground. Reports go to `report` (from several
/// threads).
pub fn run(
    setup: FlightSetup,
    stop: Arc<AtomicBool>,
    report: Arc<dyn Fn(Report) + Send + Sync>,
) -> Result<FlightSummary, VehicleError> {
    let clock = setup.clock;
    let realtime = setup.realtime;
    let rt_threads = rt::RtThreads {
        realtime,
        cpu: setup.rt_cpu,
    };
    // What the machine granted of the real-time settings: said now, and kept in the log
    // once it is open (a jittery flight's log says whether it flew under them).
    let mut rt_notes = Vec::new();
    let _wake_latency = if realtime {
        rt_notes.push(rt::lock_memory());
        let (request, note) = rt::hold_wake_latency();
        rt_notes.push(note);
        request
    } else {
        rt_notes.push(
            "real-time settings off (--no-realtime): memory not locked, normal scheduler, \
             CPUs may sleep"
                .to_string(),
        );
        None
    };
    for note in &rt_notes {
        report(Report::Note(note.clone()));
    }
    let (tx, rx) = channel::<LoopMsg>();
    let writers = Arc::new(Writers::default());
    let streams = Arc::new(LiveStreams::default());
    let (log, log_thread, log_path) = open_log(&setup, clock, &report);
    if let Some(log) = &log {
        for note in rt_notes {
            log.send(LogItem::Note(clock.now_us(), note));
        }
    }
    let spawn_error = |what: &str, source: std::io::Error| VehicleError::Thread {
        name: what.to_string(),
        source,
    };
    let mut helpers = Vec::new();
    for port in Port::ALL {
        helpers.push(
            threads::spawn_port(
                port,
                &setup.devices,
                clock,
                tx.clone(),
                Arc::clone(&writers),
                Arc::clone(&stop),
                rt_threads,
            )
            .map_err(|e| spawn_error(port.name(), e))?,
        );
    }
    helpers.push(
        threads::spawn_compass(
            &setup.devices,
            clock,
            tx.clone(),
            Arc::clone(&stop),
            rt_threads,
        )
        .map_err(|e| spawn_error("compass", e))?,
    );
    if let Some(line) = &setup.devices.gpio.hotswap {
        let line = crate::hotswap::HotSwapLine::parse(line)?;
        helpers.push(
            crate::hotswap::spawn_hotswap(line, clock, tx.clone(), Arc::clone(&stop))
                .map_err(|e| spawn_error("hotswap", e))?,
        );
    }
    let (battery, battery_thread) = telemetry::spawn_battery_server(
        setup.devices.adc.dir.clone(),
        setup.devices.adc.battery,
        tx.clone(),
        clock,
        Arc::clone(&streams),
        log.clone(),
        Arc::clone(&stop),
    )
    .map_err(|e| spawn_error("battery", e))?;
    helpers.push(battery_thread);
    let telemetry_report = {
        let report = Arc::clone(&report);
        Arc::new(move |v: Value| report(Report::Telemetry(v))) as Arc<dyn Fn(Value) + Send + Sync>
    };
    helpers.push(
        telemetry::spawn_telemetry(
            clock,
            Arc::clone(&streams),
            battery,
            telemetry_report,
            Arc::clone(&stop),
        )
        .map_err(|e| spawn_error("telemetry", e))?,
    );
    drop(tx);
    // The first commands (the board's check, the altimeter's reset) go out at start: give
    // every port its first try at opening before the loop starts (up to 2 s).
    writers.wait_for_first_attempts(Duration::from_secs(2));
    report(Report::Started {
        log: log_path.clone(),
    });

    let keeper = setup.warm_file.clone().map(|(paths, start)| {
        let report = Arc::clone(&report);
        let say = move |severity, text| {
            report(Report::Event {
                t_us: clock.now_us(),
                severity,
                text,
            });
        };
        WarmKeeper::spawn(paths, start, clock, say)
    });
    let control = {
        let stop = Arc::clone(&stop);
        let report = Arc::clone(&report);
        let log = log.clone();
        rt::thread("control", rt::CONTROL_STACK_BYTES)
            .spawn(move || {
                let said = |note: String| {
                    if let Some(log) = &log {
                        log.send(LogItem::Note(clock.now_us(), note.clone()));
                    }
                    report(Report::Note(note));
                };
                if realtime {
                    said(rt::realtime_thread(rt::LOOP_PRIORITY));
                }
                if let Some(cpu) = rt_threads.cpu {
                    said(format!("control loop and drivers {}", rt::pin_to_cpu(cpu)));
                }
                control_loop(
                    &setup,
                    clock,
                    &rx,
                    &writers,
                    &streams,
                    log.as_ref(),
                    &stop,
                    keeper,
                    &*report,
                )
            })
            .map_err(|e| spawn_error("control", e))?
    };
    let outcome = control.join();
    // The loop ends only when stopped; make sure every helper sees it.
    stop.store(true, Ordering::Release);
    for h in helpers {
        let _ = h.join();
    }
    let log_dropped = log.as_ref().map_or(0, LogSender::dropped);
    drop(log);
    // A logger that panicked still has an account: its file, and why it ends early.
    let log_report = log_thread.map(|h| {
        h.join()
            .unwrap_or_else(|_| LogReport::panicked(log_path.unwrap_or_default()))
    });
    let (stats, inputs) = outcome.map_err(|_| VehicleError::Panicked("control loop"))?;
    Ok(FlightSummary {
        stats,
        inputs,
        log: log_report,
        log_dropped,
    })
}

/// The control loop: every input to the flight computer in arrival order, ticks at its
/// deadlines, servo and altimeter bytes out, records to the streams and the logger.
#[allow(clippy::too_many_arguments)]
fn control_loop(
    setup: &FlightSetup,
    clock: Clock,
    rx: &Receiver<LoopMsg>,
    writers: &Writers,
    streams: &LiveStreams,
    log: Option<&LogSender>,
    stop: &AtomicBool,
    mut keeper: Option<WarmKeeper>,
    report: &(dyn Fn(Report) + Send + Sync),
) -> (CoreStats, u64) {
    let mut computer = match setup.restart_from {
        Some(warm) => {
            FlightComputer::restarted(setup.config, setup.params, setup.baro_rate_hz, warm)
        }
        None => FlightComputer::new(setup.config, setup.params, setup.baro_rate_hz),
    };
    let mut actions: Vec<Action> = Vec::with_capacity(64);
    let write_failures = std::cell::RefCell::new(WriteTally::default());
    // A write's failure or recovery: raised with its severity, and kept in the log.
    let raise = |said: crate::device_writes::Said| {
        let t_us = clock.now_us();
        if let Some(log) = log {
            log.send(LogItem::Note(t_us, said.text.clone()));
        }
        report(Report::Event {
            t_us,
            severity: said.severity,
            text: said.text,
        });
    };
    let probe = crate::latency::Probe::new(setup.latency_trace.clone());
    let mut tx = |port: Port, bytes: &[u8]| {
        if port == Port::Scb {
            // Stamped as the write begins: the reader at the other end may have the bytes
            // before the call returns here.
            probe.servo_written();
        }
        let outcome = writers.write(port, bytes);
        // Counted per port; a port's first failure (with why) and its recovery said.
        if let Some(said) = write_failures.borrow_mut().record(port, &outcome) {
            raise(said);
        }
    };
    let mut last_t_us = clock.now_us();
    if let Some(log) = log {
        log.send(LogItem::Start(last_t_us));
    }
    computer.start(last_t_us, &mut tx);
    let mut inputs = 0u64;
    let mut input_log = logger::InputLog::new(log);
    // A Stop the flight computer said may end the flight now (on the ground).
    let stop_now = std::cell::Cell::new(false);
    let mut feed = |computer: &mut FlightComputer, t_us: u64, input: RecordedInput| {
        if let Some(note) = input_log.record(|| LogItem::Input(t_us, inputs, input.clone())) {
            report(Report::Note(note.into()));
        }
        actions.clear();
        let imu = matches!(input, RecordedInput::Bytes(Port::Imu, _));
        probe.step_start();
        computer.receive(t_us, input.as_input(), &mut tx, &mut actions);
        inputs = inputs.saturating_add(1);
        for action in &actions {
            match action {
                Action::Publish(record) => streams.publish(record),
                Action::Event(e) => {
                    if logger::worth_reporting(&e.value) {
                        report(Report::Event {
                            t_us: e.t_us,
                            severity: e.value.severity(),
                            text: heli_log::events::event_text(e.t_us, &e.value),
                        });
                    }
                    match e.value {
                        CoreEvent::Stop(StopAnswer::Now) => stop_now.set(true),
                        CoreEvent::Stop(answer) => report(Report::Stop(
                            answer,
                            heli_log::events::event_text(e.t_us, &e.value),
                        )),
                        _ => {}
                    }
                }
                Action::Servo(_) => {}
            }
            if let Some(log) = log {
                log.send(LogItem::Action(*action));
            }
        }
        streams.health.publish(*computer.core().health());
        streams.phase.publish(computer.core().phase());
        if matches!(
            input,
            RecordedInput::Battery(_) | RecordedInput::PowerLine(_)
        ) || inputs.is_multiple_of(50)
        {
            streams
                .power
                .publish(crate::telemetry::power_row(computer.core(), t_us));
            streams.origin.publish(computer.core().navigator().origin());
        }
        let warm = computer.core().warm_start();
        setup.supervision.in_air.store(
            may_be_in_air(warm.as_ref(), computer.core().phase()),
            Ordering::Release,
        );
        if let Some(k) = keeper.as_mut() {
            k.offer(t_us, warm);
        }
        probe.step_end(imu);
    };
    let mut told_link = 0u8;
    let mut orphaned = false;
    while !stop.load(Ordering::Acquire) {
        let now = clock.now_us();
        let wait = computer
            .poll_at()
            .map_or(LOOP_WAKE, |at| {
                Duration::from_micros(at.saturating_sub(now))
            })
            .min(LOOP_WAKE);
        match rx.recv_timeout(wait) {
            Ok(LoopMsg::Input(t_us, input)) => {
                // Threads stamp independently: keep the computer's time from going back.
                last_t_us = last_t_us.max(t_us);
                probe.woken(&clock, t_us);
                feed(&mut computer, last_t_us, input);
            }
            Ok(LoopMsg::Note(text)) => {
                if let Some(log) = log {
                    log.send(LogItem::Note(clock.now_us(), text.clone()));
                }
                report(Report::Note(text));
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        let link = setup.ground_link.load(Ordering::Acquire);
        if link != 0 && link != told_link {
            told_link = link;
            last_t_us = last_t_us.max(clock.now_us());
            feed(
                &mut computer,
                last_t_us,
                RecordedInput::GroundLink(link == 1),
            );
        }
        if setup
            .supervision
            .stop_requested
            .swap(false, Ordering::AcqRel)
        {
            last_t_us = last_t_us.max(clock.now_us());
            feed(&mut computer, last_t_us, RecordedInput::StopRequested);
        }
        let now = clock.now_us();
        if computer.poll_at().is_some_and(|at| at <= now) {
            last_t_us = last_t_us.max(now);
            feed(&mut computer, last_t_us, RecordedInput::Tick);
        }
        let verdict = setup.supervision.check(&mut orphaned);
        if let Some(text) = verdict.event {
            let t_us = clock.now_us();
            if let Some(log) = log {
                log.send(LogItem::Note(t_us, text.to_string()));
            }
            report(Report::Event {
                t_us,
                severity: verdict.severity,
                text: text.to_string(),
            });
        }
        if verdict.end || stop_now.get() {
            break;
        }
    }
    if let Some(k) = keeper.take() {
        // A clean end: nothing for a successor to resume.
        k.finish();
    }
    if let Some(note) = probe.finish() {
        report(Report::Note(note));
    }
    if let Some(said) = write_failures.borrow().summary() {
        raise(said);
    }
    (computer.core().stats(), inputs)
}

/// Whether the helicopter may be in the air: it has been up in this flight, and is not in
/// a phase only a helicopter on the ground is in.
fn may_be_in_air(warm: Option<&heli_fsw::core::WarmStart>, phase: Phase) -> bool {
    let on_ground = matches!(
        phase,
        Phase::Landed | Phase::Calibrating | Phase::PreflightCheck { .. } | Phase::TakeoffRefused
    );
    warm.is_some_and(|w| w.airborne) && !on_ground
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_fsw::core::WarmStart;

    #[test]
    fn only_a_helicopter_that_has_been_up_and_is_not_in_a_ground_phase_may_be_in_the_air() {
        let up = WarmStart {
            gyro_bias_rps: [0.0; 3],
            origin: None,
            home_ned_m: None,
            airborne: true,
            trim: None,
            references: heli_nav::GroundReferences::default(),
            roll: None,
        };
        let never = WarmStart {
            airborne: false,
            ..up
        };
        let hold = Phase::BlindDescent;
        assert!(may_be_in_air(Some(&up), hold));
        assert!(may_be_in_air(Some(&up), Phase::Manual));
        assert!(!may_be_in_air(Some(&never), hold));
        assert!(!may_be_in_air(None, Phase::Manual));
        for ground in [
            Phase::Landed,
            Phase::Calibrating,
            Phase::TakeoffRefused,
            Phase::PreflightCheck { since_us: 0 },
        ] {
            assert!(!may_be_in_air(Some(&up), ground), "{ground:?}");
        }
    }
}
