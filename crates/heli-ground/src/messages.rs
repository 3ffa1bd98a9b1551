//! The message area of the display (thesis §2.4): the vehicle's status texts and the
//! ground's own notes, by severity.
//!
//! - A line that repeats one of the recent lines (same severity, source and words, numbers
//!   aside: `imu late`, `imu ok`, … five times a second) is not added again: the earlier
//!   entry counts it, moves to the end and shows its rate.
//! - Errors and critical events are *pinned* until an operator acknowledges them: the page
//!   shows them above everything else.
//! - Every warning and worse of the session is kept (up to [`SEVERE_KEPT`]); the notices and
//!   information beyond the newest [`ROUTINE_KEPT`] are forgotten. A page opened late gets all
//!   that is kept.

use std::collections::VecDeque;

use mavlink::dialects::common::MavSeverity;
use serde::Serialize;

/// Notices and information lines kept.
pub const ROUTINE_KEPT: usize = 300;
/// Warnings, errors and critical lines kept (the whole session's, short of a flood).
pub const SEVERE_KEPT: usize = 2000;
/// A line repeating one of this many newest entries is counted there.
const REPEAT_WINDOW: usize = 40;

/// The devices a line can be about (its first word, or the word after `event …`).
pub const DEVICES: [&str; 9] = [
    "imu",
    "uplink",
    "servo",
    "gps",
    "altimeter",
    "compass",
    "battery",
    "link",
    "log",
];

/// One entry of the message area: a line and its repeats.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Message {
    /// The entry's number (that of its first line): a page keeps one element per id.
    pub id: u64,
    /// Rises with every change of the area (a new entry, or a repeat of this one): a page
    /// redraws the entries with a `seq` above the last it saw.
    pub seq: u64,
    /// critical, error, warning, notice or info.
    pub severity: &'static str,
    /// "vehicle" (its status texts) or "ground".
    pub source: &'static str,
    /// The device the line is about (one of [`DEVICES`]), or empty.
    pub device: &'static str,
    /// The newest line.
    pub text: String,
    /// How many times the line came.
    pub count: u32,
    /// The ground's time of the first and the newest (s since the station started).
    pub first_s: f64,
    /// The ground's time of the newest.
    pub last_s: f64,
    /// Repeats per second, over the entry's life (with two or more).
    pub rate_hz: Option<f64>,
    /// An error or critical line no operator has acknowledged yet.
    pub pinned: bool,
}

/// The word for a MAVLink severity.
pub fn severity_word(s: MavSeverity) -> &'static str {
    use MavSeverity::*;
    match s {
        MAV_SEVERITY_EMERGENCY | MAV_SEVERITY_ALERT | MAV_SEVERITY_CRITICAL => "critical",
        MAV_SEVERITY_ERROR => "error",
        MAV_SEVERITY_WARNING => "warning",
        MAV_SEVERITY_NOTICE => "notice",
        MAV_SEVERITY_INFO | MAV_SEVERITY_DEBUG => "info",
    }
}

/// Warning or worse: kept for the whole session.
pub fn severe(severity: &str) -> bool {
    matches!(severity, "critical" | "error" | "warning")
}

/// Error or worse: pinned until acknowledged.
fn pins(severity: &str) -> bool {
    matches!(severity, "critical" | "error")
}

/// The words of a line that say what it is about, by which its repeats are known: without
/// the prefix the vehicle gives it (`flight: event warning-hi t=12.00 s `), its numbers as `#`.
fn repeat_key(text: &str) -> String {
    strip_prefix(text)
        .chars()
        .map(|c| if c.is_ascii_digit() { '#' } else { c })
        .collect()
}

/// The line without the vehicle's `flight: event SEVERITY t=… s ` or `bootstrap: `.
fn strip_prefix(text: &str) -> &str {
    let mut rest = text;
    for p in ["flight: ", "bootstrap: ", "link: "] {
        if let Some(r) = rest.strip_prefix(p) {
            rest = r;
            break;
        }
    }
    if let Some(r) = rest.strip_prefix("event ") {
        rest = r.split_once(' ').map_or(r, |(_, after)| after);
    }
    if rest.starts_with("t=")
        && let Some((_, after)) = rest.split_once(" s ")
    {
        rest = after;
    }
    rest
}

/// The device a line is about, if it names one first.
pub fn device_of(text: &str) -> &'static str {
    let body = strip_prefix(text).to_ascii_lowercase();
    let first = body
        .split(|c: char| !c.is_ascii_alphanumeric())
        .find(|w| !w.is_empty())
        .unwrap_or("");
    let first = match first {
        "bar" | "barometer" => "altimeter",
        "cmps" => "compass",
        "gps" | "satellites" => "gps",
        "servo" | "servos" => "servo",
        "flight" | "receiver" if body.contains("battery") => "battery",
        "power" => "battery",
        "telemetry" | "ground" => "link",
        other => other,
    };
    DEVICES.iter().copied().find(|d| *d == first).unwrap_or("")
}

/// The entries, oldest change first.
#[derive(Clone, Debug, Default)]
pub struct MessageArea {
    entries: VecDeque<Entry>,
    next: u64,
}

#[derive(Clone, Debug)]
struct Entry {
    key: String,
    message: Message,
}

impl MessageArea {
    /// Adds a line from `source` ("vehicle" or "ground") at the ground's time `now_s`.
    pub fn push(&mut self, severity: &'static str, source: &'static str, text: String, now_s: f64) {
        self.next = self.next.saturating_add(1);
        let key = repeat_key(&text);
        let newest = self.entries.len().saturating_sub(REPEAT_WINDOW);
        let repeat = (newest..self.entries.len()).rev().find(|i| {
            self.entries.get(*i).is_some_and(|e| {
                e.key == key && e.message.severity == severity && e.message.source == source
            })
        });
        if let Some(mut entry) = repeat.and_then(|i| self.entries.remove(i)) {
            let m = &mut entry.message;
            m.seq = self.next;
            m.count = m.count.saturating_add(1);
            m.text = text;
            m.last_s = now_s;
            let span_s = m.last_s - m.first_s;
            m.rate_hz = (span_s > 0.0).then(|| f64::from(m.count.saturating_sub(1)) / span_s);
            m.pinned = m.pinned || pins(severity);
            self.entries.push_back(entry);
            return;
        }
        let device = device_of(&text);
        self.entries.push_back(Entry {
            key,
            message: Message {
                id: self.next,
                seq: self.next,
                severity,
                source,
                device,
                text,
                count: 1,
                first_s: now_s,
                last_s: now_s,
                rate_hz: None,
                pinned: pins(severity),
            },
        });
        self.forget();
    }

    /// Forgets the oldest routine entries beyond [`ROUTINE_KEPT`], and the oldest of all
    /// beyond [`SEVERE_KEPT`] more.
    fn forget(&mut self) {
        let routine = self
            .entries
            .iter()
            .filter(|e| !severe(e.message.severity))
            .count();
        if routine > ROUTINE_KEPT
            && let Some(i) = self
                .entries
                .iter()
                .position(|e| !severe(e.message.severity))
        {
            self.entries.remove(i);
        }
        while self.entries.len() > ROUTINE_KEPT.saturating_add(SEVERE_KEPT) {
            self.entries.pop_front();
        }
    }

    /// Unpins every entry changed up to `seq` (what the operator has seen); returns how many.
    pub fn acknowledge(&mut self, seq: u64) -> usize {
        let mut n = 0;
        for e in &mut self.entries {
            if e.message.pinned && e.message.seq <= seq {
                e.message.pinned = false;
                n += 1;
            }
        }
        n
    }

    /// The newest `n` changes, oldest first.
    pub fn newest(&self, n: usize) -> Vec<Message> {
        self.entries
            .iter()
            .skip(self.entries.len().saturating_sub(n))
            .map(|e| e.message.clone())
            .collect()
    }

    /// The pinned entries, the newest change first: the box's top line, above the fold
    /// whatever came before, is the latest error (a long list scrolls its oldest away).
    pub fn pinned(&self) -> Vec<Message> {
        self.entries
            .iter()
            .rev()
            .filter(|e| e.message.pinned)
            .map(|e| e.message.clone())
            .collect()
    }

    /// The newest change's number (0: none).
    pub fn last_seq(&self) -> u64 {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routine_lines_are_forgotten_first_and_warnings_kept() {
        let mut area = MessageArea::default();
        area.push("warning", "vehicle", "gps lost".into(), 0.0);
        // Lines that differ in words, not only numbers (those would be repeats).
        let word = |k: usize| {
            format!(
                "line {}{}",
                (b'a' + (k % 26) as u8) as char,
                "x".repeat(k / 26)
            )
        };
        for k in 0..ROUTINE_KEPT + 5 {
            area.push("info", "ground", word(k), 1.0);
        }
        let all = area.newest(usize::MAX);
        assert_eq!(all.len(), ROUTINE_KEPT + 1);
        assert_eq!(
            all[0].text, "gps lost",
            "the warning outlives the routine lines"
        );
        assert_eq!(all[1].text, word(5));
        assert_eq!(severity_word(MavSeverity::MAV_SEVERITY_ALERT), "critical");
        assert_eq!(severity_word(MavSeverity::MAV_SEVERITY_DEBUG), "info");
    }

    #[test]
    fn repeats_are_counted_with_their_rate_in_one_entry_moved_to_the_end() {
        let mut area = MessageArea::default();
        for k in 0..10u32 {
            let t = f64::from(k) * 0.2;
            area.push(
                "notice",
                "vehicle",
                format!("flight: event warning-lo t={t:.2} s imu late ({k} ms)"),
                t,
            );
            area.push(
                "info",
                "vehicle",
                format!("flight: event activity-lo t={t:.2} s imu ok"),
                t,
            );
        }
        area.push(
            "warning",
            "vehicle",
            "flight: event warning-hi t=2.00 s gps lost".into(),
            2.0,
        );
        let all = area.newest(usize::MAX);
        assert_eq!(all.len(), 3, "{all:?}");
        let late = &all[0];
        assert_eq!((late.count, late.device), (10, "imu"));
        assert!(
            late.text.contains("(9 ms)"),
            "the newest text: {}",
            late.text
        );
        let rate = late.rate_hz.unwrap_or(0.0);
        assert!((rate - 5.0).abs() < 1e-9, "{rate}");
        assert_eq!(all[2].device, "gps");
        assert!(
            all.windows(2).all(|w| w[0].seq < w[1].seq),
            "in order of change"
        );
    }

    #[test]
    fn errors_are_pinned_until_acknowledged_and_pinned_again_when_they_repeat() {
        let mut area = MessageArea::default();
        area.push(
            "critical",
            "vehicle",
            "flight: event fatal t=1.00 s imu silent".into(),
            1.0,
        );
        area.push("notice", "vehicle", "imu late".into(), 1.1);
        assert_eq!(area.pinned().len(), 1);
        let seen = area.last_seq();
        assert_eq!(area.acknowledge(seen), 1);
        assert!(area.pinned().is_empty());
        area.push(
            "critical",
            "vehicle",
            "flight: event fatal t=9.00 s imu silent".into(),
            9.0,
        );
        let pinned = area.pinned();
        assert_eq!((pinned.len(), pinned[0].count), (1, 2));
        // The newest first: an older error stays below a newer one.
        area.push("error", "vehicle", "param X refused".into(), 30.0);
        area.push("critical", "vehicle", "event fatal imu silent".into(), 31.0);
        let texts: Vec<String> = area.pinned().into_iter().map(|m| m.text).collect();
        assert_eq!(
            texts.first().map(String::as_str),
            Some("event fatal imu silent")
        );
        assert_eq!(texts.get(1).map(String::as_str), Some("param X refused"));
        assert_eq!(
            area.acknowledge(seen),
            0,
            "a repeat after the acknowledgement stays"
        );
    }

    #[test]
    fn the_device_is_the_first_word_after_the_vehicles_prefix() {
        assert_eq!(device_of("flight: event fatal t=1.00 s imu silent"), "imu");
        assert_eq!(
            device_of("flight: event warning-hi t=3.00 s GPS lost"),
            "gps"
        );
        assert_eq!(device_of("bar late"), "altimeter");
        assert_eq!(device_of("flight battery at 30 %"), "battery");
        assert_eq!(device_of("start logging: sent"), "");
    }
}
