//! The main loop's watchdog: the IMU times the loop, and if no IMU packet has arrived 12 ms
//! after the last one, the loop runs anyway on a copy of the last packet (thesis §2.3.2).
//! Every firing is counted and reported, never silent.

/// Watchdog period of the thesis (µs).
pub const WATCHDOG_PERIOD_US: u64 = 12_000;

/// The watchdog's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Watchdog {
    period_us: u64,
    last_kick_us: Option<u64>,
    fires: u32,
}

impl Watchdog {
    /// A watchdog with the given period, disarmed until the first kick.
    pub const fn new(period_us: u64) -> Self {
        Self {
            period_us,
            last_kick_us: None,
            fires: 0,
        }
    }

    /// Resets the timer at `now_us` (an IMU packet arrived, or the watchdog just fired).
    pub fn kick(&mut self, now_us: u64) {
        self.last_kick_us = Some(now_us);
    }

    /// When the watchdog will fire if nobody kicks it.
    pub fn deadline_us(&self) -> Option<u64> {
        self.last_kick_us.map(|t| t.saturating_add(self.period_us))
    }

    /// True (and counted) if the deadline has passed at `now_us`; the caller repeats the
    /// last sample and kicks.
    pub fn expired(&mut self, now_us: u64) -> bool {
        match self.deadline_us() {
            Some(deadline) if now_us >= deadline => {
                self.fires = self.fires.saturating_add(1);
                true
            }
            _ => false,
        }
    }

    /// How many times it fired.
    pub fn fires(&self) -> u32 {
        self.fires
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fires_only_after_twelve_milliseconds_of_silence() {
        let mut w = Watchdog::new(WATCHDOG_PERIOD_US);
        assert!(!w.expired(1_000_000), "disarmed before the first packet");
        w.kick(0);
        assert!(!w.expired(11_999));
        assert!(w.expired(12_000));
        assert_eq!(w.fires(), 1);
    }
}
