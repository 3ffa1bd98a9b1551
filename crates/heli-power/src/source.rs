//! The hot-swap (thesis §2.2.3, §4.2.2): which battery powers the avionics, the ground
//! battery for warm-up and ground routines or the flight batteries, read from a digital
//! input, and the time spent on each, which the operator used to log by hand.

use serde::{Deserialize, Serialize};

/// What powers the avionics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PowerSource {
    /// The flight batteries on board.
    Flight,
    /// The ground battery plugged in through the hot-swap.
    Ground,
}

impl PowerSource {
    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            PowerSource::Flight => "flight",
            PowerSource::Ground => "ground",
        }
    }

    /// The source the hot-swap's digital input means: high (1) is the flight batteries.
    pub const fn from_line(high: bool) -> Self {
        if high {
            PowerSource::Flight
        } else {
            PowerSource::Ground
        }
    }
}

/// Time on each source since the log began.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SwapLog {
    /// The source now, and since when (s).
    current: Option<(PowerSource, f64)>,
    /// Time on the flight batteries before the current stretch (s).
    flight_s: f64,
    /// Time on the ground battery before the current stretch (s).
    ground_s: f64,
    /// Swaps seen.
    swaps: u32,
}

impl SwapLog {
    /// Takes the input's reading at `t_s`; returns the new source when it changed (the
    /// first reading counts as a change). A time that is not a number or goes back is
    /// ignored.
    pub fn update(&mut self, t_s: f64, source: PowerSource) -> Option<PowerSource> {
        if !t_s.is_finite() {
            return None;
        }
        match self.current {
            Some((s, _)) if s == source => None,
            Some((s, since)) if t_s >= since => {
                self.add(s, t_s - since);
                self.swaps = self.swaps.saturating_add(1);
                self.current = Some((source, t_s));
                Some(source)
            }
            Some(_) => None,
            None => {
                self.current = Some((source, t_s));
                Some(source)
            }
        }
    }

    fn add(&mut self, source: PowerSource, seconds: f64) {
        match source {
            PowerSource::Flight => self.flight_s += seconds,
            PowerSource::Ground => self.ground_s += seconds,
        }
    }

    /// The source now.
    pub fn source(&self) -> Option<PowerSource> {
        self.current.map(|(s, _)| s)
    }

    /// Swaps seen since the log began.
    pub fn swaps(&self) -> u32 {
        self.swaps
    }

    /// Time on the flight batteries and on the ground battery up to `now_s` (s).
    pub fn times(&self, now_s: f64) -> (f64, f64) {
        let mut log = *self;
        if let Some((s, since)) = self.current
            && now_s.is_finite()
            && now_s >= since
        {
            log.add(s, now_s - since);
        }
        (log.flight_s, log.ground_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_swap_from_ground_to_flight_is_logged_with_both_times() {
        let mut log = SwapLog::default();
        assert_eq!(
            log.update(0.0, PowerSource::Ground),
            Some(PowerSource::Ground)
        );
        assert_eq!(log.update(30.0, PowerSource::Ground), None);
        assert_eq!(
            log.update(90.0, PowerSource::Flight),
            Some(PowerSource::Flight)
        );
        assert_eq!(log.times(150.0), (60.0, 90.0));
        assert_eq!(log.swaps(), 1);
        // Time going back, or not a number, changes nothing.
        assert_eq!(log.update(80.0, PowerSource::Ground), None);
        assert_eq!(log.update(f64::NAN, PowerSource::Ground), None);
        assert_eq!(log.source(), Some(PowerSource::Flight));
        assert_eq!(PowerSource::from_line(true), PowerSource::Flight);
    }
}
