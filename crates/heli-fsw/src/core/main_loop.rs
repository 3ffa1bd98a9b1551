//! The main loop's timing (thesis §2.3.2): every IMU sample is one iteration, and when no
//! IMU packet has come for the watchdog's period the loop runs on a copy of the last one;
//! every second iteration (50 Hz) is a control step. After
//! [`IMU_FIRES_TO_INVALID`] fires in a row the estimate is declared invalid, until the core
//! starts it again (an alignment in the air when the IMU comes back).
//!
//! A component: it owns the watchdog, the last sample and the step clock; the core hands it
//! the IMU's samples and the timer, and it says when the loop runs and on what.

use heli_nav::seconds_between;
use heli_proto::imu::ImuRepr;

use super::watchdog::Watchdog;
use crate::health::IMU_FIRES_TO_INVALID;

/// The watchdog fired: what the loop does about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fire {
    /// This fire declared the estimate invalid (the IMU has been silent too long).
    pub estimate_invalidated: bool,
    /// The sample the loop runs on again, if one has come at all.
    pub repeat: Option<ImuRepr>,
}

/// The main loop's timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MainLoop {
    watchdog: Watchdog,
    last_imu: Option<ImuRepr>,
    odd_sample: bool,
    last_control_us: Option<u64>,
    /// Watchdog fires since the last real IMU packet.
    pub(super) imu_fires_in_row: u32,
    /// False once the IMU stayed silent too long: the estimate is not used until it is
    /// started again.
    pub(super) estimate_valid: bool,
}

impl MainLoop {
    /// A loop whose watchdog fires `watchdog_us` after the last sample.
    pub fn new(watchdog_us: u64) -> Self {
        Self {
            watchdog: Watchdog::new(watchdog_us),
            last_imu: None,
            odd_sample: false,
            last_control_us: None,
            imu_fires_in_row: 0,
            estimate_valid: true,
        }
    }

    /// Arms the watchdog at start-up, so that an IMU that never sends is noticed too.
    pub fn start(&mut self, now_us: u64) {
        self.watchdog.kick(now_us);
    }

    /// A real IMU packet came: the watchdog starts again and the fires in a row are over.
    pub fn imu(&mut self, now_us: u64) {
        self.imu_fires_in_row = 0;
        self.watchdog.kick(now_us);
    }

    /// The timer at `now_us`: the watchdog's fire, if it is due. An IMU that has not spoken
    /// yet (a port still opening, a slow boot) has no estimate to invalidate: only fires
    /// after a first sample count towards [`IMU_FIRES_TO_INVALID`].
    pub fn timer(&mut self, now_us: u64) -> Option<Fire> {
        self.timer_within(now_us, IMU_FIRES_TO_INVALID)
    }

    /// [`MainLoop::timer`], the estimate declared invalid after `fires_to_invalid` fires in a
    /// row (fewer in a roll: an estimate coasting on a repeated sample there turns with a
    /// rate the helicopter no longer has).
    pub fn timer_within(&mut self, now_us: u64, fires_to_invalid: u32) -> Option<Fire> {
        if !self.watchdog.expired(now_us) {
            return None;
        }
        self.watchdog.kick(now_us);
        if self.last_imu.is_some() {
            self.imu_fires_in_row = self.imu_fires_in_row.saturating_add(1);
        }
        let estimate_invalidated = self.imu_fires_in_row >= fires_to_invalid && self.estimate_valid;
        if estimate_invalidated {
            self.estimate_valid = false;
        }
        Some(Fire {
            estimate_invalidated,
            repeat: self.last_imu,
        })
    }

    /// One iteration on `sample`: the previous sample and this one when the iteration is a
    /// control step (every second one), `None` otherwise.
    pub fn iterate(&mut self, sample: ImuRepr) -> Option<(ImuRepr, ImuRepr)> {
        let previous = self.last_imu.replace(sample);
        self.odd_sample = !self.odd_sample;
        if self.odd_sample {
            return None;
        }
        Some((previous.unwrap_or(sample), sample))
    }

    /// The time since the last control step (s; 0.02 for the first), and now the last.
    pub fn step_dt(&mut self, now_us: u64) -> f64 {
        let dt_s = self
            .last_control_us
            .map_or(0.02, |t| seconds_between(t, now_us));
        self.last_control_us = Some(now_us);
        dt_s
    }

    /// The estimate was started again (aligned in the air after a stall): it is valid.
    pub fn revalidate(&mut self) {
        self.estimate_valid = true;
    }

    /// There is no estimate to fly on until one is started again (a process restarted in a
    /// roll: [`MainLoop::revalidate`] once it has aligned).
    pub fn invalidate(&mut self) {
        self.estimate_valid = false;
    }

    /// The time of the last control step, if there was one.
    pub fn last_step_us(&self) -> Option<u64> {
        self.last_control_us
    }

    /// False once the estimate was declared invalid (until it is started again).
    pub fn estimate_valid(&self) -> bool {
        self.estimate_valid
    }

    /// The watchdog's deadline (µs), once armed.
    pub fn deadline_us(&self) -> Option<u64> {
        self.watchdog.deadline_us()
    }

    /// Times the watchdog fired.
    pub fn fires(&self) -> u32 {
        self.watchdog.fires()
    }

    /// Whether any IMU sample has come.
    pub fn has_sample(&self) -> bool {
        self.last_imu.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: u64 = 12_000;

    fn sample(x: f64) -> ImuRepr {
        ImuRepr {
            rate_rps: [x, 0.0, 0.0],
            accel_mps2: [0.0, 0.0, -9.81],
            ..ImuRepr::default()
        }
    }

    #[test]
    fn every_second_iteration_is_a_control_step_on_the_last_two_samples() {
        let mut l = MainLoop::new(P);
        assert!(!l.has_sample());
        assert_eq!(l.iterate(sample(1.0)), None);
        assert_eq!(l.iterate(sample(2.0)), Some((sample(1.0), sample(2.0))));
        assert_eq!(l.iterate(sample(3.0)), None);
        assert_eq!(l.iterate(sample(4.0)), Some((sample(3.0), sample(4.0))));
        assert!(l.has_sample());
        assert_eq!(
            l.step_dt(1_000_000),
            0.02,
            "the first step takes the nominal period"
        );
        assert_eq!(l.step_dt(1_030_000), 0.03);
    }

    #[test]
    fn the_watchdog_fires_a_period_after_the_last_sample_and_repeats_it() {
        let mut l = MainLoop::new(P);
        assert_eq!(l.deadline_us(), None, "not armed before start");
        assert_eq!(l.timer(1_000_000), None);
        l.start(0);
        assert_eq!(l.deadline_us(), Some(P));
        assert_eq!(l.timer(P - 1), None);
        let fire = l.timer(P).unwrap();
        assert_eq!(
            fire,
            Fire {
                estimate_invalidated: false,
                repeat: None
            }
        );
        assert_eq!(l.imu_fires_in_row, 0, "no sample yet: no fire counts");
        l.iterate(sample(5.0));
        l.imu(2 * P);
        let fire = l.timer(3 * P).unwrap();
        assert_eq!(fire.repeat, Some(sample(5.0)));
        assert_eq!((l.imu_fires_in_row, l.fires()), (1, 2));
        l.imu(3 * P + 1);
        assert_eq!(l.imu_fires_in_row, 0);
    }

    #[test]
    fn the_estimate_is_declared_invalid_once_after_so_many_fires_in_a_row() {
        let mut l = MainLoop::new(P);
        l.start(0);
        l.iterate(sample(1.0));
        let mut invalidated = Vec::new();
        for k in 1..=u64::from(IMU_FIRES_TO_INVALID) + 3 {
            let fire = l.timer(k * P).unwrap();
            invalidated.push(fire.estimate_invalidated);
        }
        let at = usize::try_from(IMU_FIRES_TO_INVALID - 1).unwrap();
        assert!(invalidated[at], "the {IMU_FIRES_TO_INVALID}th fire");
        assert_eq!(invalidated.iter().filter(|i| **i).count(), 1, "said once");
        assert!(!l.estimate_valid());
        l.imu(1_000_000);
        assert!(
            !l.estimate_valid(),
            "an IMU back does not give the estimate back"
        );
    }
}
