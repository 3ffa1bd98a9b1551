//! Device drivers, protocol half: bytes from a serial port in, verified samples out.
//!
//! Each driver wraps the device's byte-at-a-time framer from `heli-proto` (the thesis's
//! interrupt service routine) and counts what it had to throw away. The altimeter driver also
//! runs the device's start-up handshake: reset, verify the answer, set the rate, start
//! continuous readings — retrying a silent device and reporting it failed after three tries.
//! Nothing here reads a clock or a port: the runtime (or the simulator) passes bytes and time.

use heli_proto::Error;
use heli_proto::baro::{self, BaroCommand, BaroReply, ReplyFramer};
use heli_proto::framer::{BinaryFormat, Framer, FramerStats};
use heli_proto::gps::{GpsFormat, GpsNav};
use heli_proto::imu::{ImuFormat, ImuRepr};
use heli_proto::scb::{Controls, PilotUplink, Pulses, SERVO_LEN, ServoPacket, UplinkFormat};

use crate::core::Input;

/// What a driver counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriverStats {
    /// The framer's counters (frames, checksum and framing errors, discarded bytes).
    pub framer: FramerStats,
    /// Frames whose checksum was right but whose fields made no sense.
    pub parse_errors: u32,
}

/// A driver for a binary device: framer plus field parser.
#[derive(Clone, Debug)]
pub struct FramedDriver<F: BinaryFormat, const N: usize, R> {
    framer: Framer<F, N>,
    parse: fn(&[u8]) -> Result<R, Error>,
    parse_errors: u32,
}

impl<F: BinaryFormat, const N: usize, R> FramedDriver<F, N, R> {
    /// A driver that parses verified frames with `parse`.
    pub const fn new(parse: fn(&[u8]) -> Result<R, Error>) -> Self {
        Self {
            framer: Framer::new(),
            parse,
            parse_errors: 0,
        }
    }

    /// Feeds received bytes; calls `sink` with every sample they complete.
    pub fn receive(&mut self, bytes: &[u8], mut sink: impl FnMut(R)) {
        for &b in bytes {
            if let Some(frame) = self.framer.push(b) {
                match (self.parse)(frame) {
                    Ok(sample) => sink(sample),
                    Err(_) => self.parse_errors = self.parse_errors.saturating_add(1),
                }
            }
        }
    }

    /// Counters.
    pub fn stats(&self) -> DriverStats {
        DriverStats {
            framer: self.framer.stats(),
            parse_errors: self.parse_errors,
        }
    }
}

/// IMU driver.
pub type ImuDriver = FramedDriver<ImuFormat, { heli_proto::imu::FRAME_LEN }, ImuRepr>;
/// Servo controller board driver, pilot-uplink direction.
pub type UplinkDriver = FramedDriver<UplinkFormat, { heli_proto::scb::UPLINK_LEN }, PilotUplink>;
/// GPS driver.
pub type GpsDriver = FramedDriver<GpsFormat, { heli_proto::gps::FRAME_LEN }, GpsNav>;

/// A new IMU driver.
pub const fn imu_driver() -> ImuDriver {
    FramedDriver::new(ImuRepr::parse)
}

/// A new pilot-uplink driver.
pub const fn uplink_driver() -> UplinkDriver {
    FramedDriver::new(PilotUplink::parse)
}

/// A new GPS driver.
pub const fn gps_driver() -> GpsDriver {
    FramedDriver::new(GpsNav::parse)
}

/// The bytes of a servo command packet for the servo controller board.
pub fn servo_packet(controls: &Controls) -> [u8; SERVO_LEN] {
    let mut buf = [0u8; SERVO_LEN];
    let packet = ServoPacket {
        pulses: Pulses::from_controls(&controls.clamped()),
    };
    // The buffer is exactly SERVO_LEN long, so emit cannot fail.
    let _ = packet.emit(&mut buf);
    buf
}

/// How long the altimeter may take to answer a command (µs).
pub const BARO_REPLY_TIMEOUT_US: u64 = 500_000;
/// How many times the altimeter is reset before it is declared failed.
pub const BARO_MAX_TRIES: u8 = 3;

/// Where the altimeter handshake is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaroLinkState {
    /// Not started.
    Idle,
    /// Reset sent at `since_us`, waiting for the device's answer.
    AwaitReset {
        /// When the command was sent (µs).
        since_us: u64,
        /// Which try this is (1-based).
        attempt: u8,
    },
    /// Rate command sent, waiting for its echo.
    AwaitRate {
        /// When the command was sent (µs).
        since_us: u64,
        /// Which try this is (1-based).
        attempt: u8,
    },
    /// Continuous readings flowing.
    Streaming,
    /// The device never answered.
    Failed,
}

/// Altimeter driver with the reset / rate / continuous handshake.
#[derive(Clone, Debug)]
pub struct BaroDriver {
    state: BaroLinkState,
    rate_hz: u8,
    framer: ReplyFramer,
    unexpected: u32,
    parse_errors: u32,
}

impl BaroDriver {
    /// A driver that will ask for `rate_hz` readings per second (1..=10; the thesis uses 5).
    pub fn new(rate_hz: u8) -> Self {
        Self {
            state: BaroLinkState::Idle,
            rate_hz: rate_hz.clamp(baro::MIN_RATE_HZ, baro::MAX_RATE_HZ),
            framer: baro::reply_framer(),
            unexpected: 0,
            parse_errors: 0,
        }
    }

    /// Handshake state.
    pub fn state(&self) -> BaroLinkState {
        self.state
    }

    /// Lines that parsed but did not fit the handshake, and lines that did not parse.
    pub fn errors(&self) -> (u32, u32) {
        (self.unexpected, self.parse_errors)
    }

    /// Starts the handshake: resets the device.
    pub fn start(&mut self, now_us: u64, tx: &mut impl FnMut(&[u8])) {
        self.send(BaroCommand::Reset, tx);
        self.state = BaroLinkState::AwaitReset {
            since_us: now_us,
            attempt: 1,
        };
    }

    /// When [`BaroDriver::poll`] must next be called (a reply timeout), if any.
    pub fn poll_at(&self) -> Option<u64> {
        match self.state {
            BaroLinkState::AwaitReset { since_us, .. }
            | BaroLinkState::AwaitRate { since_us, .. } => {
                Some(since_us.saturating_add(BARO_REPLY_TIMEOUT_US))
            }
            _ => None,
        }
    }

    /// Handles reply timeouts: retries with a new reset, or gives up.
    pub fn poll(&mut self, now_us: u64, tx: &mut impl FnMut(&[u8])) {
        let attempt = match self.state {
            BaroLinkState::AwaitReset { since_us, attempt }
            | BaroLinkState::AwaitRate { since_us, attempt }
                if now_us >= since_us.saturating_add(BARO_REPLY_TIMEOUT_US) =>
            {
                attempt
            }
            _ => return,
        };
        if attempt >= BARO_MAX_TRIES {
            self.state = BaroLinkState::Failed;
        } else {
            self.send(BaroCommand::Reset, tx);
            self.state = BaroLinkState::AwaitReset {
                since_us: now_us,
                attempt: attempt.saturating_add(1),
            };
        }
    }

    /// Feeds received bytes; answers the handshake through `tx`; calls `sink` with each
    /// pressure reading (mbar).
    pub fn receive(
        &mut self,
        bytes: &[u8],
        now_us: u64,
        tx: &mut impl FnMut(&[u8]),
        mut sink: impl FnMut(f64),
    ) {
        for &b in bytes {
            let Some(line) = self.framer.push(b) else {
                continue;
            };
            let reply = match BaroReply::parse(line) {
                Ok(r) => r,
                Err(_) => {
                    self.parse_errors = self.parse_errors.saturating_add(1);
                    continue;
                }
            };
            match (self.state, reply) {
                (BaroLinkState::AwaitReset { attempt, .. }, BaroReply::ResetDone) => {
                    self.send(BaroCommand::SetRate(self.rate_hz), tx);
                    self.state = BaroLinkState::AwaitRate {
                        since_us: now_us,
                        attempt,
                    };
                }
                (BaroLinkState::AwaitRate { .. }, BaroReply::RateSet(n)) if n == self.rate_hz => {
                    self.send(BaroCommand::StartContinuous, tx);
                    self.state = BaroLinkState::Streaming;
                }
                (BaroLinkState::Streaming, BaroReply::Pressure { pressure_mbar }) => {
                    sink(pressure_mbar)
                }
                _ => self.unexpected = self.unexpected.saturating_add(1),
            }
        }
    }

    fn send(&self, command: BaroCommand, tx: &mut impl FnMut(&[u8])) {
        let mut buf = [0u8; baro::MAX_LINE];
        if let Ok(n) = command.emit(&mut buf)
            && let Some(bytes) = buf.get(..n)
        {
            tx(bytes);
        }
    }
}

/// The serial devices of the flight computer, protocol halves only.
#[derive(Clone, Debug)]
pub struct Drivers {
    /// IMU.
    pub imu: ImuDriver,
    /// Servo controller board (pilot uplink).
    pub uplink: UplinkDriver,
    /// GPS receiver.
    pub gps: GpsDriver,
    /// Barometric altimeter.
    pub baro: BaroDriver,
}

impl Drivers {
    /// All drivers, the altimeter set to `baro_rate_hz`.
    pub fn new(baro_rate_hz: u8) -> Self {
        Self {
            imu: imu_driver(),
            uplink: uplink_driver(),
            gps: gps_driver(),
            baro: BaroDriver::new(baro_rate_hz),
        }
    }

    /// Bytes from the IMU's port.
    pub fn imu_bytes(&mut self, bytes: &[u8], mut sink: impl FnMut(Input)) {
        self.imu.receive(bytes, |s| sink(Input::Imu(s)));
    }

    /// Bytes from the servo controller board's port.
    pub fn uplink_bytes(&mut self, bytes: &[u8], mut sink: impl FnMut(Input)) {
        self.uplink.receive(bytes, |s| sink(Input::Uplink(s)));
    }

    /// Bytes from the GPS receiver's port.
    pub fn gps_bytes(&mut self, bytes: &[u8], mut sink: impl FnMut(Input)) {
        self.gps.receive(bytes, |s| sink(Input::Gps(s)));
    }

    /// Bytes from the altimeter's port.
    pub fn baro_bytes(
        &mut self,
        bytes: &[u8],
        now_us: u64,
        tx: &mut impl FnMut(&[u8]),
        mut sink: impl FnMut(Input),
    ) {
        self.baro.receive(bytes, now_us, tx, |p| {
            sink(Input::Baro { pressure_mbar: p })
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reply(r: BaroReply) -> Vec<u8> {
        let mut buf = [0u8; 32];
        let n = r.emit(&mut buf).unwrap_or(0);
        buf[..n].to_vec()
    }

    #[test]
    fn baro_handshake_reset_rate_then_readings() {
        let mut d = BaroDriver::new(5);
        let mut sent: Vec<Vec<u8>> = Vec::new();
        let mut readings = Vec::new();
        d.start(0, &mut |b: &[u8]| sent.push(b.to_vec()));
        assert_eq!(BaroCommand::parse(&sent[0]), Ok(BaroCommand::Reset));
        // A reading before the handshake is unexpected, not a sample.
        d.receive(
            &reply(BaroReply::Pressure {
                pressure_mbar: 1000.0,
            }),
            10,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            |p| readings.push(p),
        );
        d.receive(
            &reply(BaroReply::ResetDone),
            100,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            |p| readings.push(p),
        );
        assert_eq!(BaroCommand::parse(&sent[1]), Ok(BaroCommand::SetRate(5)));
        d.receive(
            &reply(BaroReply::RateSet(5)),
            200,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            |p| readings.push(p),
        );
        assert_eq!(
            BaroCommand::parse(&sent[2]),
            Ok(BaroCommand::StartContinuous)
        );
        assert_eq!(d.state(), BaroLinkState::Streaming);
        d.receive(
            &reply(BaroReply::Pressure {
                pressure_mbar: 1012.5,
            }),
            300,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            |p| readings.push(p),
        );
        assert_eq!(readings, vec![1012.5]);
        assert_eq!(d.errors().0, 1);
    }

    #[test]
    fn silent_altimeter_is_retried_then_declared_failed() {
        let mut d = BaroDriver::new(5);
        let mut resets = 0;
        d.start(0, &mut |_: &[u8]| resets += 1);
        let mut t = 0;
        while let Some(at) = d.poll_at() {
            t = at;
            d.poll(t, &mut |_: &[u8]| resets += 1);
        }
        assert_eq!(d.state(), BaroLinkState::Failed);
        assert_eq!(resets, 3);
        assert_eq!(t, 3 * BARO_REPLY_TIMEOUT_US);
    }

    #[test]
    fn servo_packet_round_trips_through_the_board_parser() {
        let c = Controls {
            aileron: 0.25,
            elevator: -0.5,
            rudder: 0.1,
            collective: 0.54,
            throttle: 0.8,
        };
        let bytes = servo_packet(&c);
        let parsed = ServoPacket::parse(&bytes).map(|p| p.pulses.to_controls());
        let back = parsed.unwrap_or_default();
        assert!((back.aileron - 0.25).abs() < 0.002 && (back.collective - 0.54).abs() < 0.002);
    }

    #[test]
    fn each_port_delivers_its_samples_and_counts_its_frames() {
        let mut d = Drivers::new(5);
        let mut inputs = Vec::new();
        let uplink = heli_proto::scb::PilotUplink {
            rotor_rpm: 1580,
            pulses: heli_proto::scb::Pulses::from_controls(&Controls::default()),
            auto_mode: true,
            bypass: false,
            receiver_batt_v: 5.0,
            servo_batt_v: 4.8,
        };
        let mut buf = [0u8; 64];
        let n = uplink.emit(&mut buf).unwrap_or(0);
        d.uplink_bytes(&buf[..n], |i| inputs.push(i));
        let fix = heli_proto::gps::GpsNav {
            tow_ms: 1000,
            lat_deg: 42.36,
            lon_deg: -71.09,
            alt_m: 10.0,
            vel_ned_mps: [0.0; 3],
            satellites: 8,
            fix: heli_proto::gps::FixType::Fix3D,
        };
        let n = fix.emit(&mut buf).unwrap_or(0);
        d.gps_bytes(&buf[..n], |i| inputs.push(i));
        assert!(matches!(inputs[0], Input::Uplink(u) if u.rotor_rpm == 1580 && u.auto_mode));
        assert!(matches!(inputs[1], Input::Gps(f) if f.satellites == 8));
        assert_eq!(d.uplink.stats().framer.frames, 1);
        assert_eq!(d.gps.stats().framer.frames, 1);
        // The altimeter's readings, once it streams.
        let mut sent = 0;
        d.baro.start(0, &mut |_: &[u8]| sent += 1);
        for (t, r) in [
            (1, BaroReply::ResetDone),
            (2, BaroReply::RateSet(5)),
            (
                3,
                BaroReply::Pressure {
                    pressure_mbar: 990.0,
                },
            ),
        ] {
            d.baro_bytes(&reply(r), t, &mut |_: &[u8]| sent += 1, |i| inputs.push(i));
        }
        assert_eq!(sent, 3);
        assert!(matches!(inputs[2], Input::Baro { pressure_mbar } if pressure_mbar == 990.0));
    }

    #[test]
    fn the_altimeter_must_confirm_the_rate_asked_for_and_garbage_is_counted() {
        let mut d = BaroDriver::new(5);
        let mut sent = Vec::new();
        d.start(0, &mut |b: &[u8]| sent.push(b.to_vec()));
        let mut none = |_: f64| {};
        d.receive(
            &reply(BaroReply::ResetDone),
            10,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            &mut none,
        );
        d.receive(
            &reply(BaroReply::RateSet(4)),
            20,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            &mut none,
        );
        assert!(
            matches!(d.state(), BaroLinkState::AwaitRate { .. }),
            "another rate is not this one"
        );
        assert_eq!(d.errors(), (1, 0));
        d.receive(
            b"?garbage\r\n",
            30,
            &mut |b: &[u8]| sent.push(b.to_vec()),
            &mut none,
        );
        assert_eq!(d.errors(), (1, 1));
        // The reply timeout is counted from the last step of the handshake.
        let at = d.poll_at().unwrap_or(0);
        assert_eq!(at, 10 + BARO_REPLY_TIMEOUT_US);
        d.poll(at - 1, &mut |b: &[u8]| sent.push(b.to_vec()));
        assert!(
            matches!(d.state(), BaroLinkState::AwaitRate { .. }),
            "not yet due"
        );
        d.poll(at, &mut |b: &[u8]| sent.push(b.to_vec()));
        assert!(matches!(
            d.state(),
            BaroLinkState::AwaitReset { attempt: 2, .. }
        ));
    }
}
