//! The flight process's runtime (`heli_vehicle::flight::run`) on pseudo-terminals, with this
//! test as the devices: the IMU's packets time the control loop, the servo controller board's
//! port carries the start check and a servo command for every other IMU packet, a silent
//! IMU is filled in by the watchdog and then reported, a port that is not there is reported
//! with the commands lost to it, the ground link's changes reach the flight software and its
//! log, the battery's channel reaches the telemetry's power row, and the warm-start record is
//! kept while the flight runs and removed when it ends cleanly.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use heli_fsw::core::{CoreConfig, FlightParams, Severity};
use heli_proto::imu::ImuRepr;
use heli_vehicle::devices::{Adc, Devices, Gpio, Ports};
use heli_vehicle::flight::{FlightSetup, FlightSummary, Report, run};
use serialport::{SerialPort, TTYPort};

/// The test's ends of the IMU's, the board's and the GPS's pseudo-terminals, and the
/// directory of the analog channels.
struct Bench {
    imu: TTYPort,
    scb: TTYPort,
    _gps: TTYPort,
    _slaves: Vec<TTYPort>,
    devices: Devices,
}

fn bench(dir: &Path) -> Bench {
    let pair = || {
        let (master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        (master, slave, path)
    };
    let (imu, imu_slave, imu_path) = pair();
    let (scb, scb_slave, scb_path) = pair();
    let (gps, gps_slave, gps_path) = pair();
    let adc = dir.join("adc");
    std::fs::create_dir_all(&adc).unwrap();
    for (channel, counts) in [(0, 2048), (1, 2048), (2, 2048), (3, 3000)] {
        heli_vehicle::adc::write_channel(&adc, channel, counts).unwrap();
    }
    let devices = Devices {
        ports: Ports {
            imu: imu_path,
            scb: scb_path,
            gps: gps_path,
            // No altimeter: its commands are lost, and that is reported.
            baro: dir.join("no-such-altimeter"),
        },
        adc: Adc {
            dir: adc,
            compass: [0, 1, 2],
            battery: 3,
        },
        gpio: Gpio {
            hotswap: Some(dir.join("hotswap").display().to_string()),
        },
    };
    // On the ground battery at first.
    std::fs::write(dir.join("hotswap"), "0\n").unwrap();
    Bench {
        imu,
        scb,
        _gps: gps,
        _slaves: vec![imu_slave, scb_slave, gps_slave],
        devices,
    }
}

fn imu_frame() -> Vec<u8> {
    let mut buf = [0u8; heli_proto::imu::FRAME_LEN];
    let n = ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
    .emit(&mut buf)
    .unwrap();
    buf[..n].to_vec()
}

/// Everything the servo controller board's port received so far.
fn drain(port: &mut TTYPort, into: &mut Vec<u8>) {
    let mut buf = [0u8; 4096];
    while port.bytes_to_read().unwrap_or(0) > 0 {
        match std::io::Read::read(port, &mut buf) {
            Ok(n) if n > 0 => into.extend_from_slice(&buf[..n]),
            _ => break,
        }
    }
}

/// The servo commands in the board's bytes after the start check, and the bytes that were
/// not part of one.
fn servo_commands(bytes: &[u8]) -> (usize, u32) {
    let mut framer = heli_proto::scb::ServoFramer::default();
    let after_check = bytes.get(heli_proto::scb::CHECK_LEN..).unwrap_or_default();
    let commands = after_check
        .iter()
        .filter(|&&b| framer.push(b).is_some())
        .count();
    (commands, framer.stats().discarded_bytes)
}

struct Flying {
    stop: Arc<AtomicBool>,
    reports: Arc<Mutex<Vec<Report>>>,
    thread: std::thread::JoinHandle<Result<FlightSummary, heli_vehicle::error::VehicleError>>,
    began: Instant,
}

impl Flying {
    fn notes(&self) -> Vec<String> {
        self.reports
            .lock()
            .unwrap()
            .iter()
            .filter_map(|r| match r {
                Report::Note(t) => Some(t.clone()),
                Report::Event { text, .. } => Some(text.clone()),
                _ => None,
            })
            .collect()
    }

    fn wait_for(&self, what: &str, timeout: Duration, done: impl Fn(&[Report]) -> bool) {
        let started = Instant::now();
        while !done(&self.reports.lock().unwrap()) {
            assert!(
                started.elapsed() < timeout,
                "{what}: not within {timeout:?}; {:#?}",
                self.notes()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn land(self) -> (FlightSummary, Vec<Report>) {
        self.stop.store(true, Ordering::Release);
        let summary = self.thread.join().unwrap().unwrap();
        let reports = std::mem::take(&mut *self.reports.lock().unwrap());
        (summary, reports)
    }
}

fn fly(devices: Devices, dir: &Path, ground_link: Arc<AtomicU8>) -> Flying {
    fly_with(devices, dir, ground_link, |_| {})
}

fn fly_with(
    devices: Devices,
    dir: &Path,
    ground_link: Arc<AtomicU8>,
    change: impl FnOnce(&mut FlightSetup),
) -> Flying {
    let mut setup = FlightSetup {
        devices,
        config: CoreConfig {
            imu_warm_up_s: 0.1,
            calibration_s: 0.5,
            ..CoreConfig::default()
        },
        params: FlightParams::default(),
        baro_rate_hz: 5,
        log_path: Some(dir.join("flight.mcap")),
        log_fallback_dir: None,
        metadata: BTreeMap::new(),
        clock: heli_vehicle::threads::Clock::start(),
        restart_from: None,
        warm_file: Some((
            vec![dir.join("warm-start")],
            heli_vehicle::supervisor::parse_start_words("t1 manual").unwrap(),
        )),
        ground_link,
        supervision: Arc::default(),
        realtime: true,
        rt_cpu: None,
        latency_trace: None,
    };
    change(&mut setup);
    let stop = Arc::new(AtomicBool::new(false));
    let reports = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&reports);
    let report = Arc::new(move |r: Report| sink.lock().unwrap().push(r));
    let flag = Arc::clone(&stop);
    let began = Instant::now();
    let thread = std::thread::spawn(move || run(setup, flag, report));
    Flying {
        stop,
        reports,
        thread,
        began,
    }
}

#[test]
fn a_flight_on_pseudo_terminals_is_timed_by_the_imu_and_watched() {
    let dir = tempfile::tempdir().unwrap();
    let Bench {
        mut imu,
        mut scb,
        _gps,
        _slaves,
        devices,
    } = bench(dir.path());
    let ground_link = Arc::new(AtomicU8::new(0));
    let flight = fly(devices, dir.path(), Arc::clone(&ground_link));
    // Every port that is there opens at once: the loop does not wait out the 2 s allowed
    // for slow ones.
    flight.wait_for("started", Duration::from_secs(5), |r| {
        r.iter().any(|r| matches!(r, Report::Started { .. }))
    });
    assert!(
        flight.began.elapsed() < Duration::from_millis(1500),
        "started after {:?}",
        flight.began.elapsed()
    );
    // Two seconds of IMU packets at 100 Hz: calibrated, and a record for a successor.
    let frame = imu_frame();
    let mut board = Vec::new();
    let mut next = Instant::now();
    for k in 0..200 {
        std::io::Write::write_all(&mut imu, &frame).unwrap();
        next += Duration::from_millis(10);
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
        if k % 20 == 0 {
            drain(&mut scb, &mut board);
        }
        if k == 100 {
            ground_link.store(1, Ordering::Release);
            std::fs::write(dir.path().join("hotswap"), "1\n").unwrap();
        }
    }
    std::thread::sleep(Duration::from_millis(50));
    drain(&mut scb, &mut board);
    assert!(
        dir.path().join("warm-start").exists(),
        "the warm-start record is kept in flight"
    );
    // The IMU goes quiet: the watchdog fills in, then the IMU is reported silent.
    ground_link.store(2, Ordering::Release);
    flight.wait_for("the IMU reported silent", Duration::from_secs(3), |r| {
        r.iter()
            .any(|r| matches!(r, Report::Event { text, .. } if text.contains("imu silent")))
    });
    flight.wait_for(
        "the battery in the telemetry",
        Duration::from_secs(3),
        |r| {
            r.iter().any(|r| {
                // The freshest value of each stream: the IMU's, the battery server's
                // voltage, the gauges' power row.
                matches!(r, Report::Telemetry(v)
                if v["power"]["batteries"].as_array().is_some_and(|b| !b.is_empty())
                    && v["battery_v"].is_number()
                    && v["imu"]["rate_rps"].is_array())
            })
        },
    );
    // A hot-swap line that reads nonsense is said once, and the flight goes on.
    std::fs::write(dir.path().join("hotswap"), "maybe\n").unwrap();
    flight.wait_for(
        "the hot-swap's nonsense said",
        Duration::from_secs(3),
        |r| {
            r.iter()
                .any(|r| matches!(r, Report::Note(t) if t.contains("is not 0 or 1")))
        },
    );
    // A battery channel that reads nonsense is said once, with its path and what it read,
    // and again when it reads a count.
    let battery_channel = heli_vehicle::adc::channel_path(&dir.path().join("adc"), 3);
    std::fs::write(&battery_channel, "junk\n").unwrap();
    flight.wait_for(
        "the battery channel's nonsense said",
        Duration::from_secs(4),
        |r| {
            r.iter().any(|r| {
                matches!(r, Report::Note(t) if t.starts_with("battery: ")
                    && t.contains("in_voltage3_raw") && t.contains("'junk'"))
            })
        },
    );
    heli_vehicle::adc::write_channel(&dir.path().join("adc"), 3, 3000).unwrap();
    flight.wait_for(
        "the battery channel read again",
        Duration::from_secs(4),
        |r| {
            r.iter()
                .any(|r| matches!(r, Report::Note(t) if t == "battery: read again"))
        },
    );
    std::thread::sleep(Duration::from_millis(300));
    let (summary, reports) = flight.land();
    // Single watchdog fires are counted, not reported; the IMU's silence is.
    assert!(
        !reports
            .iter()
            .any(|r| matches!(r, Report::Event { text, .. } if text.contains("watchdog"))),
        "{reports:#?}"
    );
    let notes: Vec<String> = reports
        .iter()
        .filter_map(|r| match r {
            Report::Note(t) => Some(t.clone()),
            _ => None,
        })
        .collect();
    // The altimeter's port is not there: its first lost command is said (once, however many
    // follow) as a warning the ground pins, and its count at the end; every servo command
    // went out; the logger kept up.
    let lost = events(&reports, Severity::WarningHi);
    assert_eq!(
        lost.iter()
            .filter(|n| n.contains("write to baro failed"))
            .count(),
        1,
        "{lost:#?}"
    );
    assert!(
        lost.iter().any(
            |n| n.contains("device writes failed during the flight (baro ") && !n.contains("scb")
        ),
        "{lost:#?}"
    );
    assert!(
        !reports.iter().any(|r| matches!(r,
            Report::Note(t) | Report::Event { text: t, .. } if t.contains("write to scb"))),
        "{reports:#?}"
    );
    assert_eq!(
        notes.iter().filter(|n| n.starts_with("battery: ")).count(),
        2,
        "one failing spell, said once, and its end: {notes:#?}"
    );
    assert!(
        !notes.iter().any(|n| n.contains("logger fell behind")),
        "{notes:#?}"
    );
    assert_eq!(
        notes.iter().filter(|n| n.contains("is not 0 or 1")).count(),
        1,
        "{notes:#?}"
    );
    // The board was checked at start, then given one servo command per control step: one
    // for every other IMU packet, and the watchdog's fill-ins.
    std::thread::sleep(Duration::from_millis(100));
    drain(&mut scb, &mut board);
    eprintln!("{notes:#?}");
    assert_eq!(
        &board[..heli_proto::scb::CHECK_LEN],
        &[heli_proto::scb::CHECK_BYTE; heli_proto::scb::CHECK_LEN]
    );
    let stats = summary.stats;
    assert_eq!(
        servo_commands(&board),
        (stats.control_steps as usize, 0),
        "{stats:?}"
    );
    assert!(stats.control_steps >= 100, "{stats:?}");
    assert_eq!(stats.imu_samples, 200);
    assert!(
        stats.compass_readings >= 20,
        "the compass read at 20 Hz: {stats:?}"
    );
    assert!(stats.watchdog_fires >= 1, "{stats:?}");
    assert!(summary.inputs >= 200, "{}", summary.inputs);
    // A clean end: nothing for a successor to resume.
    assert!(!dir.path().join("warm-start").exists());
    // The ground link's two changes are inputs of the flight, in its log.
    let log_path = dir.path().join("flight.mcap");
    let log = heli_log::reader::read(&std::fs::read(&log_path).unwrap());
    assert!(log.closed, "the log was finished");
    let report = summary.log.as_ref().unwrap();
    assert_eq!(report.path, log_path);
    assert_eq!(report.error, None);
    assert_eq!(report.messages, log.messages.len() as u64);
    // The lost commands, the battery channel's spell and the real-time settings granted
    // are in the log's notes, as they were said.
    let logged: Vec<&str> = log
        .messages
        .iter()
        .filter(|m| m.topic == "notes")
        .filter_map(|m| m.value["text"].as_str())
        .collect();
    for said in [
        "write to baro failed",
        "device writes failed during the flight (baro ",
        "battery: read again",
        "memory ",
    ] {
        assert!(
            logged.iter().any(|t| t.contains(said)),
            "{said}: {logged:#?}"
        );
    }
    let counts = log.counts();
    for channel in ["imu", "servo", "state", "device", "events", "notes"] {
        assert!(
            counts.get(channel).is_some_and(|n| *n > 0),
            "{channel}: {counts:?}"
        );
    }
    let lines: Vec<bool> = log
        .messages
        .iter()
        .filter(|m| m.value["kind"] == "power_line")
        .map(|m| m.value["high"].as_bool().unwrap())
        .collect();
    assert_eq!(
        lines,
        [false, true],
        "the hot-swap's level at start and its change"
    );
    let links: Vec<bool> = log
        .messages
        .iter()
        .filter(|m| m.value["kind"] == "ground_link")
        .map(|m| m.value["fresh"].as_bool().unwrap())
        .collect();
    assert_eq!(links, [true, false], "{:?}", log.counts());
}

#[test]
fn a_flight_with_every_port_there_reports_no_lost_commands() {
    let dir = tempfile::tempdir().unwrap();
    let Bench {
        mut imu,
        scb: _scb,
        _gps,
        _slaves,
        mut devices,
    } = bench(dir.path());
    let (_baro, baro_slave, baro_path) = {
        let (master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        (master, slave, path)
    };
    devices.ports.baro = baro_path;
    devices.gpio = Gpio::default();
    // The compass's channels are not there: said once, however many reads fail.
    devices.adc.compass = [7, 8, 9];
    let trace = dir.path().join("latency.csv");
    let flight = fly_with(devices, dir.path(), Arc::new(AtomicU8::new(0)), |s| {
        s.latency_trace = Some(trace.clone());
    });
    flight.wait_for("started", Duration::from_secs(5), |r| {
        r.iter().any(|r| matches!(r, Report::Started { .. }))
    });
    for _ in 0..30 {
        std::io::Write::write_all(&mut imu, &imu_frame()).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    let (summary, reports) = flight.land();
    drop(baro_slave);
    assert!(summary.stats.control_steps > 0);
    // The latency trace: a record for each servo command that answered an IMU packet,
    // its stages in order on the machine's monotonic clock.
    let records = heli_vehicle::latency::read(&trace).unwrap();
    assert!(
        records.len() >= 5 && records.len() as u64 <= u64::from(summary.stats.control_steps),
        "{} records, {} steps",
        records.len(),
        summary.stats.control_steps
    );
    for r in &records {
        assert!(
            r.imu_read_ns <= r.loop_woken_ns + 1_000
                && r.loop_woken_ns <= r.step_start_ns
                && r.step_start_ns <= r.servo_written_ns
                && r.servo_written_ns <= r.step_end_ns,
            "{r:?}"
        );
    }
    assert!(
        reports
            .iter()
            .any(|r| matches!(r, Report::Note(t) if t.starts_with("latency trace: "))),
        "{reports:#?}"
    );
    let writes: Vec<_> = reports
        .iter()
        .filter(|r| matches!(r, Report::Note(t) if t.contains("write")))
        .collect();
    assert!(writes.is_empty(), "{writes:#?}");
    let compass = reports
        .iter()
        .filter(|r| matches!(r, Report::Note(t) if t.starts_with("compass: ")))
        .count();
    assert_eq!(compass, 1, "{reports:#?}");
}

/// The texts of the events reported at `severity`.
fn events(reports: &[Report], severity: Severity) -> Vec<String> {
    reports
        .iter()
        .filter_map(|r| match r {
            Report::Event {
                severity: s, text, ..
            } if *s == severity => Some(text.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn a_log_directory_that_refuses_the_log_sends_it_to_the_fallback_and_then_to_none() {
    let dir = tempfile::tempdir().unwrap();
    // A log directory that cannot take the log (here: it is not there; a full or read-only
    // disk says so in its own words) and a fallback that can, for the warm-start record too.
    let refused = dir.path().join("refused");
    let fallback = dir.path().join("ram");
    std::fs::create_dir(&fallback).unwrap();
    let Bench {
        mut imu,
        scb: _scb,
        _gps,
        _slaves,
        devices,
    } = bench(dir.path());
    let flight = fly_with(devices.clone(), dir.path(), Arc::default(), |setup| {
        setup.log_path = Some(refused.join("flight.mcap"));
        setup.log_fallback_dir = Some(fallback.clone());
        setup.warm_file = Some((
            vec![refused.join("warm-start"), fallback.join("warm-start")],
            heli_vehicle::supervisor::parse_start_words("t1 manual").unwrap(),
        ));
    });
    flight.wait_for("started", Duration::from_secs(5), |r| {
        r.iter().any(|r| matches!(r, Report::Started { .. }))
    });
    // Past the calibration (0.6 s): the estimate runs and its record is kept.
    for _ in 0..120 {
        std::io::Write::write_all(&mut imu, &imu_frame()).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    flight.wait_for("the record", Duration::from_secs(5), |_| {
        fallback.join("warm-start").exists()
    });
    // The log directory comes back: the record is kept there again, and that is said.
    std::fs::create_dir(&refused).unwrap();
    for _ in 0..200 {
        std::io::Write::write_all(&mut imu, &imu_frame()).unwrap();
        std::thread::sleep(Duration::from_millis(10));
        if refused.join("warm-start").exists() {
            break;
        }
    }
    flight.wait_for("written again", Duration::from_secs(3), |r| {
        events(r, Severity::ActivityHi)
            .iter()
            .any(|t| t.ends_with("warm-start: written again"))
    });
    let warned = events(&flight.reports.lock().unwrap(), Severity::WarningHi);
    let (summary, reports) = flight.land();
    assert!(summary.stats.control_steps > 0);
    let started = reports.iter().find_map(|r| match r {
        Report::Started { log } => Some(log.clone()),
        _ => None,
    });
    assert_eq!(started, Some(Some(fallback.join("flight.mcap"))));
    let log = heli_log::reader::read(&std::fs::read(fallback.join("flight.mcap")).unwrap());
    assert!(log.closed && !log.messages.is_empty());
    // Each refusal raised at once, with its cause and what was done instead.
    assert!(
        warned.iter().any(|t| t.contains("flight.mcap")
            && t.contains("No such file")
            && t.contains(&format!(
                "logging to {} instead",
                fallback.join("flight.mcap").display()
            ))),
        "{warned:#?}"
    );
    assert!(
        warned.iter().any(|t| t.starts_with(&format!(
            "warm-start record {}",
            refused.join("warm-start").display()
        ))),
        "{warned:#?}"
    );
    assert!(
        !fallback.join("warm-start").exists(),
        "a clean end removes it"
    );

    // Neither place takes it: the flight flies without a log, and says so.
    let flight = fly_with(devices, dir.path(), Arc::default(), |setup| {
        let gone = refused.join("gone");
        setup.log_path = Some(gone.join("flight.mcap"));
        setup.log_fallback_dir = Some(gone.join("nor-this"));
    });
    flight.wait_for("started", Duration::from_secs(5), |r| {
        r.iter().any(|r| matches!(r, Report::Started { .. }))
    });
    for _ in 0..30 {
        std::io::Write::write_all(&mut imu, &imu_frame()).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    let (summary, reports) = flight.land();
    assert!(summary.stats.control_steps > 0, "it flew");
    assert!(summary.log.is_none());
    assert!(
        reports
            .iter()
            .any(|r| matches!(r, Report::Started { log: None }))
    );
    let warned = events(&reports, Severity::WarningHi);
    assert!(
        warned.iter().any(|t| t.ends_with("FLYING WITHOUT A LOG")),
        "{warned:#?}"
    );
}

#[test]
fn a_flight_whose_bootstrap_is_gone_on_the_ground_ends_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let Bench {
        mut imu,
        scb: _scb,
        _gps,
        _slaves,
        devices,
    } = bench(dir.path());
    let supervision = Arc::new(heli_vehicle::flight::Supervision::default());
    let flight = fly_with(devices, dir.path(), Arc::default(), |setup| {
        setup.supervision = Arc::clone(&supervision);
    });
    flight.wait_for("started", Duration::from_secs(5), |r| {
        r.iter().any(|r| matches!(r, Report::Started { .. }))
    });
    for _ in 0..20 {
        std::io::Write::write_all(&mut imu, &imu_frame()).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(!flight.thread.is_finished());
    // The bootstrap's line ends without a Stop, on the ground: the flight ends by itself.
    supervision.line_ended.store(true, Ordering::Release);
    let began = Instant::now();
    while !flight.thread.is_finished() {
        assert!(
            began.elapsed() < Duration::from_secs(3),
            "the flight went on"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let reports = flight.reports.lock().unwrap().clone();
    let warned = events(&reports, Severity::WarningHi);
    assert!(
        warned
            .iter()
            .any(|t| t.contains("line ended without a Stop")
                && t.ends_with("on the ground: ending the flight")),
        "{warned:#?}"
    );
    let summary = flight.thread.join().unwrap().unwrap();
    let log = heli_log::reader::read(&std::fs::read(dir.path().join("flight.mcap")).unwrap());
    assert!(log.closed);
    assert!(
        log.messages.iter().any(|m| m.topic == "notes"
            && m.value["text"]
                .as_str()
                .is_some_and(|t| t.contains("line ended"))),
        "the reason is in the log"
    );
    assert!(summary.stats.imu_samples > 0);
}
