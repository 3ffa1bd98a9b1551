//! The safety rule on board: the flight core judges the thesis §4.3 conditions it observes
//! itself (`heli_control::safety`) before it enters an augmented or automatic mode at the
//! pilot's switch, and refuses, raising why, when the rule does not allow it. The same rule
//! is what the ground display shows.
//!
//! - The check is made when a mode is *entered*; a mode already flown is left by the
//!   failsafes, not by this check.
//! - A transmitter loss is no request: the hover failsafe is never refused.
//! - An autonomous take-off from the ground is judged by the pre-flight check
//!   (`preflight`), which waits up to 30 s for the conditions before refusing.
//! - In the air, a refusal stands until the pilot takes the auto switch off: a mode that
//!   flickers on and off as a satellite comes and goes is worse than none. On the ground the
//!   mode is entered as soon as the rule allows it.
//! - The battery is judged from its readings (once a second, through the safety rule's
//!   discharge curve), the ground link from what the bootstrap says of it. Until the first
//!   reading, and on a vehicle with no link, each is passed as "not judged here".

use heli_control::safety::{AUGMENTED, AUTOMATIC, Condition, Facts, Rule, Verdict};

use super::*;

/// A mode the pilot's switch asked for and the rule refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeRefusal {
    /// The mode asked for.
    pub mode: FlightMode,
    /// What failed.
    pub verdict: Verdict,
}

impl ModeRefusal {
    /// What it says on the ground display.
    pub fn text(&self) -> String {
        format!("{} flight refused: {}", self.mode.name(), self.verdict)
    }
}

/// The rule a mode needs, if any.
pub fn rule_for(mode: FlightMode) -> Option<Rule> {
    match mode {
        FlightMode::Manual => None,
        FlightMode::Autonomous => Some(AUTOMATIC),
        FlightMode::Augmented(_) => Some(AUGMENTED),
    }
}

impl FlightCore {
    /// What the flight core observes of the safety rule's conditions now.
    pub fn safety_facts(&self) -> Facts {
        let ok = |d| self.health.state(d) == HealthState::Ok;
        let satellites = self
            .last_good_fix
            .is_some_and(|(_, fix)| fix.satellites >= preflight::MIN_SATELLITES);
        let facts = Facts::none()
            .with(
                Condition::Calibrated,
                self.estimate_valid && self.phase != Phase::Calibrating,
            )
            .with(Condition::Imu, ok(Device::Imu))
            .with(Condition::Uplink, ok(Device::Uplink) && !self.uplink_lost)
            .with(Condition::Gps, ok(Device::Gps))
            .with(Condition::Satellites, satellites)
            .with(Condition::Altimeter, ok(Device::Baro))
            .with(Condition::Compass, ok(Device::Compass))
            .with(Condition::Bypass, self.pilot.is_some_and(|p| p.bypass));
        // Judged once a battery has been read: every battery read above its warning level.
        let facts = if self.power.any_read() {
            facts.with(
                Condition::Battery,
                self.power.worst() == heli_power::Level::Good,
            )
        } else {
            facts
        };
        match self.ground_link {
            Some(fresh) => facts.with(Condition::Link, fresh),
            None => facts,
        }
    }

    /// The refusal standing in the air, if any.
    pub fn mode_refusal(&self) -> Option<ModeRefusal> {
        self.refused_in_air
    }

    /// Raises `refusal` unless what fails was already raised while the switch has been on:
    /// a condition that comes and goes raises one event, a new reason raises another.
    pub(super) fn raise_refusal(
        &mut self,
        refusal: ModeRefusal,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        let v = refusal.verdict;
        let known = self.refusal_raised.is_some_and(|r| {
            r.mode == refusal.mode
                && r.verdict.wanted_true.contains_all(v.wanted_true)
                && r.verdict.wanted_false.contains_all(v.wanted_false)
        });
        if known {
            return;
        }
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::ModeRefused(refusal),
        )));
        let mut raised = refusal;
        if let Some(r) = self.refusal_raised.filter(|r| r.mode == refusal.mode) {
            raised.verdict.wanted_true = r.verdict.wanted_true.union(v.wanted_true);
            raised.verdict.wanted_false = r.verdict.wanted_false.union(v.wanted_false);
        }
        self.refusal_raised = Some(raised);
    }

    /// While calibrating with the auto switch on: the mode asked for is refused, raised once.
    pub(super) fn refuse_while_calibrating(&mut self, now_us: u64, out: &mut Vec<Action>) {
        let asked = self
            .pilot
            .is_some_and(|p| p.auto_mode && !p.signal_lost() && !p.bypass);
        if !asked {
            self.clear_refusal();
            return;
        }
        let Some(rule) = rule_for(self.params.mode) else {
            return;
        };
        // Raised once while the switch stays on: the devices coming up one by one during
        // the calibration would otherwise raise a new verdict each.
        if self.refusal_raised.is_some() {
            return;
        }
        let verdict = rule.judge(self.safety_facts());
        if !verdict.allowed {
            let refusal = ModeRefusal {
                mode: self.params.mode,
                verdict,
            };
            self.raise_refusal(refusal, now_us, out);
        }
    }

    /// Whether the mode the pilot's switch asks for is refused now (`on_ground`: judged
    /// afresh each step; in the air a refusal stands until the switch goes off, whatever
    /// happens meanwhile: a failsafe hover that ends with the switch still on does not let
    /// the refused mode in).
    pub(super) fn refuse_mode(
        &mut self,
        on_ground: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> bool {
        let mode = self.params.mode;
        let Some(rule) = rule_for(mode) else {
            return false;
        };
        if self.refused_in_air.is_some() {
            return true;
        }
        let entering = matches!(
            self.phase,
            Phase::Manual | Phase::Calibrating | Phase::GroundFailsafe | Phase::BlindDescent
        );
        // A mode already flown is left by the failsafes, not here; an autonomous take-off
        // is the pre-flight check's to judge (it waits for the GPS).
        if !entering || (on_ground && mode == FlightMode::Autonomous) {
            return false;
        }
        // Called with an estimate: the calibration is done.
        let verdict = rule.judge(self.safety_facts().with(Condition::Calibrated, true));
        if verdict.allowed {
            return false;
        }
        let refusal = ModeRefusal { mode, verdict };
        self.raise_refusal(refusal, now_us, out);
        if !on_ground {
            self.refused_in_air = Some(refusal);
        }
        true
    }

    /// The pilot took the auto switch off: a standing refusal is over, and the next request
    /// is judged and raised afresh.
    pub(super) fn clear_refusal(&mut self) {
        self.refused_in_air = None;
        self.refusal_raised = None;
    }

    /// The automatic rule's verdict for a take-off (used by the pre-flight check).
    pub(super) fn automatic_verdict(&self) -> Verdict {
        AUTOMATIC.judge(self.safety_facts().with(Condition::Calibrated, true))
    }
}
