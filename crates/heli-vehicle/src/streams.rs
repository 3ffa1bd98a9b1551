//! The seven streams of the running flight process, plus the battery: single-writer cells
//! whose freshest value any observer (telemetry, the battery server's clients, the link) reads
//! without ever blocking or delaying the writer, in the manner of PX4's uORB.
//!
//! The lock-free part is `arc-swap`: the writer swaps in a new `Arc` with one atomic
//! operation, readers load the current one with another; neither waits for the other. The
//! history a logger needs travels separately, through the logger's bounded channel.
//!
//! Under `--cfg loom` (the model checker, `tests/loom_streams.rs`) the cell is a loom mutex
//! with the same meaning (a linearizable load and store of an `Arc`; loom cannot look inside
//! arc-swap) and the counter is loom's atomic, so that every interleaving of the writer's
//! store-then-count with a reader's count-then-load is explored.

use std::sync::Arc;

#[cfg(loom)]
use loom::sync::atomic::{AtomicU64, Ordering};
#[cfg(not(loom))]
use std::sync::atomic::{AtomicU64, Ordering};

#[cfg(not(loom))]
type Cell<T> = arc_swap::ArcSwapOption<T>;

/// The model checker's stand-in for arc-swap's cell.
#[cfg(loom)]
struct Cell<T>(loom::sync::Mutex<Option<Arc<T>>>);

#[cfg(loom)]
impl<T> Cell<T> {
    fn empty() -> Self {
        Self(loom::sync::Mutex::new(None))
    }

    fn store(&self, value: Option<Arc<T>>) {
        *self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = value;
    }

    fn load_full(&self) -> Option<Arc<T>> {
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }
}
use heli_fsw::Stamped;
use heli_fsw::health::Health;
use heli_fsw::streams::{BaroRecord, CompassRecord, ImuRecord, Record, ServoRecord, StateRecord};
use heli_proto::gps::GpsNav;
use heli_proto::scb::PilotUplink;

/// One stream's freshest value.
pub struct Latest<T> {
    cell: Cell<T>,
    published: AtomicU64,
}

impl<T> Default for Latest<T> {
    fn default() -> Self {
        Self {
            cell: Cell::empty(),
            published: AtomicU64::new(0),
        }
    }
}

impl<T> Latest<T> {
    /// Replaces the freshest value (the one writer). The value is stored before it is
    /// counted, so a reader that sees the count `n` sees the `n`-th value or a later one.
    pub fn publish(&self, value: T) {
        self.cell.store(Some(Arc::new(value)));
        self.published.fetch_add(1, Ordering::Release);
    }

    /// The freshest value, if any was published.
    pub fn latest(&self) -> Option<Arc<T>> {
        self.cell.load_full()
    }

    /// How many values were published.
    pub fn published(&self) -> u64 {
        self.published.load(Ordering::Acquire)
    }
}

/// The flight process's live streams.
#[derive(Default)]
pub struct LiveStreams {
    /// IMU packets.
    pub imu: Latest<Stamped<ImuRecord>>,
    /// State estimates.
    pub state: Latest<Stamped<StateRecord>>,
    /// Servo commands.
    pub servo: Latest<Stamped<ServoRecord>>,
    /// Pilot uplink.
    pub uplink: Latest<Stamped<PilotUplink>>,
    /// GPS solutions.
    pub gps: Latest<Stamped<GpsNav>>,
    /// Altimeter readings.
    pub baro: Latest<Stamped<BaroRecord>>,
    /// Compass readings.
    pub compass: Latest<Stamped<CompassRecord>>,
    /// Battery voltage (V), written by the battery server.
    pub battery_v: Latest<Stamped<f64>>,
    /// Device watchdogs, written by the loop after every input.
    pub health: Latest<Health>,
    /// The flight phase, written by the loop after every input: the phase now, whether or not
    /// the estimate (and with it the state stream) goes on.
    pub phase: Latest<heli_fsw::phase::Phase>,
    /// The batteries' gauges and the hot-swap, written by the loop after every input that
    /// changed them.
    pub power: Latest<heli_link::telemetry::PowerRow>,
    /// The navigation's origin (the frame of the positions north and east), once it has one;
    /// written with the power row.
    pub origin: Latest<Option<heli_nav::GeoOrigin>>,
}

impl LiveStreams {
    /// Publishes a record of the main control process to its stream.
    pub fn publish(&self, record: &Record) {
        match *record {
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

#[cfg(all(test, not(loom)))]
mod tests {
    use super::*;

    #[test]
    fn readers_see_the_freshest_value_while_the_writer_goes_on() {
        let streams = Arc::new(LiveStreams::default());
        assert!(streams.battery_v.latest().is_none());
        let reader = {
            let s = Arc::clone(&streams);
            std::thread::spawn(move || {
                let mut last = 0u64;
                let mut seen = 0;
                while last < 9_999 {
                    if let Some(v) = s.battery_v.latest() {
                        // Values only move forward: a reader never sees an older one again.
                        assert!(v.t_us >= last);
                        last = v.t_us;
                        seen += 1;
                    }
                }
                seen
            })
        };
        for k in 0..10_000u64 {
            streams.battery_v.publish(Stamped::new(k, 11.1));
        }
        assert!(reader.join().unwrap() > 0);
        assert_eq!(streams.battery_v.published(), 10_000);
    }
}
