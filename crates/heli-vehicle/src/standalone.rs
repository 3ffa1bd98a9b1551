//! The stand-alone drivers (thesis §2.3 and ch. 4: "every stand-alone driver has data
//! logging capabilities"): one device, its driver's protocol half from `heli-fsw`, a readable
//! line per packet, and the flight log format of the flight process (the device's stream and
//! its raw inputs on channel `device`).
//!
//! - `imu`: also runs the 12 ms watchdog and reports every miss.
//! - `scb`: sends the board its start-up check, then passes the pilot's commands through to
//!   the servo outputs every 20 ms (the emergency mode of the thesis).
//! - `baro`: runs the reset / rate / continuous handshake at the chosen rate.
//! - `compass`, `battery`: read the ADC channels.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use heli_fsw::core::watchdog::Watchdog;
use heli_fsw::drivers::{self, BaroDriver, BaroLinkState};
use heli_fsw::streams::{BaroRecord, CompassRecord, ImuRecord, Record};
use heli_fsw::{RecordedInput, Stamped};
use heli_log::FlightLog;
use heli_proto::battery::BatteryAdc;
use heli_proto::compass::{CompassAdc, CompassCalibration, heading_rad};
use heli_types::Port;
use serialport::TTYPort;

use crate::error::VehicleError;
use crate::{adc, devices, port};
use heli_log::inputs;

/// Which device (as named on the command line: `heli driver imu`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DriverKind {
    /// The IMU (serial); runs the 12 ms watchdog and reports misses.
    Imu,
    /// The servo controller board (serial); passes the pilot's commands to the servos.
    Scb,
    /// The GPS receiver (serial).
    Gps,
    /// The barometric altimeter (serial); runs the handshake at --rate.
    Baro,
    /// The compass (ADC channels, --adc DIR).
    Compass,
    /// The battery (ADC channel, --adc DIR).
    Battery,
}

/// Where the device is.
#[derive(Clone, Debug)]
pub enum Source {
    /// A serial port.
    Port(PathBuf),
    /// ADC channels of an IIO directory.
    Adc {
        /// The directory.
        dir: PathBuf,
        /// The channels (three for the compass, one for the battery).
        channels: Vec<u8>,
    },
}

/// What a stand-alone driver counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriverReport {
    /// Packets or readings.
    pub samples: u64,
    /// IMU watchdog misses (12 ms without a packet).
    pub watchdog_misses: u64,
    /// Bytes thrown away by the framer.
    pub discarded_bytes: u64,
    /// Servo packets passed through (scb).
    pub servo_packets: u64,
    /// Log messages written.
    pub log_messages: u64,
}

struct Logger {
    log: Option<FlightLog<std::fs::File>>,
}

impl Logger {
    fn new(path: Option<&Path>) -> Result<Self, VehicleError> {
        let log = path
            .map(|p| {
                FlightLog::create(p).map_err(|source| VehicleError::Log {
                    path: Some(p.to_path_buf()),
                    source,
                    hint: "",
                })
            })
            .transpose()?;
        Ok(Self { log })
    }

    fn input(&mut self, t_us: u64, input: &RecordedInput) -> Result<(), VehicleError> {
        match self.log.as_mut() {
            Some(log) => log
                .write(inputs::CHANNEL, t_us, &inputs::input_json(input))
                .map_err(VehicleError::from),
            None => Ok(()),
        }
    }

    fn record(&mut self, record: &Record) -> Result<(), VehicleError> {
        match self.log.as_mut() {
            Some(log) => log.write_record(record).map_err(VehicleError::from),
            None => Ok(()),
        }
    }

    fn value(&mut self, topic: &str, t_us: u64, v: &serde_json::Value) -> Result<(), VehicleError> {
        match self.log.as_mut() {
            Some(log) => log.write(topic, t_us, v).map_err(VehicleError::from),
            None => Ok(()),
        }
    }

    fn finish(self) -> Result<u64, VehicleError> {
        match self.log {
            Some(log) => {
                let n = log.messages();
                log.finish()?;
                Ok(n)
            }
            None => Ok(0),
        }
    }
}

/// Runs a stand-alone driver until `stop` is set or `max_samples` samples were read.
pub fn run(
    kind: DriverKind,
    source: &Source,
    log_path: Option<&Path>,
    baro_rate_hz: u8,
    max_samples: Option<u64>,
    stop: &AtomicBool,
    print: &mut dyn FnMut(&str),
) -> Result<DriverReport, VehicleError> {
    let clock = crate::threads::Clock::start();
    let mut logger = Logger::new(log_path)?;
    let mut report = DriverReport::default();
    let done = |r: &DriverReport| max_samples.is_some_and(|m| r.samples >= m);
    match (kind, source) {
        (DriverKind::Compass | DriverKind::Battery, Source::Adc { dir, channels }) => {
            let period = if kind == DriverKind::Compass {
                Duration::from_millis(50)
            } else {
                Duration::from_secs(1)
            };
            while !stop.load(Ordering::Acquire) && !done(&report) {
                let t_us = clock.now_us();
                let counts: Result<Vec<u16>, _> = channels
                    .iter()
                    .map(|n| adc::read_channel(dir, *n))
                    .collect();
                let counts = counts?;
                match (kind, counts.as_slice()) {
                    (DriverKind::Compass, [x, y, z]) => {
                        let adc = CompassAdc {
                            counts: [*x, *y, *z],
                        };
                        let field = CompassCalibration::default().apply(&adc.raw_field());
                        let heading = heading_rad(&field, 0.0, 0.0);
                        print(&format!(
                            "t={:.3} s compass counts {x} {y} {z}  field {:.3} {:.3} {:.3} G  heading (level) {}",
                            t_us as f64 * 1e-6,
                            field.field_gauss[0],
                            field.field_gauss[1],
                            field.field_gauss[2],
                            heading
                                .map_or("-".to_string(), |h| format!("{:.1} deg", h.to_degrees()))
                        ));
                        logger.input(t_us, &RecordedInput::Compass(adc))?;
                        logger.record(&Record::Compass(Stamped::new(
                            t_us,
                            CompassRecord {
                                adc,
                                field,
                                heading_rad: heading,
                            },
                        )))?;
                    }
                    (DriverKind::Battery, [c]) => {
                        let volts = BatteryAdc { counts: *c }.volts();
                        print(&format!(
                            "t={:.3} s battery {volts:.2} V ({c} counts)",
                            t_us as f64 * 1e-6
                        ));
                        logger.value("battery", t_us, &serde_json::json!({ "volts": volts }))?;
                    }
                    _ => {
                        return Err(VehicleError::Device(
                            "wrong number of ADC channels for this device (the compass reads 3, x, y and z; the battery 1)",
                        ));
                    }
                }
                report.samples = report.samples.saturating_add(1);
                crate::threads::sleep_unless_stopped(period, stop);
            }
        }
        (DriverKind::Compass | DriverKind::Battery, Source::Port(p)) => {
            return Err(VehicleError::invalid(
                p.display().to_string(),
                "the compass and battery are ADC channels: give --adc DIR, not a serial port",
            ));
        }
        (_, Source::Adc { dir, .. }) => {
            return Err(VehicleError::invalid(
                dir.display().to_string(),
                "this device is on a serial port: give --port PATH",
            ));
        }
        (kind, Source::Port(path)) => {
            let port = match kind {
                DriverKind::Imu => Port::Imu,
                DriverKind::Scb => Port::Scb,
                DriverKind::Gps => Port::Gps,
                _ => Port::Baro,
            };
            let mut serial = port::open(path, devices::baud(port))?;
            serial_driver(
                port,
                &mut serial,
                baro_rate_hz,
                clock,
                &mut logger,
                &mut report,
                max_samples,
                stop,
                print,
            )?;
        }
    }
    report.log_messages = logger.finish()?;
    Ok(report)
}

#[allow(clippy::too_many_arguments)]
fn serial_driver(
    port: Port,
    serial: &mut TTYPort,
    baro_rate_hz: u8,
    clock: crate::threads::Clock,
    logger: &mut Logger,
    report: &mut DriverReport,
    max_samples: Option<u64>,
    stop: &AtomicBool,
    print: &mut dyn FnMut(&str),
) -> Result<(), VehicleError> {
    let mut imu = drivers::imu_driver();
    let mut uplink = drivers::uplink_driver();
    let mut gps = drivers::gps_driver();
    let mut baro = BaroDriver::new(baro_rate_hz);
    let mut watchdog = Watchdog::new(heli_fsw::core::watchdog::WATCHDOG_PERIOD_US);
    let mut last_sticks = None;
    let mut next_servo_us = 0u64;
    let mut writes: Vec<Vec<u8>> = Vec::new();
    match port {
        Port::Scb => writes.push(vec![
            heli_proto::scb::CHECK_BYTE;
            heli_proto::scb::CHECK_LEN
        ]),
        Port::Baro => baro.start(clock.now_us(), &mut |b: &[u8]| writes.push(b.to_vec())),
        Port::Imu => {
            // Every 12 ms without a packet is a miss: the reads must wake more often than
            // that, not once per port timeout.
            serialport::SerialPort::set_timeout(serial, Duration::from_millis(2)).map_err(|e| {
                VehicleError::DeviceIo {
                    doing: "setting the read timeout",
                    source: e.into(),
                }
            })?;
            watchdog.kick(clock.now_us());
        }
        Port::Gps => {}
    }
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Acquire) && max_samples.is_none_or(|m| report.samples < m) {
        send(serial, &mut writes)?;
        let n = port::read_some(serial, &mut buf).map_err(|source| VehicleError::DeviceIo {
            doing: "reading the device",
            source,
        })?;
        let t_us = clock.now_us();
        let bytes = buf.get(..n).unwrap_or_default();
        if n > 0 {
            logger.input(t_us, &RecordedInput::Bytes(port, bytes.to_vec()))?;
        }
        let mut records: Vec<Record> = Vec::new();
        match port {
            Port::Imu => {
                imu.receive(bytes, |s| {
                    records.push(Record::Imu(Stamped::new(
                        t_us,
                        ImuRecord {
                            imu: s,
                            repeated: false,
                        },
                    )));
                });
                if !records.is_empty() {
                    watchdog.kick(t_us);
                } else if watchdog.expired(t_us) {
                    watchdog.kick(t_us);
                    report.watchdog_misses = report.watchdog_misses.saturating_add(1);
                    print(&format!(
                        "t={:.3} s WATCHDOG: no IMU packet for 12 ms (miss {})",
                        t_us as f64 * 1e-6,
                        report.watchdog_misses
                    ));
                }
                report.discarded_bytes = u64::from(imu.stats().framer.discarded_bytes);
            }
            Port::Scb => {
                uplink.receive(bytes, |u| {
                    last_sticks = u.sticks();
                    records.push(Record::Uplink(Stamped::new(t_us, u)));
                });
                // Emergency mode: the pilot's commands straight to the servos, every 20 ms.
                if let Some(sticks) = last_sticks
                    && t_us >= next_servo_us
                {
                    next_servo_us = t_us.saturating_add(20_000);
                    writes.push(drivers::servo_packet(&sticks).to_vec());
                    report.servo_packets = report.servo_packets.saturating_add(1);
                }
                report.discarded_bytes = u64::from(uplink.stats().framer.discarded_bytes);
            }
            Port::Gps => {
                gps.receive(bytes, |g| records.push(Record::Gps(Stamped::new(t_us, g))));
                report.discarded_bytes = u64::from(gps.stats().framer.discarded_bytes);
            }
            Port::Baro => {
                let before = baro.state();
                baro.receive(bytes, t_us, &mut |b: &[u8]| writes.push(b.to_vec()), |p| {
                    records.push(Record::Baro(Stamped::new(
                        t_us,
                        BaroRecord {
                            pressure_mbar: p,
                            alt_m: None,
                        },
                    )));
                });
                baro.poll(t_us, &mut |b: &[u8]| writes.push(b.to_vec()));
                if baro.state() != before {
                    print(&format!(
                        "t={:.3} s altimeter {:?}",
                        t_us as f64 * 1e-6,
                        baro.state()
                    ));
                }
                if baro.state() == BaroLinkState::Failed {
                    return Err(VehicleError::Device(
                        "the altimeter never answered its handshake (3 tries)",
                    ));
                }
            }
        }
        for record in &records {
            print(&describe(record));
            logger.record(record)?;
            report.samples = report.samples.saturating_add(1);
        }
    }
    // What the last packets called for still goes out (the pilot's last command, a retry).
    send(serial, &mut writes)
}

/// Writes what is waiting to go to the device.
fn send(serial: &mut TTYPort, writes: &mut Vec<Vec<u8>>) -> Result<(), VehicleError> {
    for w in writes.drain(..) {
        port::write_all(serial, &w).map_err(|source| VehicleError::DeviceIo {
            doing: "writing to the device",
            source,
        })?;
    }
    Ok(())
}

/// A readable line for one record.
pub fn describe(record: &Record) -> String {
    match record {
        Record::Imu(r) => {
            let i = r.value.imu;
            format!(
                "t={:.3} s imu rate {:+.4} {:+.4} {:+.4} rad/s  accel {:+.3} {:+.3} {:+.3} m/s2  {:.1} C",
                r.t_us as f64 * 1e-6,
                i.rate_rps[0],
                i.rate_rps[1],
                i.rate_rps[2],
                i.accel_mps2[0],
                i.accel_mps2[1],
                i.accel_mps2[2],
                i.temp_c
            )
        }
        Record::Uplink(r) => {
            let u = r.value;
            let p = u.pulses;
            format!(
                "t={:.3} s scb ail {} ele {} rud {} col {} thr {} us  rotor {} rpm  auto {} bypass {}  rx {:.2} V servo {:.2} V",
                r.t_us as f64 * 1e-6,
                p.aileron_us,
                p.elevator_us,
                p.rudder_us,
                p.collective_us,
                p.throttle_us,
                u.rotor_rpm,
                u.auto_mode,
                u.bypass,
                u.receiver_batt_v,
                u.servo_batt_v
            )
        }
        Record::Gps(r) => {
            let g = r.value;
            format!(
                "t={:.3} s gps {:.7} {:.7} {:.1} m  vel {:+.2} {:+.2} {:+.2} m/s  {} sats {:?}",
                r.t_us as f64 * 1e-6,
                g.lat_deg,
                g.lon_deg,
                g.alt_m,
                g.vel_ned_mps[0],
                g.vel_ned_mps[1],
                g.vel_ned_mps[2],
                g.satellites,
                g.fix
            )
        }
        Record::Baro(r) => format!(
            "t={:.3} s baro {:.2} mbar",
            r.t_us as f64 * 1e-6,
            r.value.pressure_mbar
        ),
        Record::Compass(r) => format!(
            "t={:.3} s compass {:?}",
            r.t_us as f64 * 1e-6,
            r.value.adc.counts
        ),
        Record::State(r) => format!(
            "t={:.3} s state {}",
            r.t_us as f64 * 1e-6,
            r.value.phase.name()
        ),
        Record::Servo(r) => format!(
            "t={:.3} s servo {:?}",
            r.t_us as f64 * 1e-6,
            r.value.controls
        ),
    }
}
