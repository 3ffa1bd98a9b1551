//! What a flight and its supervisor (the bootstrap) know of each other, and what the control
//! loop does when the supervisor goes or comes back.
//!
//! Only an explicit Stop, or being on the ground, ends a flight: when the bootstrap's line
//! ends without a Stop (the bootstrap was killed or crashed), a helicopter in the air flies
//! on — the init system restarts the bootstrap, which takes the flight back (`crate::adopt`)
//! — and a flight still without a bootstrap ends when it has landed. Each change is an event,
//! raised and written into the log.

use std::sync::atomic::{AtomicBool, Ordering};

use heli_fsw::core::Severity;

/// Shared by the control loop and the thread that reads the bootstrap's lines.
#[derive(Debug, Default)]
pub struct Supervision {
    /// Set by the control loop while the helicopter may be in the air (it has taken off and
    /// not landed).
    pub in_air: AtomicBool,
    /// Set when the bootstrap's line ended without a Stop; cleared when a bootstrap takes
    /// the flight back.
    pub line_ended: AtomicBool,
    /// Set when the bootstrap asked to stop; the control loop takes it and gives it to the
    /// flight computer, which answers (`heli_fsw::core::stop`).
    pub stop_requested: AtomicBool,
}

/// What the control loop does about its supervision at one turn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Verdict {
    /// The event to raise and log, if the supervision changed.
    pub event: Option<&'static str>,
    /// How much it matters: a flight without its supervisor is a warning, one taken back
    /// is news.
    pub severity: Severity,
    /// End the flight now.
    pub end: bool,
}

/// Raised when the bootstrap goes while the helicopter flies.
pub const GONE_IN_AIR: &str = "the bootstrap's line ended without a Stop (the bootstrap is gone) \
     in the air: flying on; the flight ends when it has landed";
/// Raised when the bootstrap goes while the helicopter is on the ground.
pub const GONE_ON_GROUND: &str = "the bootstrap's line ended without a Stop (the bootstrap is \
     gone) on the ground: ending the flight";
/// Raised when a flight without a bootstrap has landed.
pub const LANDED_ALONE: &str = "landed without a bootstrap: ending the flight";
/// Raised when a bootstrap started again took the flight back.
pub const TAKEN_BACK: &str = "a bootstrap took the flight back: supervised again";

impl Supervision {
    /// The verdict at one turn of the control loop; `orphaned` (whether the flight has been
    /// told it flies without a bootstrap) is kept by the loop and updated here.
    pub fn check(&self, orphaned: &mut bool) -> Verdict {
        let line_ended = self.line_ended.load(Ordering::Acquire);
        let in_air = self.in_air.load(Ordering::Acquire);
        let was = std::mem::replace(orphaned, line_ended);
        let event = match (was, line_ended, in_air) {
            (false, true, true) => Some(GONE_IN_AIR),
            (false, true, false) => Some(GONE_ON_GROUND),
            (true, true, false) => Some(LANDED_ALONE),
            (true, false, _) => Some(TAKEN_BACK),
            (true, true, true) | (false, false, _) => None,
        };
        let severity = if event == Some(TAKEN_BACK) {
            Severity::ActivityHi
        } else {
            Severity::WarningHi
        };
        Verdict {
            event,
            severity,
            end: line_ended && !in_air,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn turn(s: &Supervision, orphaned: &mut bool, ended: bool, in_air: bool) -> Verdict {
        s.line_ended.store(ended, Ordering::Release);
        s.in_air.store(in_air, Ordering::Release);
        s.check(orphaned)
    }

    const GO_ON: Verdict = Verdict {
        event: None,
        severity: Severity::WarningHi,
        end: false,
    };

    #[test]
    fn a_supervised_flight_goes_on() {
        let s = Supervision::default();
        let mut orphaned = false;
        assert_eq!(turn(&s, &mut orphaned, false, false), GO_ON);
        assert_eq!(turn(&s, &mut orphaned, false, true), GO_ON);
        assert!(!orphaned);
    }

    #[test]
    fn without_a_bootstrap_the_helicopter_flies_on_until_it_has_landed() {
        let s = Supervision::default();
        let mut orphaned = false;
        let gone = turn(&s, &mut orphaned, true, true);
        assert_eq!(gone.event, Some(GONE_IN_AIR));
        assert_eq!(gone.severity, Severity::WarningHi);
        assert!(!gone.end && orphaned);
        // Said once.
        assert_eq!(turn(&s, &mut orphaned, true, true), GO_ON);
        let landed = turn(&s, &mut orphaned, true, false);
        assert_eq!(landed.event, Some(LANDED_ALONE));
        assert!(landed.end);
    }

    #[test]
    fn without_a_bootstrap_on_the_ground_the_flight_ends_at_once() {
        let s = Supervision::default();
        let mut orphaned = false;
        let v = turn(&s, &mut orphaned, true, false);
        assert_eq!(v.event, Some(GONE_ON_GROUND));
        assert!(v.end);
    }

    #[test]
    fn a_bootstrap_that_takes_the_flight_back_ends_the_orphaned_time() {
        let s = Supervision::default();
        let mut orphaned = false;
        turn(&s, &mut orphaned, true, true);
        let back = turn(&s, &mut orphaned, false, true);
        assert_eq!(back.event, Some(TAKEN_BACK));
        assert_eq!(back.severity, Severity::ActivityHi);
        assert!(!back.end && !orphaned);
        // Supervised again: landing no longer ends the flight.
        assert_eq!(turn(&s, &mut orphaned, false, false), GO_ON);
        // And a second loss is said again.
        assert_eq!(turn(&s, &mut orphaned, true, true).event, Some(GONE_IN_AIR));
    }
}
