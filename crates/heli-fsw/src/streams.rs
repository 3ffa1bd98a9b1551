//! The seven streams: the thesis's shared-memory buffers for IMU, state estimate, servo
//! commands, pilot uplink, GPS, altimeter and compass.
//!
//! One writer per stream (the main control process or a driver). Any number of observers —
//! telemetry, the logger, the ground link — read the freshest value or drain the history by
//! sequence number; they never change what the writer sees, and a slow observer only loses
//! the oldest history entries (counted), it never delays the writer. This is the
//! single-threaded form used by the lockstep simulator; the vehicle runtime wraps the same
//! records in lock-free buffers.

use std::collections::VecDeque;

use heli_control::Target;
use heli_nav::NavState;
use heli_proto::compass::{CompassAdc, MagField};
use heli_proto::gps::GpsNav;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink};

use crate::phase::Phase;

/// A value with the time it was received or produced (µs on the vehicle's monotonic clock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamped<T> {
    /// Time stamp (µs).
    pub t_us: u64,
    /// The value.
    pub value: T,
}

impl<T> Stamped<T> {
    /// Stamps `value` with `t_us`.
    pub const fn new(t_us: u64, value: T) -> Self {
        Self { t_us, value }
    }
}

/// An IMU packet as the main loop used it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRecord {
    /// The packet.
    pub imu: ImuRepr,
    /// True when the watchdog repeated the previous packet because this one never came.
    pub repeated: bool,
}

/// The state estimate with the flight phase and target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateRecord {
    /// Navigation estimate.
    pub nav: NavState,
    /// Phase of flight.
    pub phase: Phase,
    /// Target of the autonomous controller, if one is active.
    pub target: Option<Target>,
}

/// A servo command as sent to the servo controller board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoRecord {
    /// Normalised commands.
    pub controls: Controls,
    /// Rotor speed reported by the board when the command was made (rpm).
    pub rotor_rpm: u16,
}

/// An altimeter reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroRecord {
    /// Static pressure (mbar).
    pub pressure_mbar: f64,
    /// Pressure altitude above the calibration reference (m), once there is one.
    pub alt_m: Option<f64>,
}

/// A compass reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompassRecord {
    /// The three ADC channels.
    pub adc: CompassAdc,
    /// Calibrated field (gauss).
    pub field: MagField,
    /// Tilt-compensated magnetic heading (rad).
    pub heading_rad: Option<f64>,
}

/// One entry of one of the seven streams.
// By value: no allocation in the control step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Record {
    /// IMU stream.
    Imu(Stamped<ImuRecord>),
    /// State-estimate stream.
    State(Stamped<StateRecord>),
    /// Servo-command stream.
    Servo(Stamped<ServoRecord>),
    /// Pilot-uplink stream.
    Uplink(Stamped<PilotUplink>),
    /// GPS stream.
    Gps(Stamped<GpsNav>),
    /// Altimeter stream.
    Baro(Stamped<BaroRecord>),
    /// Compass stream.
    Compass(Stamped<CompassRecord>),
}

/// A single-writer buffer: freshest value plus a bounded history numbered by sequence.
#[derive(Clone, Debug)]
pub struct Stream<T> {
    history: VecDeque<T>,
    capacity: usize,
    next_seq: u64,
    overwritten: u64,
}

impl<T: Clone> Stream<T> {
    /// A stream keeping the last `capacity` entries.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            history: VecDeque::with_capacity(capacity),
            capacity: capacity.max(1),
            next_seq: 0,
            overwritten: 0,
        }
    }

    /// Appends a value (the one writer).
    pub fn publish(&mut self, value: T) {
        if self.history.len() >= self.capacity {
            self.history.pop_front();
            self.overwritten = self.overwritten.saturating_add(1);
        }
        self.history.push_back(value);
        self.next_seq = self.next_seq.saturating_add(1);
    }

    /// The freshest value.
    pub fn latest(&self) -> Option<&T> {
        self.history.back()
    }

    /// Number of values ever published.
    pub fn published(&self) -> u64 {
        self.next_seq
    }

    /// Values an observer has not seen, given the sequence number it will read next; returns
    /// them with the observer's new cursor and how many it missed because they were overwritten.
    pub fn read_since(&self, cursor: u64) -> (Vec<T>, u64, u64) {
        let oldest = self.next_seq.saturating_sub(self.history.len() as u64);
        let start = cursor.max(oldest);
        let missed = start.saturating_sub(cursor);
        let skip = usize::try_from(start.saturating_sub(oldest)).unwrap_or(usize::MAX);
        (
            self.history.iter().skip(skip).cloned().collect(),
            self.next_seq,
            missed,
        )
    }
}

/// The seven streams of the flight process.
#[derive(Clone, Debug)]
pub struct Streams {
    /// IMU packets (100 Hz).
    pub imu: Stream<Stamped<ImuRecord>>,
    /// State estimates (50 Hz).
    pub state: Stream<Stamped<StateRecord>>,
    /// Servo commands (50 Hz).
    pub servo: Stream<Stamped<ServoRecord>>,
    /// Pilot uplink (50 Hz).
    pub uplink: Stream<Stamped<PilotUplink>>,
    /// GPS (1 Hz).
    pub gps: Stream<Stamped<GpsNav>>,
    /// Altimeter (5 Hz).
    pub baro: Stream<Stamped<BaroRecord>>,
    /// Compass (20 Hz).
    pub compass: Stream<Stamped<CompassRecord>>,
}

impl Streams {
    /// Streams that keep `seconds` of history at each device's nominal rate.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn with_history_s(seconds: f64) -> Self {
        let n = |hz: f64| (seconds * hz).ceil().max(1.0) as usize;
        Self {
            imu: Stream::with_capacity(n(100.0)),
            state: Stream::with_capacity(n(50.0)),
            servo: Stream::with_capacity(n(50.0)),
            uplink: Stream::with_capacity(n(50.0)),
            gps: Stream::with_capacity(n(1.0)),
            baro: Stream::with_capacity(n(10.0)),
            compass: Stream::with_capacity(n(20.0)),
        }
    }

    /// Appends a record to its stream.
    pub fn publish(&mut self, record: Record) {
        match record {
            Record::Imu(r) => self.imu.publish(r),
            Record::State(r) => self.state.publish(r),
            Record::Servo(r) => self.servo.publish(r),
            Record::Uplink(r) => self.uplink.publish(r),
            Record::Gps(r) => self.gps.publish(r),
            Record::Baro(r) => self.baro.publish(r),
            Record::Compass(r) => self.compass.publish(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_proto::imu::ImuRepr;

    fn imu(t_us: u64) -> Record {
        Record::Imu(Stamped::new(
            t_us,
            ImuRecord {
                imu: ImuRepr {
                    rate_rps: [0.0; 3],
                    accel_mps2: [0.0, 0.0, -9.81],
                    temp_c: 20.0,
                },
                repeated: false,
            },
        ))
    }

    #[test]
    fn history_is_kept_for_the_seconds_asked_at_each_rate() {
        let mut streams = Streams::with_history_s(2.0);
        for k in 0..500 {
            streams.publish(imu(k * 10_000));
        }
        assert_eq!(streams.imu.published(), 500);
        // 2 s at 100 Hz.
        let (kept, cursor, missed) = streams.imu.read_since(0);
        assert_eq!(kept.len(), 200);
        assert_eq!((cursor, missed), (500, 300));
        assert_eq!(kept.first().map(|r| r.t_us), Some(300 * 10_000));
        assert_eq!(streams.gps.published(), 0);
        let mut tiny = Streams::with_history_s(0.0);
        tiny.publish(imu(1));
        tiny.publish(imu(2));
        assert_eq!(tiny.imu.read_since(0).0.len(), 1, "never less than one");
    }

    #[test]
    fn observer_reads_in_order_and_counts_what_it_missed() {
        let mut s = Stream::with_capacity(3);
        for v in 0..5 {
            s.publish(v);
        }
        assert_eq!(s.latest(), Some(&4));
        let (values, cursor, missed) = s.read_since(0);
        assert_eq!(values, vec![2, 3, 4]);
        assert_eq!((cursor, missed), (5, 2));
        s.publish(5);
        let (values, cursor, missed) = s.read_since(cursor);
        assert_eq!(values, vec![5]);
        assert_eq!((cursor, missed), (6, 0));
    }
}
