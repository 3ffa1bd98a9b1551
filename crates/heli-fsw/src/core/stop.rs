//! The operator's Stop (thesis §2.3.1: Stop ends the flight, on the ground). On the ground
//! the flight ends at once. In the air a Stop never drops the helicopter: when the computer
//! flies it, it lands where it is first and the flight ends on the skids; when the pilot
//! flies it (manual, augmented) or nothing knows where the ground is (the blind failsafe),
//! the Stop is refused with the reason — land, then Stop. Only the separate, confirmed kill
//! (the runtime's, never the core's) ends a flight in the air.
//!
//! The request is an input ([`super::Input::StopRequested`]), recorded like the others, so a
//! replayed flight answers it the same way; the answer is an event
//! ([`super::CoreEvent::Stop`]) the runtime acts on.

use crate::phase::Phase;

/// Below this height above the take-off point (m) ...
pub const ON_GROUND_HEIGHT_M: f64 = 0.5;
/// ... and slower than this (m/s), a helicopter the pilot flies is on the ground.
pub const ON_GROUND_SPEED_MPS: f64 = 0.5;

/// The flight computer's answer to a Stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopAnswer {
    /// On the ground: the flight ends now.
    Now,
    /// In the air under the computer: landing where it is first; [`StopAnswer::Now`]
    /// follows on the skids.
    Landing,
    /// Refused: the flight goes on.
    Refused(StopRefusal),
    /// A Stop's landing was given up, for the reason a Stop would now be refused (the
    /// pilot took the helicopter, or the estimate was lost and it descends blind): the
    /// flight goes on.
    Cancelled(StopRefusal),
}

/// Why a Stop in the air is refused (or a Stop's landing given up).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopRefusal {
    /// The pilot flies (manual or augmented): the pilot lands.
    PilotFlying,
    /// Descending on the blind failsafe: no estimate says when it is down.
    Blind,
}

impl StopRefusal {
    /// What the operator reads, with what to do.
    pub fn text(self) -> &'static str {
        match self {
            StopRefusal::PilotFlying => {
                "in the air under the pilot's control: land, then Stop (a kill ends the flight process in the air)"
            }
            StopRefusal::Blind => {
                "descending blind (no estimate): Stop once it is down (a kill ends the flight process in the air)"
            }
        }
    }
}

/// The answer to a Stop in `phase`; `settled`: a valid estimate puts the helicopter within
/// [`ON_GROUND_HEIGHT_M`] of the take-off point and slower than [`ON_GROUND_SPEED_MPS`].
pub fn answer(phase: Phase, airborne_once: bool, settled: bool) -> StopAnswer {
    match phase {
        Phase::Calibrating
        | Phase::PreflightCheck { .. }
        | Phase::TakeoffRefused
        | Phase::GroundFailsafe
        | Phase::Landed => StopAnswer::Now,
        Phase::TakingOff { .. }
        | Phase::Holding { .. }
        | Phase::Flying { .. }
        | Phase::Maneuver { .. }
        | Phase::Landing { .. }
        | Phase::Autorotation { .. } => StopAnswer::Landing,
        Phase::BlindDescent if airborne_once => StopAnswer::Refused(StopRefusal::Blind),
        Phase::Manual | Phase::Augmented(_) if airborne_once && !settled => {
            StopAnswer::Refused(StopRefusal::PilotFlying)
        }
        Phase::BlindDescent | Phase::Manual | Phase::Augmented(_) => StopAnswer::Now,
    }
}

/// Whether a helicopter `height_m` above the take-off point, moving at `speed_mps` (by a
/// valid estimate), is on the ground.
pub fn settled(height_m: f64, speed_mps: f64) -> bool {
    height_m < ON_GROUND_HEIGHT_M && speed_mps < ON_GROUND_SPEED_MPS
}

/// What a Stop's landing under way comes to in `phase`: `Some(Now)` down, `Some(Cancelled)`
/// the pilot or the blind failsafe took over (which of them), `None` still on its way down.
pub fn landing_outcome(phase: Phase) -> Option<StopAnswer> {
    match phase {
        Phase::Landed
        | Phase::GroundFailsafe
        | Phase::Calibrating
        | Phase::PreflightCheck { .. }
        | Phase::TakeoffRefused => Some(StopAnswer::Now),
        Phase::Manual | Phase::Augmented(_) => {
            Some(StopAnswer::Cancelled(StopRefusal::PilotFlying))
        }
        Phase::BlindDescent => Some(StopAnswer::Cancelled(StopRefusal::Blind)),
        Phase::TakingOff { .. }
        | Phase::Holding { .. }
        | Phase::Flying { .. }
        | Phase::Maneuver { .. }
        | Phase::Landing { .. }
        | Phase::Autorotation { .. } => None,
    }
}
