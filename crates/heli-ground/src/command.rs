//! A command on its way to the vehicle, sans-I/O: sent again every
//! [`COMMAND_RETRY_US`] until the vehicle answers, every [`IN_PROGRESS_RETRY_US`] once it
//! said the command is under way (to recover a lost final answer), given up after its
//! timeout. Each retry carries a rising `confirmation`, so the vehicle answers it without
//! carrying the command out twice. The display's station and the command-line client both
//! send their commands through it.

use heli_link::GroundCommand;
use heli_link::command::command_long;
use heli_link::ground::{COMMAND_RETRY_US, GroundLink};
use mavlink::dialects::common::{COMMAND_LONG_DATA, MavCmd, MavResult};

/// After `IN_PROGRESS`, a command is sent again this often (µs).
pub const IN_PROGRESS_RETRY_US: u64 = 2_000_000;

/// Where a command is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Progress {
    /// No final answer yet.
    Waiting,
    /// The vehicle's final answer.
    Answered(MavResult),
    /// No final answer within the timeout: given up.
    TimedOut,
}

/// A command sent, and its retries.
#[derive(Clone, Debug)]
pub struct InFlight {
    long: COMMAND_LONG_DATA,
    first_us: u64,
    sent_us: u64,
    in_progress: bool,
    acks_from: usize,
    timeout_us: u64,
}

impl InFlight {
    /// Sends `command` at `now_us`: the command and its first frame, or `None` when its
    /// parameters cannot go over the link (a suffix longer than the link carries).
    pub fn send(
        link: &mut GroundLink,
        command: &GroundCommand,
        timeout_us: u64,
        now_us: u64,
    ) -> Option<(Self, Vec<u8>)> {
        let long = command_long(command, (1, 1))?;
        let frame = link.command_frame(long.clone(), now_us);
        let sent = Self {
            long,
            first_us: now_us,
            sent_us: now_us,
            in_progress: false,
            acks_from: link.acks.len(),
            timeout_us,
        };
        Some((sent, frame))
    }

    /// The MAVLink command it is.
    pub fn command(&self) -> MavCmd {
        self.long.command
    }

    /// Reads the answers that came since the last step; at `now_us`, where the command is,
    /// and a retry's frame to send when one is due.
    pub fn tick(&mut self, link: &mut GroundLink, now_us: u64) -> (Progress, Option<Vec<u8>>) {
        let answers: Vec<MavResult> = link
            .acks
            .iter()
            .skip(self.acks_from)
            .filter(|(c, _)| *c == self.long.command)
            .map(|(_, r)| *r)
            .collect();
        self.acks_from = link.acks.len();
        for r in answers {
            if r == MavResult::MAV_RESULT_IN_PROGRESS {
                self.in_progress = true;
            } else {
                return (Progress::Answered(r), None);
            }
        }
        if now_us.saturating_sub(self.first_us) > self.timeout_us {
            return (Progress::TimedOut, None);
        }
        let retry = if self.in_progress {
            IN_PROGRESS_RETRY_US
        } else {
            COMMAND_RETRY_US
        };
        if now_us.saturating_sub(self.sent_us) < retry {
            return (Progress::Waiting, None);
        }
        self.long.confirmation = self.long.confirmation.saturating_add(1);
        self.sent_us = now_us;
        let frame = link.command_frame(self.long.clone(), now_us);
        (Progress::Waiting, Some(frame))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn answered(link: &mut GroundLink, command: MavCmd, result: MavResult) {
        link.acks.push((command, result));
    }

    #[test]
    fn retried_until_answered_slower_once_in_progress_and_given_up_at_its_timeout() {
        let mut link = GroundLink::new(None);
        let (mut c, first) = InFlight::send(&mut link, &GroundCommand::Connect, 30_000_000, 0)
            .expect("connect goes over the link");
        assert!(!first.is_empty());
        assert_eq!(
            c.tick(&mut link, COMMAND_RETRY_US - 1),
            (Progress::Waiting, None)
        );
        let (p, retry) = c.tick(&mut link, COMMAND_RETRY_US);
        assert_eq!(p, Progress::Waiting);
        assert!(retry.is_some(), "retried after {COMMAND_RETRY_US} us");
        assert_eq!(c.long.confirmation, 1, "each retry confirms again");
        answered(&mut link, c.command(), MavResult::MAV_RESULT_IN_PROGRESS);
        // Another command's answer is not this one's.
        answered(
            &mut link,
            MavCmd::MAV_CMD_DO_SET_MODE,
            MavResult::MAV_RESULT_DENIED,
        );
        let t = 2 * COMMAND_RETRY_US;
        assert_eq!(
            c.tick(&mut link, t),
            (Progress::Waiting, None),
            "in progress: slower"
        );
        assert_eq!(
            c.tick(&mut link, COMMAND_RETRY_US + IN_PROGRESS_RETRY_US - 1),
            (Progress::Waiting, None)
        );
        assert!(
            c.tick(&mut link, COMMAND_RETRY_US + IN_PROGRESS_RETRY_US)
                .1
                .is_some()
        );
        answered(&mut link, c.command(), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(
            c.tick(&mut link, 3_000_000),
            (Progress::Answered(MavResult::MAV_RESULT_ACCEPTED), None)
        );
        let (mut late, _) = InFlight::send(&mut link, &GroundCommand::Stop, 1_000, 0).unwrap();
        assert_eq!(late.tick(&mut link, 1_000).0, Progress::Waiting);
        assert_eq!(late.tick(&mut link, 1_001), (Progress::TimedOut, None));
    }

    #[test]
    fn an_answer_from_before_it_was_sent_is_not_its_answer() {
        let mut link = GroundLink::new(None);
        answered(
            &mut link,
            MavCmd::MAV_CMD_USER_1,
            MavResult::MAV_RESULT_FAILED,
        );
        let (mut c, _) = InFlight::send(&mut link, &GroundCommand::Connect, 30_000_000, 0).unwrap();
        assert_eq!(c.command(), MavCmd::MAV_CMD_USER_1);
        assert_eq!(c.tick(&mut link, 1).0, Progress::Waiting);
        answered(&mut link, c.command(), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(
            c.tick(&mut link, 2).0,
            Progress::Answered(MavResult::MAV_RESULT_ACCEPTED)
        );
    }
}
