//! The flight computer as one sans-I/O machine: device bytes and ADC readings in, servo and
//! device commands and the core's actions out.
//!
//! This is the single code path of the flight software. The vehicle runtime feeds it what
//! its driver threads read from serial ports and ADC files; the lockstep simulator feeds it
//! the simulated devices' bytes; `heli log replay` feeds it the device inputs recorded in a
//! flight log. Given the same inputs at the same times it takes the same actions, bit for bit.
//!
//! Inside: the drivers' protocol halves ([`crate::drivers`]: framing, parsing, the altimeter
//! handshake) and the main control process ([`crate::core`]). A driver that gives up on its
//! device (the altimeter handshake, or a port the runtime reports failed) is reported to the
//! core, which raises it and degrades.

use heli_proto::battery::BatteryAdc;
use heli_proto::compass::CompassAdc;

use crate::core::{Action, CoreConfig, FlightCore, FlightParams, Input};
use crate::drivers::{self, BaroLinkState, Drivers};
use crate::invariants::{InvariantReport, Invariants};
use heli_types::{Device, Port};

/// One thing that reaches the flight computer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DeviceInput<'a> {
    /// Bytes read from a serial port.
    Bytes {
        /// Which port.
        port: Port,
        /// What was read.
        bytes: &'a [u8],
    },
    /// The compass's three ADC channels were read.
    Compass(CompassAdc),
    /// The runtime could not open or read a port: its driver gives up on the device.
    PortFailed(Port),
    /// A timer tick: deliver at [`FlightComputer::poll_at`] (extra ticks do no harm).
    Tick,
    /// The flight battery's analog channel was read (once a second).
    Battery(BatteryAdc),
    /// The bootstrap's link says whether a ground station is heard (sent on each change;
    /// never on a vehicle without a link).
    GroundLink {
        /// A ground heard in the last few seconds.
        fresh: bool,
    },
    /// The hot-swap's digital input was read: high when the flight batteries power the
    /// avionics, low on the ground battery.
    PowerLine {
        /// The line's level.
        high: bool,
    },
    /// The operator asked to stop the flight (the bootstrap's `stop`).
    StopRequested,
}

/// An owned [`DeviceInput`], for recordings and flight logs.
#[derive(Clone, Debug, PartialEq)]
pub enum RecordedInput {
    /// Bytes read from a serial port.
    Bytes(Port, Vec<u8>),
    /// The compass's three ADC channels.
    Compass(CompassAdc),
    /// A port failed.
    PortFailed(Port),
    /// A timer tick.
    Tick,
    /// The battery's analog channel.
    Battery(BatteryAdc),
    /// Whether a ground station is heard.
    GroundLink(bool),
    /// The hot-swap's digital input.
    PowerLine(bool),
    /// The operator's Stop.
    StopRequested,
}

impl RecordedInput {
    /// The borrowed form, to feed to [`FlightComputer::receive`].
    pub fn as_input(&self) -> DeviceInput<'_> {
        match self {
            RecordedInput::Bytes(port, bytes) => DeviceInput::Bytes { port: *port, bytes },
            RecordedInput::Compass(adc) => DeviceInput::Compass(*adc),
            RecordedInput::PortFailed(port) => DeviceInput::PortFailed(*port),
            RecordedInput::Tick => DeviceInput::Tick,
            RecordedInput::Battery(adc) => DeviceInput::Battery(*adc),
            RecordedInput::GroundLink(fresh) => DeviceInput::GroundLink { fresh: *fresh },
            RecordedInput::PowerLine(high) => DeviceInput::PowerLine { high: *high },
            RecordedInput::StopRequested => DeviceInput::StopRequested,
        }
    }
}

impl From<DeviceInput<'_>> for RecordedInput {
    fn from(input: DeviceInput<'_>) -> Self {
        match input {
            DeviceInput::Bytes { port, bytes } => RecordedInput::Bytes(port, bytes.to_vec()),
            DeviceInput::Compass(adc) => RecordedInput::Compass(adc),
            DeviceInput::PortFailed(port) => RecordedInput::PortFailed(port),
            DeviceInput::Tick => RecordedInput::Tick,
            DeviceInput::Battery(adc) => RecordedInput::Battery(adc),
            DeviceInput::GroundLink { fresh } => RecordedInput::GroundLink(fresh),
            DeviceInput::PowerLine { high } => RecordedInput::PowerLine(high),
            DeviceInput::StopRequested => RecordedInput::StopRequested,
        }
    }
}

/// Drivers and the main control process together.
#[derive(Clone, Debug)]
pub struct FlightComputer {
    drivers: Drivers,
    core: FlightCore,
    /// Samples the drivers completed, waiting for the core (kept to avoid allocating).
    scratch: Vec<Input>,
    baro_failed_reported: bool,
    /// The invariants' checker and what it found, when asked for.
    invariants: Option<Box<(Invariants, InvariantReport)>>,
}

impl FlightComputer {
    /// A flight computer with the ground's parameters; the altimeter is asked for
    /// `baro_rate_hz` readings per second.
    pub fn new(config: CoreConfig, params: FlightParams, baro_rate_hz: u8) -> Self {
        Self {
            drivers: Drivers::new(baro_rate_hz),
            core: FlightCore::new(config, params),
            scratch: Vec::with_capacity(8),
            baro_failed_reported: false,
            invariants: None,
        }
    }

    /// A flight computer started again after a brown-out or a crash of its flight process,
    /// from the record the one before left ([`FlightCore::restarted`]); start it with
    /// [`FlightComputer::start`] as a new one.
    pub fn restarted(
        config: CoreConfig,
        params: FlightParams,
        baro_rate_hz: u8,
        warm: crate::core::WarmStart,
    ) -> Self {
        Self {
            core: FlightCore::restarted(config, params, warm),
            ..Self::new(config, params, baro_rate_hz)
        }
    }

    /// Starts at `now_us`: arms every watchdog, sends the servo board its start-up check
    /// (nine non-header bytes, which the board answers with an uplink packet; a board that
    /// does not is caught by the uplink watchdog) and begins the altimeter handshake. What
    /// goes to the devices goes out through `tx`.
    pub fn start(&mut self, now_us: u64, tx: &mut impl FnMut(Port, &[u8])) {
        self.core.start(now_us);
        tx(
            Port::Scb,
            &[heli_proto::scb::CHECK_BYTE; heli_proto::scb::CHECK_LEN],
        );
        self.drivers
            .baro
            .start(now_us, &mut |b: &[u8]| tx(Port::Baro, b));
    }

    /// When the next [`DeviceInput::Tick`] is due (the loop watchdog, a device watchdog or
    /// the altimeter's reply timeout).
    pub fn poll_at(&self) -> Option<u64> {
        match (self.core.poll_at(), self.drivers.baro.poll_at()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Handles one input that arrived at `now_us`: bytes for a device go out through `tx`
    /// (servo commands to the board, handshake commands to the altimeter), the core's
    /// actions are appended to `out`.
    pub fn receive(
        &mut self,
        now_us: u64,
        input: DeviceInput<'_>,
        tx: &mut impl FnMut(Port, &[u8]),
        out: &mut Vec<Action>,
    ) {
        let mut samples = core::mem::take(&mut self.scratch);
        samples.clear();
        match input {
            DeviceInput::Bytes { port, bytes } => match port {
                Port::Imu => self.drivers.imu_bytes(bytes, |i| samples.push(i)),
                Port::Scb => self.drivers.uplink_bytes(bytes, |i| samples.push(i)),
                Port::Gps => self.drivers.gps_bytes(bytes, |i| samples.push(i)),
                Port::Baro => {
                    self.drivers
                        .baro_bytes(bytes, now_us, &mut |b: &[u8]| tx(Port::Baro, b), |i| {
                            samples.push(i)
                        })
                }
            },
            DeviceInput::Compass(adc) => samples.push(Input::Compass(adc)),
            DeviceInput::Battery(adc) => samples.push(Input::Battery { volts: adc.volts() }),
            DeviceInput::GroundLink { fresh } => samples.push(Input::GroundLink { fresh }),
            DeviceInput::StopRequested => samples.push(Input::StopRequested),
            DeviceInput::PowerLine { high } => {
                samples.push(Input::PowerSource(heli_power::PowerSource::from_line(high)))
            }
            DeviceInput::PortFailed(port) => samples.push(Input::DeviceFailed(port.device())),
            DeviceInput::Tick => {
                self.drivers
                    .baro
                    .poll(now_us, &mut |b: &[u8]| tx(Port::Baro, b));
                samples.push(Input::Timer);
            }
        }
        if self.drivers.baro.state() == BaroLinkState::Failed && !self.baro_failed_reported {
            self.baro_failed_reported = true;
            samples.insert(0, Input::DeviceFailed(Device::Baro));
        }
        let first_new = out.len();
        for sample in samples.drain(..) {
            let before = out.len();
            self.core.handle(sample, now_us, out);
            if let Some(watch) = self.invariants.as_deref_mut() {
                let (checker, report) = watch;
                let verdict = checker.check(&self.core, now_us, out.get(before..).unwrap_or(&[]));
                report.record(now_us, verdict);
            }
        }
        self.scratch = samples;
        for action in out.iter().skip(first_new) {
            if let Action::Servo(cmd) = action {
                tx(Port::Scb, &drivers::servo_packet(&cmd.value));
            }
        }
    }

    /// Checks the core's invariants ([`crate::invariants`]) after every input from now on:
    /// what a simulated or replayed flight runs with, to find defects. The report
    /// ([`FlightComputer::invariant_report`]) counts what was broken; nothing is acted on.
    pub fn watch_invariants(&mut self) {
        let checker = Invariants::new(&self.core, self.core.config().watchdog_us);
        self.invariants = Some(Box::new((checker, InvariantReport::default())));
    }

    /// What the invariants' checker found, if it was asked for.
    pub fn invariant_report(&self) -> Option<&InvariantReport> {
        self.invariants.as_deref().map(|(_, report)| report)
    }

    /// The main control process.
    pub fn core(&self) -> &FlightCore {
        &self.core
    }

    /// The drivers' protocol halves (counters, the altimeter's handshake state).
    pub fn drivers(&self) -> &Drivers {
        &self.drivers
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::CoreEvent;
    use crate::health::HealthState;

    #[test]
    fn an_altimeter_that_never_answers_is_reported_failed_once() {
        let mut fc = FlightComputer::new(CoreConfig::default(), FlightParams::default(), 5);
        let mut resets = 0;
        fc.start(0, &mut |port, _| resets += usize::from(port == Port::Baro));
        let mut out = Vec::new();
        while let Some(at) = fc.poll_at().filter(|at| *at < 5_000_000) {
            fc.receive(
                at,
                DeviceInput::Tick,
                &mut |port, _| resets += usize::from(port == Port::Baro),
                &mut out,
            );
        }
        assert_eq!(resets, 3);
        let failed = out
            .iter()
            .filter(|a| {
                matches!(a, Action::Event(e) if e.value == CoreEvent::DeviceHealth {
                    device: Device::Baro,
                    state: HealthState::Failed,
                })
            })
            .count();
        assert_eq!(failed, 1);
        assert_eq!(fc.core().health().state(Device::Baro), HealthState::Failed);
    }

    #[test]
    fn a_port_the_runtime_cannot_open_fails_its_device() {
        let mut fc = FlightComputer::new(CoreConfig::default(), FlightParams::default(), 5);
        fc.start(0, &mut |_, _| {});
        let mut out = Vec::new();
        fc.receive(
            10,
            DeviceInput::PortFailed(Port::Gps),
            &mut |_, _| {},
            &mut out,
        );
        assert_eq!(fc.core().health().state(Device::Gps), HealthState::Failed);
    }

    #[test]
    fn start_sends_the_board_its_check_and_the_altimeter_its_reset() {
        let mut fc = FlightComputer::new(CoreConfig::default(), FlightParams::default(), 5);
        let mut sent = Vec::new();
        fc.start(0, &mut |port, b: &[u8]| sent.push((port, b.to_vec())));
        assert_eq!(
            sent.first(),
            Some(&(
                Port::Scb,
                vec![heli_proto::scb::CHECK_BYTE; heli_proto::scb::CHECK_LEN]
            ))
        );
        assert!(sent.iter().any(|(p, _)| *p == Port::Baro));
    }

    #[test]
    fn servo_commands_leave_on_the_board_port() {
        let mut fc = FlightComputer::new(CoreConfig::default(), FlightParams::default(), 5);
        let imu = heli_proto::imu::ImuRepr {
            rate_rps: [0.0; 3],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        };
        let mut frame = [0u8; heli_proto::imu::FRAME_LEN];
        let n = imu.emit(&mut frame).unwrap_or(0);
        let mut sent = Vec::new();
        let mut out = Vec::new();
        for k in 0..2u64 {
            fc.receive(
                k * 10_000,
                DeviceInput::Bytes {
                    port: Port::Imu,
                    bytes: &frame[..n],
                },
                &mut |port, b: &[u8]| sent.push((port, b.to_vec())),
                &mut out,
            );
        }
        assert_eq!(sent.len(), 1);
        assert_eq!(sent[0].0, Port::Scb);
        assert_eq!(sent[0].1.len(), heli_proto::scb::SERVO_LEN);
    }

    fn imu_frame() -> Vec<u8> {
        let imu = heli_proto::imu::ImuRepr {
            rate_rps: [0.0; 3],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        };
        let mut frame = [0u8; heli_proto::imu::FRAME_LEN];
        let n = imu.emit(&mut frame).unwrap_or(0);
        frame[..n].to_vec()
    }

    #[test]
    fn the_invariants_are_checked_only_when_asked_for_after_every_input() {
        let frame = imu_frame();
        let mut fc = FlightComputer::new(CoreConfig::default(), FlightParams::default(), 5);
        assert!(fc.invariant_report().is_none());
        fc.watch_invariants();
        fc.start(0, &mut |_, _| {});
        let mut out = Vec::new();
        for k in 1..=20u64 {
            fc.receive(
                k * 10_000,
                DeviceInput::Bytes {
                    port: Port::Imu,
                    bytes: &frame,
                },
                &mut |_, _| {},
                &mut out,
            );
        }
        let report = fc.invariant_report().copied().unwrap();
        assert_eq!(report.checked, 20);
        assert_eq!(report.violations, 0);
        assert_eq!(report.first, None);
    }

    #[test]
    fn a_computer_restarted_in_the_air_aligns_instead_of_calibrating() {
        let warm = crate::core::WarmStart {
            gyro_bias_rps: [0.001, 0.0, 0.0],
            origin: None,
            home_ned_m: Some([0.0, 0.0, 0.0]),
            airborne: true,
            trim: None,
            references: heli_nav::GroundReferences::default(),
            roll: None,
        };
        let fc = FlightComputer::restarted(CoreConfig::default(), FlightParams::default(), 5, warm);
        assert_eq!(fc.core().phase(), crate::phase::Phase::BlindDescent);
        let cold = FlightComputer::restarted(
            CoreConfig::default(),
            FlightParams::default(),
            5,
            crate::core::WarmStart {
                airborne: false,
                ..warm
            },
        );
        assert_eq!(cold.core().phase(), crate::phase::Phase::Calibrating);
    }

    #[test]
    fn ports_are_named_and_found_by_name() {
        for port in [Port::Imu, Port::Scb, Port::Gps, Port::Baro] {
            assert_eq!(Port::from_name(port.name()), Some(port));
        }
        assert_eq!(Port::Imu.name(), "imu");
        assert_eq!(Port::from_name("modem"), None);
    }
}
