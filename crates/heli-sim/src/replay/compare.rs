//! The HIL replay's verdict: the servo commands a flight computer sends now against the
//! ones the recorded flight sent, paired by time.
//!
//! Both are one command per 50 Hz control step, but not at the same instants: the new
//! computer runs on its own clock, and its inputs arrive with the replay machine's jitter.
//! An IMU packet more than 2 ms late makes the main loop's 12 ms watchdog fill in a
//! sample, and the control steps then fall on the other IMU samples, 10 ms off, until the
//! next fill-in; a threshold in time (the end of the calibration, a phase's duration) can
//! be crossed one control step earlier or later. So a recorded command is compared with
//! every replayed command within [`Tolerance::window_us`] of it — one control step and
//! 2 ms — and counts as reproduced when the closest of them in value has every pulse width
//! within [`Tolerance::pulse_us`] of the recorded one. The flight is reproduced when
//! every recorded command has a replayed one in the window and at most
//! [`Tolerance::share`] of them are out of tolerance. Sans-I/O: the two lists in, the
//! report out.

use heli_proto::scb::Pulses;
use serde::Serialize;

/// How close counts as the same.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerance {
    /// Largest time between a recorded command and a replayed one it may be compared with
    /// (µs).
    pub window_us: u64,
    /// Largest difference of a pulse width (µs; 1000 µs is full travel). A phase that
    /// begins one control step later (its target taken 20 ms later: the end of the
    /// calibration is a time on the computer's own clock) moves the commands that follow by
    /// up to 32 µs, measured; the default, 50 µs, is 5 % of full travel.
    pub pulse_us: u16,
    /// Share of the recorded commands that may be out of tolerance (0–1): an IMU packet
    /// late on one side of the 12 ms watchdog and not on the other gives the estimator a
    /// repeated sample on one side only, and the commands around it differ by tens of µs
    /// for a few steps. A changed gain differs throughout.
    pub share: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Self {
            window_us: 22_000,
            pulse_us: 50,
            share: 0.01,
        }
    }
}

/// The largest difference of one channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ChannelDifference {
    /// Largest |difference| of the pulse width (µs).
    pub max_us: u16,
    /// Root mean square of the differences (µs).
    pub rms_us: f64,
    /// Recorded time of the largest difference (s).
    pub at_s: f64,
}

/// What the comparison found.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Comparison {
    /// The recorded flight's commands in the compared span.
    pub recorded: usize,
    /// The commands the computer sent.
    pub replayed: usize,
    /// Recorded commands with a replayed command inside the window.
    pub paired: usize,
    /// Largest |time| between a recorded command and the replayed one closest to it in
    /// value (µs).
    pub max_offset_us: u64,
    /// Recorded commands whose closest replayed command came more than 5 ms off.
    pub shifted: usize,
    /// Aileron, elevator, rudder, collective, throttle.
    pub channels: [ChannelDifference; 5],
    /// Paired commands with a pulse width out of tolerance.
    pub out_of_tolerance: usize,
    /// Recorded time of the first paired command out of tolerance, or of the first
    /// recorded command left unpaired (s).
    pub first_difference_s: Option<f64>,
    /// The tolerance used.
    pub tolerance: Tolerance,
}

impl Comparison {
    /// Every recorded command paired, at most [`Tolerance::share`] of them out of
    /// tolerance (and there was something to compare).
    pub fn matches(&self) -> bool {
        self.recorded > 0
            && self.paired == self.recorded
            && self.out_of_tolerance as f64 <= self.tolerance.share * self.recorded as f64
    }
}

/// Channel names in [`Comparison::channels`]' order.
pub const CHANNELS: [&str; 5] = ["aileron", "elevator", "rudder", "collective", "throttle"];

fn differences(a: &Pulses, b: &Pulses) -> [u16; 5] {
    let (a, b) = (widths(a), widths(b));
    [0, 1, 2, 3, 4].map(|i| match (a.get(i), b.get(i)) {
        (Some(x), Some(y)) => x.abs_diff(*y),
        _ => 0,
    })
}

fn widths(p: &Pulses) -> [u16; 5] {
    [
        p.aileron_us,
        p.elevator_us,
        p.rudder_us,
        p.collective_us,
        p.throttle_us,
    ]
}

/// Compares `replayed` with `recorded` (both `(t_us, pulses)` in the recorded flight's time,
/// sorted by time).
pub fn compare(
    recorded: &[(u64, Pulses)],
    replayed: &[(u64, Pulses)],
    tolerance: Tolerance,
) -> Comparison {
    let mut out = Comparison {
        recorded: recorded.len(),
        replayed: replayed.len(),
        tolerance,
        ..Comparison::default()
    };
    let mut sums = [0.0_f64; 5];
    let mut first = 0usize;
    for (t, p) in recorded {
        // The replayed commands within the window (both lists are in time order).
        while replayed
            .get(first)
            .is_some_and(|(u, _)| *u + tolerance.window_us < *t)
        {
            first += 1;
        }
        let best = replayed
            .get(first..)
            .unwrap_or_default()
            .iter()
            .take_while(|(u, _)| *u <= t.saturating_add(tolerance.window_us))
            .map(|(u, q)| {
                let d = differences(p, q);
                (d.iter().copied().max().unwrap_or(0), u.abs_diff(*t), d)
            })
            .min();
        let Some((worst, offset, d)) = best else {
            out.first_difference_s.get_or_insert(*t as f64 * 1e-6);
            continue;
        };
        out.paired += 1;
        out.max_offset_us = out.max_offset_us.max(offset);
        if offset > 5_000 {
            out.shifted += 1;
        }
        for ((c, s), d) in out.channels.iter_mut().zip(sums.iter_mut()).zip(d) {
            *s += f64::from(d) * f64::from(d);
            if d > c.max_us {
                c.max_us = d;
                c.at_s = *t as f64 * 1e-6;
            }
        }
        if worst > tolerance.pulse_us {
            out.out_of_tolerance += 1;
            out.first_difference_s.get_or_insert(*t as f64 * 1e-6);
        }
    }
    if out.paired > 0 {
        for (c, s) in out.channels.iter_mut().zip(sums) {
            c.rms_us = (s / out.paired as f64).sqrt();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pulses(aileron_us: u16) -> Pulses {
        Pulses {
            aileron_us,
            elevator_us: 1500,
            rudder_us: 1500,
            collective_us: 1500,
            throttle_us: 1800,
        }
    }

    fn steps(n: u64, offset_us: u64, aileron: impl Fn(u64) -> u16) -> Vec<(u64, Pulses)> {
        (0..n)
            .map(|k| (1_000_000 + k * 20_000 + offset_us, pulses(aileron(k))))
            .collect()
    }

    #[test]
    fn the_same_commands_a_little_late_match() {
        let recorded = steps(100, 0, |k| 1500 + (k % 7) as u16);
        let replayed = steps(100, 400, |k| 1500 + (k % 7) as u16 + (k % 2) as u16);
        let c = compare(&recorded, &replayed, Tolerance::default());
        assert!(c.matches(), "{c:?}");
        assert_eq!(c.paired, 100);
        assert_eq!(c.max_offset_us, 400);
        assert_eq!(c.channels[0].max_us, 1);
    }

    #[test]
    fn a_command_out_of_tolerance_is_the_first_difference() {
        let recorded = steps(100, 0, |_| 1500);
        let replayed = steps(100, 0, |k| if k >= 60 { 1570 } else { 1500 });
        let c = compare(&recorded, &replayed, Tolerance::default());
        assert!(!c.matches());
        assert_eq!(c.channels[0].max_us, 70);
        // The recorded command at the change may be the replay's one step early; the one
        // after it cannot.
        assert!((c.first_difference_s.unwrap() - 2.22).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn steps_on_the_other_imu_samples_still_pair() {
        // A watchdog fill-in moves the control steps by one IMU period for a while.
        let recorded = steps(100, 0, |_| 1500);
        let replayed: Vec<_> = steps(100, 0, |_| 1501)
            .into_iter()
            .map(|(t, p)| {
                if (1_400_000..1_800_000).contains(&t) {
                    (t + 10_000, p)
                } else {
                    (t, p)
                }
            })
            .collect();
        let c = compare(&recorded, &replayed, Tolerance::default());
        assert!(c.matches(), "{c:?}");
        assert_eq!(c.shifted, 20);
    }

    #[test]
    fn a_few_stray_commands_are_the_same_flight_a_lasting_difference_is_not() {
        // 400 commands: 1 % is 4. A run of bad commands is hidden at its two ends by the
        // good neighbours one step away; its middle counts.
        let recorded = steps(400, 0, |_| 1500);
        let run_of = |n: u64| {
            steps(400, 0, move |k| {
                if (50..50 + n).contains(&k) {
                    1560
                } else {
                    1500
                }
            })
        };
        let c = compare(&recorded, &run_of(5), Tolerance::default());
        assert_eq!(c.out_of_tolerance, 3);
        assert!(c.matches(), "{c:?}");
        let c = compare(&recorded, &run_of(8), Tolerance::default());
        assert_eq!(c.out_of_tolerance, 6);
        assert!(!c.matches(), "{c:?}");
    }

    #[test]
    fn a_change_one_control_step_later_is_the_same_flight() {
        // The end of the calibration crossed one step later: the take-off's collective
        // comes 20 ms later.
        let recorded = steps(100, 0, |k| if k >= 60 { 1700 } else { 1500 });
        let replayed = steps(100, 300, |k| if k >= 61 { 1700 } else { 1500 });
        let c = compare(&recorded, &replayed, Tolerance::default());
        assert!(c.matches(), "{c:?}");
        assert_eq!(c.shifted, 1);
    }

    #[test]
    fn missing_commands_are_a_difference() {
        let recorded = steps(100, 0, |_| 1500);
        let replayed: Vec<_> = steps(100, 0, |_| 1500)
            .into_iter()
            .filter(|(t, _)| *t < 1_000_000 + 50 * 20_000)
            .collect();
        let c = compare(&recorded, &replayed, Tolerance::default());
        assert!(!c.matches());
        // The first recorded command after the end is still within a step of the last sent.
        assert_eq!(c.paired, 51);
        assert!((c.first_difference_s.unwrap() - 2.02).abs() < 1e-9, "{c:?}");
        assert!(!compare(&recorded, &[], Tolerance::default()).matches());
        assert!(!compare(&[], &[], Tolerance::default()).matches());
    }
}
