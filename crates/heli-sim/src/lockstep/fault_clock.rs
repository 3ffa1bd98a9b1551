//! The scenario's faults timed from a phase of the flight (`faults.timed_from`,
//! `heli_scenario::fault_timing`): held back until the flight software first enters that
//! phase, then acting at their times counted from that moment.

use heli_scenario::fault_timing::NOT_YET_S;
use heli_scenario::faults::Faults;

use super::Simulation;

/// The faults waiting for their phase, and when it began.
#[derive(Clone, Debug, Default)]
pub(super) struct FaultClock {
    /// The scenario's faults as written (times from the phase), until the phase begins.
    waiting: Option<Faults>,
    /// When the phase began (µs).
    pub(super) began_us: Option<u64>,
}

impl FaultClock {
    /// Takes `faults` timed from a phase and leaves in their place the same faults moved
    /// past any run's end; faults timed from the start are left as they are.
    pub(super) fn hold(faults: &mut Faults) -> Self {
        if faults.timed_from.is_none() {
            return Self::default();
        }
        let waiting = faults.clone();
        *faults = waiting.shifted(NOT_YET_S);
        Self {
            waiting: Some(waiting),
            began_us: None,
        }
    }
}

impl Simulation {
    /// After a control step: when the flight software has just entered the faults' phase
    /// for the first time, their times count from now.
    pub(super) fn time_faults_from_phase(&mut self) {
        let Some(waiting) = &self.fault_clock.waiting else {
            return;
        };
        let phase = self.computer.core().phase().name();
        if waiting.timed_from.as_deref() == Some(phase) {
            self.scenario.faults = waiting.shifted(self.now_us as f64 * 1e-6);
            self.fault_clock.waiting = None;
            self.fault_clock.began_us = Some(self.now_us);
        }
    }
}
