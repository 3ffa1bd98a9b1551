//! The stand-alone drivers (`heli vehicle driver ...`) on pseudo-terminals and an ADC
//! directory, with this test as the device: the IMU's packets printed and logged with the
//! 12 ms watchdog's misses, the servo controller board checked and its pilot's commands
//! passed to the servos, the GPS's fixes, an altimeter that never answers its handshake,
//! the compass's and the battery's channels, and the wrong kind of source refused.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use heli_proto::scb::{Controls, PilotUplink, Pulses};
use heli_vehicle::standalone::{DriverKind, DriverReport, Source, run};
use serialport::{SerialPort, TTYPort};

/// A pseudo-terminal: the test's end, the slave kept open, and the slave's path.
fn pty() -> (TTYPort, TTYPort, PathBuf) {
    let (master, slave) = TTYPort::pair().unwrap();
    let path = PathBuf::from(slave.name().unwrap());
    (master, slave, path)
}

/// A driver running in a thread: what it printed so far, and its end.
struct Driving {
    lines: std::sync::mpsc::Receiver<String>,
    thread: std::thread::JoinHandle<Result<DriverReport, heli_vehicle::error::VehicleError>>,
    seen: Vec<String>,
}

impl Driving {
    /// Whether it printed a line yet.
    fn speaking(&mut self) -> bool {
        self.seen.extend(self.lines.try_iter());
        !self.seen.is_empty()
    }

    fn finished(&self) -> bool {
        self.thread.is_finished()
    }

    fn end(
        mut self,
    ) -> (
        Result<DriverReport, heli_vehicle::error::VehicleError>,
        Vec<String>,
    ) {
        let report = self.thread.join().unwrap();
        self.seen.extend(self.lines.try_iter());
        (report, self.seen)
    }
}

/// Starts a driver until it has read `max_samples`.
fn drive(kind: DriverKind, source: Source, log: Option<PathBuf>, max_samples: u64) -> Driving {
    let (tx, lines) = std::sync::mpsc::channel();
    let thread = std::thread::spawn(move || {
        let stop = AtomicBool::new(false);
        run(
            kind,
            &source,
            log.as_deref(),
            5,
            Some(max_samples),
            &stop,
            &mut |l: &str| {
                let _ = tx.send(l.to_string());
            },
        )
    });
    Driving {
        lines,
        thread,
        seen: Vec::new(),
    }
}

/// Writes `frame` every 10 ms until `until` says stop (at most 10 s).
fn feed(port: &mut TTYPort, frame: &[u8], mut until: impl FnMut() -> bool) {
    let started = std::time::Instant::now();
    while !until() {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "the driver never read enough"
        );
        port.write_all(frame).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn log_counts(path: &Path) -> std::collections::BTreeMap<String, u64> {
    let log = heli_log::reader::read(&std::fs::read(path).unwrap());
    assert!(log.closed, "the log is finished");
    log.counts()
}

fn imu_frame(rate: f64) -> Vec<u8> {
    let mut buf = [0u8; heli_proto::imu::FRAME_LEN];
    let n = heli_proto::imu::ImuRepr {
        rate_rps: [rate, 0.0, 0.0],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 31.5,
    }
    .emit(&mut buf)
    .unwrap();
    buf[..n].to_vec()
}

#[test]
fn the_imu_driver_prints_logs_and_counts_the_watchdogs_misses() {
    let dir = tempfile::tempdir().unwrap();
    let (mut master, _slave, path) = pty();
    let log = dir.path().join("imu.mcap");
    let mut driver = drive(DriverKind::Imu, Source::Port(path), Some(log.clone()), 20);
    // Packets at 100 Hz until the driver speaks, then garbage, five packets, a 60 ms gap,
    // and packets until it has read twenty.
    feed(&mut master, &imu_frame(0.25), || driver.speaking());
    master.write_all(&[0x13, 0x37, 0x00]).unwrap();
    for _ in 0..5 {
        master.write_all(&imu_frame(0.25)).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(60));
    feed(&mut master, &imu_frame(0.25), || driver.finished());
    let (report, lines) = driver.end();
    let report = report.unwrap();
    assert_eq!(report.samples, 20);
    assert!(report.watchdog_misses >= 3, "{report:?}");
    assert_eq!(report.discarded_bytes, 3);
    assert_eq!(
        lines.iter().filter(|l| l.contains("WATCHDOG")).count() as u64,
        report.watchdog_misses
    );
    let imu_lines: Vec<_> = lines.iter().filter(|l| l.contains(" imu rate")).collect();
    assert_eq!(imu_lines.len(), 20);
    assert!(
        imu_lines[0].contains("imu rate +0.2500 +0.0000 +0.0000 rad/s  accel +0.000 +0.000 -9.8")
            && imu_lines[0].ends_with("m/s2  31.5 C"),
        "{}",
        imu_lines[0]
    );
    let counts = log_counts(&log);
    assert_eq!(counts.get("imu"), Some(&20));
    // Only reads that brought bytes are device inputs.
    let inputs = heli_log::reader::read(&std::fs::read(&log).unwrap());
    assert!(
        inputs
            .messages
            .iter()
            .filter(|m| m.topic == "device")
            .all(|m| m.value["hex"].as_str().is_some_and(|h| !h.is_empty())),
        "an empty read logged"
    );
    assert!(counts.get("device").is_some_and(|n| *n >= 1));
    assert_eq!(
        report.log_messages,
        counts.values().sum::<u64>(),
        "{counts:?}"
    );
}

#[test]
fn the_board_is_checked_then_given_the_pilots_commands_every_20_ms() {
    let (mut master, _slave, path) = pty();
    let driver = drive(DriverKind::Scb, Source::Port(path), None, 15);
    let sticks = Controls {
        aileron: 0.25,
        elevator: -0.5,
        rudder: 0.1,
        collective: 0.3,
        throttle: 0.7,
    };
    let mut frame = [0u8; heli_proto::scb::UPLINK_LEN];
    let uplink = PilotUplink {
        rotor_rpm: 1600,
        pulses: Pulses::from_controls(&sticks),
        auto_mode: false,
        bypass: true,
        receiver_batt_v: 5.0,
        servo_batt_v: 4.8,
    };
    let n = uplink.emit(&mut frame).unwrap();
    feed(&mut master, &frame[..n], || driver.finished());
    let (report, lines) = driver.end();
    let report = report.unwrap();
    assert_eq!(report.samples, 15);
    // 150 ms of packets read: a servo packet at most every 20 ms.
    assert!((5..=9).contains(&report.servo_packets), "{report:?}");
    assert!(
        lines[0].contains("scb ail")
            && lines[0].contains("rotor 1600 rpm  auto false bypass true  rx 5.00 V servo 4.80 V"),
        "{}",
        lines[0]
    );
    std::thread::sleep(Duration::from_millis(50));
    let mut got = Vec::new();
    let mut buf = [0u8; 1024];
    while master.bytes_to_read().unwrap() > 0 {
        let n = master.read(&mut buf).unwrap();
        got.extend_from_slice(&buf[..n]);
    }
    let check = heli_proto::scb::CHECK_LEN;
    assert_eq!(got[..check], [heli_proto::scb::CHECK_BYTE; 9]);
    let servos: Vec<_> = got[check..]
        .chunks(heli_proto::scb::SERVO_LEN)
        .map(|c| heli_proto::scb::ServoPacket::parse(c).unwrap())
        .collect();
    assert_eq!(servos.len() as u64, report.servo_packets);
    assert!(
        servos
            .iter()
            .all(|s| s.pulses == Pulses::from_controls(&sticks))
    );
}

#[test]
fn the_gps_driver_prints_each_fix() {
    let (mut master, _slave, path) = pty();
    let driver = drive(DriverKind::Gps, Source::Port(path), None, 3);
    let fix = heli_proto::gps::GpsNav {
        tow_ms: 1000,
        lat_deg: 42.3601,
        lon_deg: -71.0942,
        alt_m: 12.5,
        vel_ned_mps: [1.0, -0.5, 0.25],
        satellites: 7,
        fix: heli_proto::gps::FixType::Fix3D,
    };
    let mut buf = [0u8; 64];
    let n = fix.emit(&mut buf).unwrap();
    feed(&mut master, &buf[..n], || driver.finished());
    let (report, lines) = driver.end();
    assert_eq!(report.unwrap().samples, 3);
    assert!(
        lines[0]
            .contains("gps 42.3601000 -71.0942000 12.5 m  vel +1.00 -0.50 +0.25 m/s  7 sats Fix3D"),
        "{}",
        lines[0]
    );
}

#[test]
fn an_altimeter_that_never_answers_fails_its_handshake_after_three_tries() {
    let (mut master, _slave, path) = pty();
    let (report, lines) = drive(DriverKind::Baro, Source::Port(path), None, 1).end();
    assert_eq!(
        report.unwrap_err().to_string(),
        "the altimeter never answered its handshake (3 tries)"
    );
    assert!(
        lines.iter().any(|l| l.contains("altimeter Failed")),
        "{lines:?}"
    );
    // Three resets were sent.
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while master.bytes_to_read().unwrap() > 0 {
        let n = master.read(&mut buf).unwrap();
        got.extend_from_slice(&buf[..n]);
    }
    let commands = got
        .iter()
        .filter(|&&b| b == heli_proto::baro::COMMAND_HEADER)
        .count();
    assert_eq!(commands, 3, "{:?}", String::from_utf8_lossy(&got));
}

#[test]
fn the_compass_and_battery_channels_are_read_printed_and_logged() {
    let dir = tempfile::tempdir().unwrap();
    let adc = dir.path().join("adc");
    std::fs::create_dir_all(&adc).unwrap();
    for (channel, counts) in [(0, 2100), (1, 2000), (2, 2600), (3, 3100)] {
        heli_vehicle::adc::write_channel(&adc, channel, counts).unwrap();
    }
    let log = dir.path().join("compass.mcap");
    let compass = Source::Adc {
        dir: adc.clone(),
        channels: vec![0, 1, 2],
    };
    let started = std::time::Instant::now();
    let (report, lines) = drive(DriverKind::Compass, compass, Some(log.clone()), 3).end();
    // 20 readings a second: three in well under a second.
    assert!(
        started.elapsed() < Duration::from_millis(800),
        "{:?}",
        started.elapsed()
    );
    assert_eq!(report.unwrap().samples, 3);
    assert_eq!(lines.len(), 3);
    assert!(
        lines[0].contains("compass counts 2100 2000 2600"),
        "{}",
        lines[0]
    );
    assert!(lines[0].contains("deg"), "a heading: {}", lines[0]);
    let counts = log_counts(&log);
    assert_eq!(
        (counts.get("compass"), counts.get("device")),
        (Some(&3), Some(&3))
    );
    let battery = Source::Adc {
        dir: adc.clone(),
        channels: vec![3],
    };
    let log = dir.path().join("battery.mcap");
    let started = std::time::Instant::now();
    let (report, lines) = drive(DriverKind::Battery, battery, Some(log.clone()), 2).end();
    assert_eq!(report.unwrap().samples, 2);
    // Once a second: the second reading a second after the first.
    assert!(
        started.elapsed() >= Duration::from_secs(1),
        "{:?}",
        started.elapsed()
    );
    let volts = heli_proto::battery::BatteryAdc { counts: 3100 }.volts();
    assert!(
        lines[0].ends_with(&format!("battery {volts:.2} V (3100 counts)")),
        "{}",
        lines[0]
    );
    assert_eq!(log_counts(&log).get("battery"), Some(&2));
}

#[test]
fn the_wrong_kind_of_source_is_refused_with_what_to_give() {
    let dir = tempfile::tempdir().unwrap();
    let adc = Source::Adc {
        dir: dir.path().to_path_buf(),
        channels: vec![0],
    };
    let e = drive(DriverKind::Imu, adc, None, 1)
        .end()
        .0
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("this device is on a serial port: give --port PATH"),
        "{e}"
    );
    let port = Source::Port(dir.path().join("ttyS9"));
    let e = drive(DriverKind::Compass, port, None, 1)
        .end()
        .0
        .unwrap_err()
        .to_string();
    assert!(e.contains("give --adc DIR, not a serial port"), "{e}");
    // Two channels for the battery, or a channel that is not there.
    let two = Source::Adc {
        dir: dir.path().to_path_buf(),
        channels: vec![0, 1],
    };
    heli_vehicle::adc::write_channel(dir.path(), 0, 1).unwrap();
    heli_vehicle::adc::write_channel(dir.path(), 1, 1).unwrap();
    let e = drive(DriverKind::Battery, two, None, 1)
        .end()
        .0
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "wrong number of ADC channels for this device (the compass reads 3, x, y and z; the battery 1)"
    );
    let missing = Source::Adc {
        dir: dir.path().to_path_buf(),
        channels: vec![7],
    };
    let e = drive(DriverKind::Battery, missing, None, 1)
        .end()
        .0
        .unwrap_err()
        .to_string();
    assert!(e.contains("in_voltage7_raw"), "{e}");
}
