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

//!
//! A component: it owns the refusal standing in the air and what was raised while the
//! switch has been on; the core hands it the facts ([`safety_facts`], from the devices,
//! the aids, the loop and the batteries) and what the pilot asks.

use heli_control::safety::{AUGMENTED, AUTOMATIC, Condition, Facts, Rule, Verdict};
use heli_types::{Device, FlightMode};

use super::aids::Aiding;
use super::devices::DeviceWatch;
use super::event::CoreEvent;
use super::power::Power;
use super::preflight::MIN_SATELLITES;
use super::{Action, Stamped};
use crate::phase::Phase;

pub use super::event::ModeRefusal;

/// The rule a mode needs, if any.
pub fn rule_for(mode: FlightMode) -> Option<Rule> {
    match mode {
        FlightMode::Manual => None,
        FlightMode::Autonomous => Some(AUTOMATIC),
        FlightMode::Augmented(_) => Some(AUGMENTED),
    }
}

/// The conditions of the safety rule the core observes: calibrated (the estimate valid and
/// the calibration over), each device on time, the transmitter heard, five satellites in
/// the last good fix, the bypass switch; the batteries once one has been read (every one
/// above its warning level); the ground link on a vehicle with one.
pub fn safety_facts(
    phase: Phase,
    estimate_valid: bool,
    devices: &DeviceWatch,
    aiding: &Aiding,
    power: &Power,
) -> Facts {
    let ok = |d| devices.ok(d);
    let satellites = aiding
        .last_good_fix()
        .is_some_and(|(_, fix)| fix.satellites >= MIN_SATELLITES);
    let facts = Facts::none()
        .with(
            Condition::Calibrated,
            estimate_valid && phase != Phase::Calibrating,
        )
        .with(Condition::Imu, ok(Device::Imu))
        .with(
            Condition::Uplink,
            ok(Device::Uplink) && !devices.uplink_lost(),
        )
        .with(Condition::Gps, ok(Device::Gps))
        .with(Condition::Satellites, satellites)
        .with(Condition::Altimeter, ok(Device::Baro))
        .with(Condition::Compass, ok(Device::Compass))
        .with(Condition::Bypass, devices.pilot().is_some_and(|p| p.bypass));
    // Judged once a battery has been read: every battery read above its warning level.
    let facts = if power.any_read() {
        facts.with(Condition::Battery, power.worst() == heli_power::Level::Good)
    } else {
        facts
    };
    match devices.ground_heard() {
        Some(fresh) => facts.with(Condition::Link, fresh),
        None => facts,
    }
}

/// The verdict on automatic flight, the calibration taken as done.
pub fn automatic_verdict(facts: Facts) -> Verdict {
    AUTOMATIC.judge(facts.with(Condition::Calibrated, true))
}

/// The mode check.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModeCheck {
    /// A refusal standing in the air until the pilot's switch goes off.
    pub(super) refused_in_air: Option<ModeRefusal>,
    /// What was raised while the switch has been on (the failing conditions so far).
    pub(super) refusal_raised: Option<ModeRefusal>,
    /// Whether that was raised during the calibration: the end of the calibration, where
    /// the mode would be entered, raises the verdict again with what still fails.
    pub(super) raised_calibrating: bool,
}

impl ModeCheck {
    /// The refusal standing in the air, if any.
    pub fn refused_in_air(&self) -> Option<ModeRefusal> {
        self.refused_in_air
    }

    /// Raises `refusal` unless the same conditions were raised while the switch has been on;
    /// a new failing condition is raised with the ones before.
    pub fn raise(&mut self, refusal: ModeRefusal, now_us: u64, out: &mut Vec<Action>) {
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

    /// While calibrating, with the switch asking for `mode` (`asked`): the rule's verdict on
    /// `facts` raised once, so that the pilot knows before the calibration ends. The switch
    /// off forgets it.
    pub fn while_calibrating(
        &mut self,
        asked: bool,
        mode: FlightMode,
        facts: impl FnOnce() -> Facts,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        if !asked {
            self.clear();
            return;
        }
        let Some(rule) = rule_for(mode) else {
            return;
        };
        // Raised once while the switch stays on: the devices coming up one by one during
        // the calibration would otherwise raise a new verdict each.
        if self.refusal_raised.is_some() {
            return;
        }
        let verdict = rule.judge(facts());
        if !verdict.allowed {
            let refusal = ModeRefusal { mode, verdict };
            self.raise(refusal, now_us, out);
            self.raised_calibrating = true;
        }
    }

    /// Whether entering `mode` from `phase` is refused on `facts` (raised when it is); in
    /// the air the refusal stands until the switch goes off.
    pub fn refuse(
        &mut self,
        mode: FlightMode,
        phase: Phase,
        on_ground: bool,
        facts: impl FnOnce() -> Facts,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> bool {
        let Some(rule) = rule_for(mode) else {
            return false;
        };
        if self.refused_in_air.is_some() {
            return true;
        }
        let entering = matches!(
            phase,
            Phase::Manual | Phase::Calibrating | Phase::GroundFailsafe | Phase::BlindDescent
        );
        // A mode already flown is left by the failsafes, not here; an autonomous take-off
        // is the pre-flight check's to judge (it waits for the GPS).
        if !entering || (on_ground && mode == FlightMode::Autonomous) {
            return false;
        }
        // Called with an estimate: the calibration is done.
        let verdict = rule.judge(facts().with(Condition::Calibrated, true));
        if verdict.allowed {
            return false;
        }
        // The calibration's verdict named what was missing then; the pilot about to lift
        // off is told what is missing now.
        if std::mem::take(&mut self.raised_calibrating) {
            self.refusal_raised = None;
        }
        let refusal = ModeRefusal { mode, verdict };
        self.raise(refusal, now_us, out);
        if !on_ground {
            self.refused_in_air = Some(refusal);
        }
        true
    }

    /// The switch went off: nothing is refused, nothing raised stands.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}
