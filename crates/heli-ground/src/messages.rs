//! The message area of the display (thesis §2.4): the vehicle's status texts and the
//! ground's own notes, numbered, the oldest forgotten beyond [`MESSAGES_KEPT`].

use std::collections::VecDeque;

use mavlink::dialects::common::MavSeverity;
use serde::Serialize;

/// Lines kept in the message area.
pub const MESSAGES_KEPT: usize = 300;

/// One line of the message area.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Message {
    /// Rises with every line (the page shows each once).
    pub seq: u64,
    /// critical, error, warning, notice or info.
    pub severity: &'static str,
    /// "vehicle" (its status texts) or "ground".
    pub source: &'static str,
    /// The line.
    pub text: String,
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

/// The lines, newest last.
#[derive(Clone, Debug, Default)]
pub struct MessageArea {
    lines: VecDeque<Message>,
    next: u64,
}

impl MessageArea {
    /// Adds a line from `source` ("vehicle" or "ground").
    pub fn push(&mut self, severity: &'static str, source: &'static str, text: String) {
        self.next = self.next.saturating_add(1);
        self.lines.push_back(Message {
            seq: self.next,
            severity,
            source,
            text,
        });
        while self.lines.len() > MESSAGES_KEPT {
            self.lines.pop_front();
        }
    }

    /// The newest `n` lines, oldest first.
    pub fn newest(&self, n: usize) -> Vec<Message> {
        self.lines
            .iter()
            .skip(self.lines.len().saturating_sub(n))
            .cloned()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_numbered_and_the_oldest_forgotten() {
        let mut area = MessageArea::default();
        for k in 0..MESSAGES_KEPT + 5 {
            area.push("info", "ground", format!("line {k}"));
        }
        let all = area.newest(usize::MAX);
        assert_eq!(all.len(), MESSAGES_KEPT);
        assert_eq!(all[0].text, "line 5");
        assert_eq!(all[0].seq, 6);
        let last = area.newest(2);
        assert_eq!(last.len(), 2);
        assert_eq!(last[1].text, format!("line {}", MESSAGES_KEPT + 4));
        assert_eq!(severity_word(MavSeverity::MAV_SEVERITY_ALERT), "critical");
        assert_eq!(severity_word(MavSeverity::MAV_SEVERITY_DEBUG), "info");
    }
}
