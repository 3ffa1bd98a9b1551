//! Device health: every driver's watchdog (thesis ch. 4, "all drivers include a watchdog
//! timer").
//!
//! Each device has an expected period. A [`DeviceMonitor`] is told when a sample arrives and
//! asked, at any time, what the device's state is: [`HealthState::Ok`] while samples come on
//! time, [`HealthState::Late`] once one is overdue, [`HealthState::Silent`] once none has come
//! for the device's silence timeout, [`HealthState::Failed`] when its driver gave up (the
//! altimeter handshake never answered, the port could not be opened). Every change of state
//! is returned once, so the core can raise it as an event with a severity; counts are kept.
//!
//! The timeouts (µs), documented in `docs/architecture.md`:
//!
//! | device | period | late after | silent after | what silence does |
//! |---|---|---|---|---|
//! | IMU | 10 ms | 25 ms (two packets missed; the loop watchdog repeats at 12 ms) | 100 ms | after [`IMU_FIRES_TO_INVALID`] watchdog fires in a row the estimate is declared invalid |
//! | servo board uplink | 20 ms | 60 ms | 500 ms | transmitter loss: hover where it is (or idle on the ground) |
//! | GPS | 1 s | 1.5 s | 3 s | estimate coasts on the IMU (GPS outage) |
//! | altimeter | 200 ms | 600 ms | 2 s | altitude from GPS and the IMU only |
//! | compass | 50 ms | 150 ms | 1 s | heading from GPS velocity and the IMU only |

/// Consecutive IMU watchdog fires after which the estimate is declared invalid: 25 fires is
/// 0.3 s without an IMU packet, long enough that dead reckoning on a repeated sample is
/// meaningless at the helicopter's rates.
pub const IMU_FIRES_TO_INVALID: u32 = 25;

/// Watchdog fires in a row after which the estimate is declared invalid during a roll (60 ms
/// at the 12 ms watchdog): a roll flown on a repeated sample turns the estimate at a rate the
/// helicopter no longer has, so it is finished or stopped blind at once.
pub const IMU_FIRES_TO_INVALID_IN_ROLL: u32 = 5;

use heli_types::Device;

/// A device's expected period, late and silent thresholds (µs).
pub const fn timing_us(device: Device) -> (u64, u64, u64) {
    match device {
        Device::Imu => (10_000, 25_000, 100_000),
        Device::Uplink => (20_000, 60_000, 500_000),
        Device::Gps => (1_000_000, 1_500_000, 3_000_000),
        Device::Baro => (200_000, 600_000, 2_000_000),
        Device::Compass => (50_000, 150_000, 1_000_000),
    }
}

/// What a device's watchdog says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum HealthState {
    /// Nothing heard yet since start-up (no deadline until the first sample, except for
    /// devices the core arms at start).
    Waiting,
    /// Samples arrive on time.
    Ok,
    /// A sample is overdue.
    Late,
    /// No sample for the device's silence timeout.
    Silent,
    /// The driver gave up on the device.
    Failed,
}

impl HealthState {
    /// Short name for logs and displays.
    pub const fn name(self) -> &'static str {
        match self {
            HealthState::Waiting => "waiting",
            HealthState::Ok => "ok",
            HealthState::Late => "late",
            HealthState::Silent => "silent",
            HealthState::Failed => "failed",
        }
    }
}

/// Counts of one device's watchdog.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthCounts {
    /// Samples received.
    pub samples: u32,
    /// Times the device became late.
    pub late: u32,
    /// Times the device fell silent.
    pub silent: u32,
    /// Times its driver reported it failed.
    pub failed: u32,
}

impl HealthCounts {
    /// Times the device left `ok` for late, silent or failed (late then silent is two): a
    /// lapse shorter than the interval between two reports shows as a rise of this.
    pub fn lapses(&self) -> u32 {
        self.late
            .saturating_add(self.silent)
            .saturating_add(self.failed)
    }
}

/// One device's watchdog.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceMonitor {
    device: Device,
    last_us: Option<u64>,
    state: HealthState,
    counts: HealthCounts,
}

impl DeviceMonitor {
    /// A monitor for `device`, waiting for its first sample.
    pub const fn new(device: Device) -> Self {
        Self {
            device,
            last_us: None,
            state: HealthState::Waiting,
            counts: HealthCounts {
                samples: 0,
                late: 0,
                silent: 0,
                failed: 0,
            },
        }
    }

    /// Starts the clock at `now_us` without a sample: a device that never speaks will be
    /// reported late, then silent.
    pub fn arm(&mut self, now_us: u64) {
        if self.last_us.is_none() {
            self.last_us = Some(now_us);
        }
    }

    /// A sample arrived at `now_us`. Returns the new state if it changed.
    pub fn sample(&mut self, now_us: u64) -> Option<HealthState> {
        self.counts.samples = self.counts.samples.saturating_add(1);
        self.last_us = Some(now_us);
        self.set(HealthState::Ok)
    }

    /// The driver gave up. Returns the new state if it changed.
    pub fn fail(&mut self) -> Option<HealthState> {
        self.set(HealthState::Failed)
    }

    /// Re-evaluates the deadlines at `now_us`. Returns the new state if it changed.
    pub fn check(&mut self, now_us: u64) -> Option<HealthState> {
        let last = self.last_us?;
        if self.state == HealthState::Failed {
            return None;
        }
        let (_, late, silent) = timing_us(self.device);
        let age = now_us.saturating_sub(last);
        let state = if age >= silent {
            HealthState::Silent
        } else if age >= late && self.state != HealthState::Waiting {
            HealthState::Late
        } else {
            return None;
        };
        // Once silent, it stays silent until a sample arrives (never back to late).
        if self.state == HealthState::Silent {
            return None;
        }
        self.set(state)
    }

    /// When [`DeviceMonitor::check`] next has something to decide (µs), if ever.
    pub fn deadline_us(&self) -> Option<u64> {
        let last = self.last_us?;
        let (_, late, silent) = timing_us(self.device);
        match self.state {
            HealthState::Ok => Some(last.saturating_add(late)),
            HealthState::Waiting => Some(last.saturating_add(silent)),
            HealthState::Late => Some(last.saturating_add(silent)),
            HealthState::Silent | HealthState::Failed => None,
        }
    }

    /// Current state.
    pub fn state(&self) -> HealthState {
        self.state
    }

    /// Counts so far.
    pub fn counts(&self) -> HealthCounts {
        self.counts
    }

    fn set(&mut self, state: HealthState) -> Option<HealthState> {
        if self.state == state {
            return None;
        }
        match state {
            HealthState::Late => self.counts.late = self.counts.late.saturating_add(1),
            HealthState::Silent => self.counts.silent = self.counts.silent.saturating_add(1),
            HealthState::Failed => self.counts.failed = self.counts.failed.saturating_add(1),
            HealthState::Ok | HealthState::Waiting => {}
        }
        self.state = state;
        Some(state)
    }
}

/// The watchdogs of all devices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Health {
    imu: DeviceMonitor,
    uplink: DeviceMonitor,
    gps: DeviceMonitor,
    baro: DeviceMonitor,
    compass: DeviceMonitor,
}

impl Default for Health {
    fn default() -> Self {
        Self {
            imu: DeviceMonitor::new(Device::Imu),
            uplink: DeviceMonitor::new(Device::Uplink),
            gps: DeviceMonitor::new(Device::Gps),
            baro: DeviceMonitor::new(Device::Baro),
            compass: DeviceMonitor::new(Device::Compass),
        }
    }
}

impl Health {
    /// The monitor of `device`.
    pub fn monitor(&self, device: Device) -> &DeviceMonitor {
        match device {
            Device::Imu => &self.imu,
            Device::Uplink => &self.uplink,
            Device::Gps => &self.gps,
            Device::Baro => &self.baro,
            Device::Compass => &self.compass,
        }
    }

    /// The monitor of `device`, to change.
    pub fn monitor_mut(&mut self, device: Device) -> &mut DeviceMonitor {
        match device {
            Device::Imu => &mut self.imu,
            Device::Uplink => &mut self.uplink,
            Device::Gps => &mut self.gps,
            Device::Baro => &mut self.baro,
            Device::Compass => &mut self.compass,
        }
    }

    /// State of `device`.
    pub fn state(&self, device: Device) -> HealthState {
        self.monitor(device).state()
    }

    /// The earliest deadline of any monitor (µs).
    pub fn deadline_us(&self) -> Option<u64> {
        Device::ALL
            .iter()
            .filter_map(|d| self.monitor(*d).deadline_us())
            .min()
    }

    /// Re-evaluates every monitor at `now_us`; returns each device's change of state, if
    /// it changed.
    pub fn check(&mut self, now_us: u64) -> [Option<(Device, HealthState)>; 5] {
        Device::ALL.map(|device| {
            self.monitor_mut(device)
                .check(now_us)
                .map(|state| (device, state))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_states_have_the_names_the_ground_shows() {
        let names: Vec<_> = Device::ALL.iter().map(|d| d.name()).collect();
        assert_eq!(names, ["imu", "uplink", "gps", "baro", "compass"]);
        let states = [
            HealthState::Waiting,
            HealthState::Ok,
            HealthState::Late,
            HealthState::Silent,
            HealthState::Failed,
        ];
        let names: Vec<_> = states.iter().map(|s| s.name()).collect();
        assert_eq!(names, ["waiting", "ok", "late", "silent", "failed"]);
    }

    #[test]
    fn late_then_silent_then_back_with_counts() {
        let mut m = DeviceMonitor::new(Device::Baro);
        assert_eq!(m.check(10_000_000), None, "never armed, never judged");
        assert_eq!(m.sample(0), Some(HealthState::Ok));
        assert_eq!(m.deadline_us(), Some(600_000));
        assert_eq!(m.check(599_999), None);
        assert_eq!(m.check(600_000), Some(HealthState::Late));
        assert_eq!(m.deadline_us(), Some(2_000_000));
        assert_eq!(m.check(2_000_000), Some(HealthState::Silent));
        assert_eq!(m.check(9_000_000), None, "silent stays silent");
        assert_eq!(m.deadline_us(), None);
        assert_eq!(m.sample(9_000_000), Some(HealthState::Ok));
        assert_eq!(
            m.counts(),
            HealthCounts {
                samples: 2,
                late: 1,
                silent: 1,
                failed: 0
            }
        );
        assert_eq!(m.counts().lapses(), 2);
        let _ = m.fail();
        assert_eq!(m.counts().lapses(), 3);
    }

    #[test]
    fn an_armed_device_that_never_speaks_goes_straight_to_silent() {
        let mut m = DeviceMonitor::new(Device::Gps);
        m.arm(1_000_000);
        assert_eq!(
            m.check(2_600_000),
            None,
            "no late verdict before a first sample"
        );
        assert_eq!(m.check(4_000_000), Some(HealthState::Silent));
    }

    #[test]
    fn failed_is_final_until_a_sample_arrives() {
        let mut m = DeviceMonitor::new(Device::Baro);
        m.arm(0);
        assert_eq!(m.fail(), Some(HealthState::Failed));
        assert_eq!(m.check(10_000_000), None);
        assert_eq!(m.fail(), None, "reported once");
        assert_eq!(m.counts().failed, 1);
    }
}
