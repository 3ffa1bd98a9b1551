//! Status texts said while no ground station is heard: the warnings and worse are held and
//! sent when a ground is heard again, after a line that says how many lines were said
//! meanwhile; the routine ones are counted, not held. A crash, a restart or a refusal during
//! a link outage reaches the operator when the link comes back, not never.

use std::collections::VecDeque;

use mavlink::dialects::common::MavSeverity;

/// Most texts held for a ground; past them, the first ones are kept (what began the trouble)
/// and the rest counted.
pub const MAX_HELD: usize = 50;

/// The texts said while no ground was heard.
#[derive(Debug, Default)]
pub struct Held {
    texts: VecDeque<(MavSeverity, String)>,
    /// Routine texts (notice and below) not held.
    routine: u64,
    /// Warnings and worse past [`MAX_HELD`], not held.
    beyond: u64,
}

impl Held {
    /// Texts said while no ground is heard.
    pub fn keep(&mut self, texts: impl IntoIterator<Item = (MavSeverity, String)>) {
        for (severity, text) in texts {
            // MAVLink's severities run from EMERGENCY (0) to DEBUG (7).
            if (severity as u8) > (MavSeverity::MAV_SEVERITY_WARNING as u8) {
                self.routine = self.routine.saturating_add(1);
            } else if self.texts.len() < MAX_HELD {
                self.texts.push_back((severity, text));
            } else {
                self.beyond = self.beyond.saturating_add(1);
            }
        }
    }

    /// A ground is heard: what was held, after a line that says what was said meanwhile
    /// (nothing if nothing was).
    pub fn release(&mut self) -> Vec<(MavSeverity, String)> {
        let held = std::mem::take(&mut self.texts);
        let routine = std::mem::take(&mut self.routine);
        let beyond = std::mem::take(&mut self.beyond);
        if held.is_empty() && routine == 0 && beyond == 0 {
            return Vec::new();
        }
        let total = (held.len() as u64)
            .saturating_add(routine)
            .saturating_add(beyond);
        let lines = if total == 1 { "line" } else { "lines" };
        let mut said = match held.len() {
            0 => format!("while no ground was heard: {total} {lines} said, none a warning"),
            1 => format!("while no ground was heard: {total} {lines} said, the warning follows"),
            n => format!(
                "while no ground was heard: {total} {lines} said, the {n} warnings and worse follow"
            ),
        };
        if beyond > 0 {
            said.push_str(&format!(" ({beyond} more not kept)"));
        }
        let worst = held
            .iter()
            .map(|(s, _)| *s)
            .min_by_key(|s| *s as u8)
            .unwrap_or(MavSeverity::MAV_SEVERITY_NOTICE);
        std::iter::once((worst, said)).chain(held).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_said_while_no_ground_is_heard_follow_a_line_that_counts_them() {
        let mut held = Held::default();
        assert!(held.release().is_empty(), "nothing said, nothing to send");
        held.keep([
            (MavSeverity::MAV_SEVERITY_INFO, "state flying".to_string()),
            (
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "flight process CRASHED".to_string(),
            ),
            (MavSeverity::MAV_SEVERITY_NOTICE, "restarting".to_string()),
            (
                MavSeverity::MAV_SEVERITY_WARNING,
                "restarted in the air".to_string(),
            ),
        ]);
        let sent = held.release();
        assert_eq!(
            sent,
            [
                (
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    "while no ground was heard: 4 lines said, the 2 warnings and worse follow"
                        .to_string()
                ),
                (
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    "flight process CRASHED".to_string()
                ),
                (
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "restarted in the air".to_string()
                ),
            ]
        );
        assert!(held.release().is_empty(), "sent once");
        held.keep([
            (MavSeverity::MAV_SEVERITY_INFO, "i".to_string()),
            (MavSeverity::MAV_SEVERITY_ERROR, "e".to_string()),
        ]);
        assert_eq!(
            held.release()[0].1,
            "while no ground was heard: 2 lines said, the warning follows"
        );
    }

    #[test]
    fn past_the_bound_the_first_warnings_are_kept_and_the_rest_counted() {
        let mut held = Held::default();
        held.keep((0..MAX_HELD + 3).map(|i| (MavSeverity::MAV_SEVERITY_ERROR, format!("e{i}"))));
        held.keep([(MavSeverity::MAV_SEVERITY_DEBUG, "d".to_string())]);
        let sent = held.release();
        assert_eq!(sent.len(), MAX_HELD + 1);
        assert_eq!(
            sent[0].1,
            format!(
                "while no ground was heard: {} lines said, the {MAX_HELD} warnings and worse follow (3 more not kept)",
                MAX_HELD + 4
            )
        );
        assert_eq!(sent[1].1, "e0");
        assert_eq!(sent[MAX_HELD].1, format!("e{}", MAX_HELD - 1));
        // Routine lines alone are counted, with nothing after.
        held.keep([(MavSeverity::MAV_SEVERITY_INFO, "i".to_string())]);
        assert_eq!(
            held.release(),
            [(
                MavSeverity::MAV_SEVERITY_NOTICE,
                "while no ground was heard: 1 line said, none a warning".to_string()
            )]
        );
    }
}
