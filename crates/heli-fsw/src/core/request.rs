//! The pilot's take-off request on the skids, as the sequencer acts on it
//! (`preflight::Request`): the take-off or the check that holds it back, a wait that runs
//! out while the transmitter is lost, and the refusal raised.

use heli_nav::NavState;

use super::event::CoreEvent;
use super::preflight::{Refusal, Request};
use super::sequencer::{Crew, Sequencer};
use super::{Action, Stamped};
use crate::phase::Phase;

impl Sequencer {
    /// On the skids, the auto switch on and nothing flown yet: the take-off, or the check
    /// that holds it back. A standing refusal stands (a restart's switch left on is refused
    /// first, said once); the checks failing, the wait goes on from the pilot's request; they
    /// pass, it takes off.
    pub(super) fn on_the_skids(
        &mut self,
        crew: &Crew<'_>,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Phase {
        self.leg = 0;
        if self.takeoff == Request::AfterRestart {
            self.refuse(Refusal::Restarted, now_us, out);
        }
        if self.takeoff.refused() {
            return Phase::TakeoffRefused;
        }
        if self.preflight(crew, now_us).is_some() {
            let since_us = self.takeoff.wait_since(now_us);
            return Phase::PreflightCheck { since_us };
        }
        self.takeoff = Request::None;
        self.start_leg(est, now_us, out)
    }

    /// On the skids with the transmitter lost: a wait that runs out meanwhile is refused
    /// then, said with the check that fails (or the loss itself), so that the transmitter's
    /// return, however late, is no order to take off.
    pub(super) fn skids_without_transmitter(
        &mut self,
        crew: &Crew<'_>,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        if self.takeoff.expired(now_us) {
            let refusal = self
                .preflight(crew, now_us)
                .unwrap_or(Refusal::TransmitterLost);
            self.refuse(refusal, now_us, out);
        }
    }

    /// Refuses the pilot's request: raised, and it stands.
    pub(super) fn refuse(&mut self, refusal: Refusal, now_us: u64, out: &mut Vec<Action>) {
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::TakeoffRefused(refusal),
        )));
        self.takeoff = Request::Refused;
    }
}
