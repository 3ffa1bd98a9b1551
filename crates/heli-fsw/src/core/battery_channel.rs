//! The flight battery's ADC channel, watched before its gauge believes it: a channel can
//! freeze (the same count again and again: a stuck multiplexer, a dead divider), garble (a
//! reading anywhere in the ADC's range), or fall behind (read less often than once a
//! second). None of these is the pack: a garbled reading fed to the gauge says the pack is
//! draining abnormally, a frozen one hides a pack that is.
//!
//! - **Frozen**: a channel on a draining pack never gives the same count
//!   [`STUCK_READINGS`] times in a row. From then on its readings are refused until it moves,
//!   and the operator is told: the charge is unknown.
//! - **Garbled**: a reading is used only if it is within [`JUMP_V`] of the reading before it
//!   and of the last one used — or, a real step (a load switched on, a cell gone), once
//!   [`AGREE_READINGS`] readings in a row after it have each been within [`JUMP_V`] of
//!   their predecessor. A random reading
//!   passes both one time in a few hundred; the good reading after it is refused too. The
//!   first refusal of an episode is raised with the count so far.
//! - **Behind**: no reading for [`LATE_S`] is raised once; on time again for
//!   [`BACK_READINGS`] readings, the channel is said to be back.
//!
//! A component: the core hands it each reading (it returns the volts the gauge may use) and
//! the time at each control step; it raises what it sees.

use super::event::{Battery, CoreEvent, ReadingFault};

/// The same reading this many times in a row is a frozen channel (a minute at 1 Hz): a
/// flight pack feeding the avionics drains about 2 % a minute, which moves its reading by
/// some six counts even on a channel with no noise at all.
pub const STUCK_READINGS: u32 = 60;

/// A reading this far from its predecessor or from the last one used is suspect (V): a
/// second's change of the flight pack's terminal voltage is its noise (10 mV) and its
/// avionics load's steps (a few tenths of an ampere on 0.25 Ω).
pub const JUMP_V: f64 = 0.3;

/// Readings in a row, each within [`JUMP_V`] of its predecessor, after which a reading is
/// a real step and used, however far from the last one used.
pub const AGREE_READINGS: u32 = 3;

/// No reading for this long is a channel behind (s); it is read once a second.
pub const LATE_S: f64 = 3.0;

/// Readings in a row, each on time and used, that end an episode (late, refused or frozen).
pub const BACK_READINGS: u32 = 5;

/// What the channel watch knows.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BatteryChannel {
    /// The last reading used (V).
    last_used_v: Option<f64>,
    /// The last reading (V) and how many times in a row it came.
    last_v: Option<f64>,
    same: u32,
    /// Readings in a row, each within [`JUMP_V`] of its predecessor.
    consistent_run: u32,
    /// Readings refused as garbled, over the flight.
    refused: u32,
    /// When the last reading came (µs).
    last_read_us: Option<u64>,
    /// An episode raised and not yet over.
    raised: bool,
    /// Readings in a row on time and used since the episode.
    good_run: u32,
    /// The channel is behind (raised).
    late: bool,
}

impl BatteryChannel {
    /// Readings refused as garbled, over the flight.
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// A reading came at `now_us` that is not judged (the pack it measures is off the bus):
    /// the channel is on time.
    pub fn heard(&mut self, now_us: u64) {
        self.last_read_us = Some(now_us);
    }

    /// A reading of `volts` at `now_us`: the volts the gauge may use, or `None` (refused:
    /// frozen or garbled). What it sees is handed to `raise`.
    pub fn reading(
        &mut self,
        volts: f64,
        now_us: u64,
        raise: &mut dyn FnMut(CoreEvent),
    ) -> Option<f64> {
        self.heard(now_us);
        let first = self.last_v.is_none();
        let consistent = self.last_v.is_some_and(|p| (volts - p).abs() <= JUMP_V);
        self.consistent_run = if consistent {
            self.consistent_run.saturating_add(1)
        } else {
            0
        };
        self.same = match self.last_v {
            Some(v) if v == volts => self.same.saturating_add(1),
            _ => 1,
        };
        self.last_v = Some(volts);
        if self.same >= STUCK_READINGS {
            self.episode(ReadingFault::Stuck { volts }, raise);
            return None;
        }
        let near_used = self.last_used_v.is_none_or(|u| (volts - u).abs() <= JUMP_V);
        let used = first || (consistent && (near_used || self.consistent_run >= AGREE_READINGS));
        if !used {
            self.refused = self.refused.saturating_add(1);
            let refused = self.refused;
            self.episode(ReadingFault::Garbled { volts, refused }, raise);
            return None;
        }
        self.last_used_v = Some(volts);
        if self.raised {
            self.good_run = self.good_run.saturating_add(1);
            if self.good_run >= BACK_READINGS {
                self.raised = false;
                self.late = false;
                raise(CoreEvent::BatteryReading {
                    battery: Battery::Flight,
                    fault: ReadingFault::Back,
                });
            }
        }
        Some(volts)
    }

    /// Raises the first fault of an episode; any fault starts the count of good readings
    /// again.
    fn episode(&mut self, fault: ReadingFault, raise: &mut dyn FnMut(CoreEvent)) {
        self.good_run = 0;
        if !self.raised {
            self.raised = true;
            raise(CoreEvent::BatteryReading {
                battery: Battery::Flight,
                fault,
            });
        }
    }

    /// The time at a control step: a channel with no reading for [`LATE_S`] is raised
    /// (once an episode).
    pub fn watch(&mut self, now_us: u64, raise: &mut dyn FnMut(CoreEvent)) {
        let Some(last_us) = self.last_read_us else {
            return;
        };
        let age_s = now_us.saturating_sub(last_us) as f64 * 1e-6;
        if age_s > LATE_S {
            if !self.late {
                raise(CoreEvent::BatteryReading {
                    battery: Battery::Flight,
                    fault: ReadingFault::Late { age_s },
                });
            }
            self.late = true;
            self.raised = true;
            self.good_run = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Readings of `volts` (by the reading's index) once a second from `from_s`: the volts
    /// used (NaN for a refusal) and what was raised.
    fn read(
        c: &mut BatteryChannel,
        from_s: u64,
        n: u64,
        volts: impl Fn(u64) -> f64,
    ) -> (Vec<f64>, Vec<ReadingFault>) {
        let mut raised = Vec::new();
        let mut used = Vec::new();
        for k in 0..n {
            let now_us = (from_s + k) * 1_000_000;
            c.watch(now_us, &mut |e| raised.push(e));
            used.push(
                c.reading(volts(k), now_us, &mut |e| raised.push(e))
                    .unwrap_or(f64::NAN),
            );
        }
        let faults = raised
            .into_iter()
            .filter_map(|e| match e {
                CoreEvent::BatteryReading {
                    battery: Battery::Flight,
                    fault,
                } => Some(fault),
                _ => None,
            })
            .collect();
        (used, faults)
    }

    /// A pack's noisy reading: 12.4 V and a few millivolts either way.
    fn noisy(k: u64) -> f64 {
        12.4 + 0.004 * ((k * 7919) % 5) as f64
    }

    #[test]
    fn a_reading_frozen_for_a_minute_is_said_once_and_refused_until_it_moves() {
        let mut c = BatteryChannel::default();
        let (used, faults) = read(&mut c, 0, 10, noisy);
        assert!(used.iter().all(|v| v.is_finite()) && faults.is_empty());
        let (used, faults) = read(&mut c, 10, 70, |_| 12.37);
        assert_eq!(faults, vec![ReadingFault::Stuck { volts: 12.37 }]);
        // The first 59 could be a steady pack's; from the 60th, refused.
        assert!(used[..59].iter().all(|v| v.is_finite()), "{used:?}");
        assert!(used[59..].iter().all(|v| v.is_nan()), "{used:?}");
        // Moving again: used, and good again after five.
        let (used, faults) = read(&mut c, 80, 6, noisy);
        assert!(used.iter().all(|v| v.is_finite()), "{used:?}");
        assert_eq!(faults, vec![ReadingFault::Back]);
    }

    #[test]
    fn garbled_readings_are_refused_counted_and_said_once() {
        let mut c = BatteryChannel::default();
        read(&mut c, 0, 5, noisy);
        // Every third reading anywhere in the ADC's range.
        let garbled = |k: u64| {
            if k.is_multiple_of(3) {
                [3.1, 14.2, 0.4, 9.0][(k / 3 % 4) as usize]
            } else {
                noisy(k)
            }
        };
        let (used, faults) = read(&mut c, 5, 12, garbled);
        assert!(
            matches!(faults.as_slice(), [ReadingFault::Garbled { volts, refused: 1 }] if *volts == 3.1),
            "{faults:?}"
        );
        // The garbled one and the good one after it are refused; the rest used.
        for (k, v) in used.iter().enumerate() {
            let refused = k % 3 != 2;
            assert_eq!(v.is_nan(), refused, "reading {k}: {used:?}");
        }
        assert_eq!(c.refused(), 8);
        assert!(
            used.iter()
                .filter(|v| v.is_finite())
                .all(|v| (v - 12.4).abs() < 0.05)
        );
    }

    #[test]
    fn a_real_step_is_used_once_three_readings_in_a_row_agree_with_it() {
        let mut c = BatteryChannel::default();
        read(&mut c, 0, 5, noisy);
        // A load switched on: 0.75 V less from now on.
        let (used, _) = read(&mut c, 5, 5, |k| noisy(k) - 0.75);
        assert!(used[..3].iter().all(|v| v.is_nan()), "{used:?}");
        assert!(used[3..].iter().all(|v| v.is_finite()), "{used:?}");
        // Exactly at the limit is no jump.
        let mut c = BatteryChannel::default();
        read(&mut c, 0, 1, |_| 0.0);
        let (used, faults) = read(&mut c, 1, 1, |_| JUMP_V);
        assert!(used[0].is_finite() && faults.is_empty());
    }

    #[test]
    fn a_channel_behind_is_said_once_and_good_again_after_five_readings_on_time() {
        let mut c = BatteryChannel::default();
        let mut raised = Vec::new();
        c.watch(10_000_000, &mut |e| raised.push(e));
        assert!(raised.is_empty(), "nothing before the first reading");
        read(&mut c, 0, 3, noisy);
        c.watch(2_000_000 + 3_000_000, &mut |e| raised.push(e));
        assert!(raised.is_empty(), "exactly {LATE_S} s is not late");
        // Read every ten seconds for a minute.
        for k in 1..=6u64 {
            let now_us = (2 + 10 * k) * 1_000_000;
            for step in 1..=500u64 {
                c.watch(now_us - 10_000_000 + step * 20_000, &mut |e| raised.push(e));
            }
            c.reading(noisy(k), now_us, &mut |e| raised.push(e));
        }
        let late: Vec<_> = raised
            .iter()
            .filter(|e| {
                matches!(
                    e,
                    CoreEvent::BatteryReading {
                        fault: ReadingFault::Late { .. },
                        ..
                    }
                )
            })
            .collect();
        assert_eq!(late.len(), 1, "{raised:?}");
        assert!(matches!(
            late[0],
            CoreEvent::BatteryReading { fault: ReadingFault::Late { age_s }, .. } if *age_s > LATE_S && *age_s < LATE_S + 0.05
        ));
        assert!(!raised.iter().any(|e| matches!(
            e,
            CoreEvent::BatteryReading {
                fault: ReadingFault::Back,
                ..
            }
        )));
        // Once a second again: good after five.
        let (_, faults) = read(&mut c, 63, 5, noisy);
        assert_eq!(faults, vec![ReadingFault::Back]);
    }
}
