//! What `heli log info` says about a log beyond its counts: each channel's rate, its largest
//! silence and the gaps in its sequence numbers (each channel numbers its own messages, so a
//! gap names its stream), and the events that were warnings or worse.

use crate::LogContents;
use crate::events::{EventLevel, level_of};

/// One channel's messages, summed up.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelStats {
    /// Channel.
    pub topic: String,
    /// Its schema's name, if the log announced one.
    pub schema: Option<String>,
    /// Messages read.
    pub messages: u64,
    /// First message time (µs).
    pub first_us: u64,
    /// Last message time (µs).
    pub last_us: u64,
    /// Mean message rate over the channel's own span (Hz); `None` with fewer than two
    /// messages or no time between them.
    pub rate_hz: Option<f64>,
    /// Longest time between two consecutive messages (µs).
    pub largest_interval_us: u64,
    /// Time of the message that ended that longest interval (µs).
    pub largest_interval_end_us: u64,
    /// Places where the sequence number jumped forward by more than one.
    pub sequence_gaps: u64,
    /// Sequence numbers skipped over by those jumps: messages that never reached the log.
    pub missing: u64,
    /// Places where the sequence number went back or repeated (a restarted source, or
    /// messages out of order).
    pub sequence_breaks: u64,
}

/// Per-channel statistics, in channel-name order.
pub fn channels(contents: &LogContents) -> Vec<ChannelStats> {
    let counts = contents.counts();
    counts
        .keys()
        .map(|topic| {
            let messages: Vec<_> = contents
                .messages
                .iter()
                .filter(|m| &m.topic == topic)
                .collect();
            let mut times: Vec<u64> = messages.iter().map(|m| m.t_us).collect();
            times.sort_unstable();
            let first_us = times.first().copied().unwrap_or(0);
            let last_us = times.last().copied().unwrap_or(0);
            let (largest_interval_us, largest_interval_end_us) = times
                .windows(2)
                .map(|w| (w[1] - w[0], w[1]))
                .max_by_key(|(gap, _)| *gap)
                .unwrap_or((0, first_us));
            let span_s = (last_us - first_us) as f64 * 1e-6;
            let rate_hz =
                (times.len() >= 2 && span_s > 0.0).then(|| (times.len() - 1) as f64 / span_s);
            let (mut sequence_gaps, mut missing, mut sequence_breaks) = (0, 0, 0);
            for pair in messages.windows(2) {
                let step = pair[1].sequence.wrapping_sub(pair[0].sequence);
                match step {
                    1 => {}
                    // A forward jump (less than half the number space).
                    2..0x8000_0000 => {
                        sequence_gaps += 1;
                        missing += u64::from(step - 1);
                    }
                    _ => sequence_breaks += 1,
                }
            }
            ChannelStats {
                topic: topic.clone(),
                schema: contents.schemas.get(topic).cloned(),
                messages: times.len() as u64,
                first_us,
                last_us,
                rate_hz,
                largest_interval_us,
                largest_interval_end_us,
                sequence_gaps,
                missing,
                sequence_breaks,
            }
        })
        .collect()
}

/// An event that was a warning or worse.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fault {
    /// When (µs).
    pub t_us: u64,
    /// How bad.
    pub level: EventLevel,
    /// What happened.
    pub text: String,
}

/// The `events` channel's warnings, errors and fatal events, in time order. Events from logs
/// written before events had levels are judged by their text.
pub fn faults(contents: &LogContents) -> Vec<Fault> {
    let mut faults: Vec<Fault> = contents
        .messages
        .iter()
        .filter(|m| m.topic == "events")
        .map(|m| Fault {
            t_us: m.t_us,
            level: level_of(&m.value),
            text: m.value["text"].as_str().unwrap_or_default().to_string(),
        })
        .filter(|f| f.level.is_fault())
        .collect();
    faults.sort_by_key(|f| f.t_us);
    faults
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LoggedMessage;
    use serde_json::json;

    fn message(topic: &str, t_us: u64, sequence: u32) -> LoggedMessage {
        LoggedMessage {
            topic: topic.into(),
            t_us,
            sequence,
            value: json!({}),
        }
    }

    #[test]
    fn rates_gaps_and_missing_messages_are_per_channel() {
        let mut messages = Vec::new();
        // imu at 100 Hz for 1 s, with messages 40..=44 missing (a 60 ms silence).
        for k in (0..=100u32).filter(|k| !(40..45).contains(k)) {
            messages.push(message("imu", u64::from(k) * 10_000, k));
        }
        // gps at 1 Hz, numbered on its own, one restart.
        for (k, seq) in [(0u64, 0u32), (1, 1), (2, 2), (3, 0)] {
            messages.push(message("gps", k * 1_000_000, seq));
        }
        let contents = LogContents {
            messages,
            ..Default::default()
        };
        let stats = channels(&contents);
        let (gps, imu) = (&stats[0], &stats[1]);
        assert_eq!((imu.topic.as_str(), imu.messages), ("imu", 96));
        assert_eq!(
            (imu.sequence_gaps, imu.missing, imu.sequence_breaks),
            (1, 5, 0)
        );
        assert_eq!(
            (imu.largest_interval_us, imu.largest_interval_end_us),
            (60_000, 450_000)
        );
        assert!((imu.rate_hz.unwrap_or_default() - 95.0).abs() < 1e-9);
        assert_eq!((gps.sequence_gaps, gps.sequence_breaks), (0, 1));
        assert_eq!(gps.rate_hz, Some(1.0));
    }

    #[test]
    fn faults_are_the_warnings_and_worse_in_time_order() {
        let event = |t_us: u64, value| LoggedMessage {
            topic: "events".into(),
            t_us,
            sequence: 0,
            value,
        };
        let contents = LogContents {
            messages: vec![
                event(
                    3_000_000,
                    json!({"text": "t=3.00 s GPS lost: estimate coasting on the IMU", "level": "error"}),
                ),
                event(
                    1_000_000,
                    json!({"text": "t=1.00 s phase hold", "level": "info"}),
                ),
                event(2_000_000, json!({"text": "t=2.00 s watchdog fired"})),
            ],
            ..Default::default()
        };
        let faults = faults(&contents);
        assert_eq!(faults.len(), 2);
        assert_eq!(
            (faults[0].t_us, faults[0].level),
            (2_000_000, EventLevel::Warning)
        );
        assert_eq!(faults[1].level, EventLevel::Error);
    }
}
