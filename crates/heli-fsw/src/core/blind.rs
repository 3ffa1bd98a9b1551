//! The mission sequencer without an estimate: calibrating, aligning after a restart in the
//! air, or after the estimate was declared invalid (an IMU stall). A roll under way is
//! finished blind first; then the pilot flies if one is flying, the blind failsafe holds in
//! the air, and on the ground everything idles — a take-off waiting on its pre-flight check
//! is refused, a refusal stands (`preflight::Request`).

use heli_types::FlightMode;

use super::event::CoreEvent;
use super::preflight;
use super::roll::{self, BlindRoll};
use super::sequencer::{Crew, Sequencer};
use super::{Action, Stamped};
use crate::phase::{Phase, RollStage};

impl Sequencer {
    /// The phase of a control step with no estimate, as [`Sequencer::next_phase`].
    pub(super) fn without_estimate(
        &mut self,
        crew: &mut Crew<'_>,
        now_us: u64,
        dt_s: f64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let pilot = crew.devices.pilot();
        let signal_lost = crew.devices.signal_lost();
        // A roll under way when the estimate went is finished before anything else.
        if let Phase::Maneuver {
            target,
            stage: stage @ RollStage::Rolling { .. },
            rolls_done,
        } = self.phase
        {
            let finished = match roll::blind_step(
                &crew.config.roll,
                stage,
                crew.roll_rate_rps,
                now_us,
                dt_s,
            ) {
                BlindRoll::Rolling(stage) => {
                    return Phase::Maneuver {
                        target,
                        stage,
                        rolls_done,
                    };
                }
                BlindRoll::Stopped => false,
                BlindRoll::Finished => true,
            };
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::RollEndedBlind { finished },
            )));
        }
        if crew.aligning {
            // Restarted in the air and aligning: the pilot flies if the switch is off,
            // otherwise the blind failsafe holds on until the estimate starts.
            let pilot_flies = !signal_lost && pilot.is_some_and(|p| !p.auto_mode || p.bypass);
            return if pilot_flies {
                Phase::Manual
            } else {
                Phase::BlindDescent
            };
        }
        if crew.estimate_valid {
            // The switch seen off while calibrating after a restart: the next one on is
            // the pilot's request.
            if !signal_lost && pilot.is_some_and(|p| !p.auto_mode) {
                self.takeoff = preflight::Request::None;
            }
            self.refuse_while_calibrating(crew, now_us, out);
            return Phase::Calibrating;
        }
        // The estimate is gone: the pilot flies if one is flying (the switch off, the
        // bypass, or a flight the pilot flies through the augmentation or by hand);
        // otherwise the blind failsafe in the air, the safest thing left without
        // attitude, and idle on a helicopter that never left the ground. A pilot who
        // left the helicopter to the computer is not handed it unawares.
        let pilot_flies = !signal_lost
            && pilot.is_some_and(|p| {
                !p.auto_mode || p.bypass || self.params.mode != FlightMode::Autonomous
            });
        if pilot_flies {
            self.takeoff = preflight::Request::None;
            return Phase::Manual;
        }
        // A pre-flight check under way is refused; a refusal stands (`preflight`).
        if let Some(refusal) = self.takeoff.estimate_lost() {
            let refused = CoreEvent::TakeoffRefused(refusal);
            out.push(Action::Event(Stamped::new(now_us, refused)));
        }
        // Landed already, it stays on its skids: no blind descent on the ground.
        if self.phase == Phase::Landed {
            Phase::Landed
        } else if self.airborne_once {
            Phase::BlindDescent
        } else if self.takeoff.refused() && !signal_lost {
            Phase::TakeoffRefused
        } else {
            Phase::GroundFailsafe
        }
    }
}
