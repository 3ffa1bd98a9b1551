//! What the flight software is doing: the phases of a flight, and the stages of the roll
//! maneuver. The phase is part of every state record (`crate::streams`).

use heli_control::Target;
use heli_types::AugmentedMode;
use nalgebra::Vector3;

/// What the flight software is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Warming up and calibrating the IMU biases; servos follow the pilot.
    Calibrating,
    /// The pilot flies (auto switch off, or manual mode), with computer yaw damping.
    Manual,
    /// The transmitter was lost while the helicopter was on the ground: cyclic neutral,
    /// collective flat, throttle closed, until the pilot's signal returns.
    GroundFailsafe,
    /// The pilot asked for an autonomous take-off; on the skids, rotor governed, waiting up
    /// to [`crate::core::preflight::CHECK_WAIT_S`] for the pre-flight checks to pass.
    PreflightCheck {
        /// Since when it has waited (µs).
        since_us: u64,
    },
    /// The pilot asked for an autonomous take-off that the pre-flight checks refused (no
    /// recent GPS fix, too few satellites, an IMU that is not healthy): on the skids with the
    /// rotor governed and the collective flat, until the auto switch goes off.
    TakeoffRefused,
    /// The IMU went silent and the estimate was declared invalid while no pilot was there to
    /// fly: the blind failsafe — cyclic and tail neutral, collective a little under hover for
    /// a slow descent, rotor governed — until the pilot's signal returns.
    BlindDescent,
    /// Autonomous climb to the target.
    TakingOff {
        /// Where the climb ends.
        target: Target,
    },
    /// Autonomous position hold.
    Holding {
        /// Where the helicopter is held.
        target: Target,
        /// When the hold began (µs).
        since_us: u64,
    },
    /// Velocity tracking along a straight path: the target moves toward `to_ned_m`.
    Flying {
        /// The moving target.
        target: Target,
        /// The end of the path (m, NED).
        to_ned_m: Vector3<f64>,
    },
    /// The aileron-roll maneuver.
    Maneuver {
        /// The trim trajectory (moving target) used outside the rolls themselves.
        target: Target,
        /// Where in the maneuver.
        stage: RollStage,
        /// Rolls completed in this maneuver.
        rolls_done: u32,
    },
    /// Vertical descent to the ground.
    Landing {
        /// The descending target.
        target: Target,
        /// Since when the helicopter has stopped following the target down (µs).
        settled_since_us: Option<u64>,
    },
    /// The engine failed in the air: autorotation to the ground (`core::engine`).
    Autorotation {
        /// Since when the helicopter has been down and not sinking (µs).
        settled_since_us: Option<u64>,
    },
    /// On the skids after an autonomous landing.
    Landed,
    /// The pilot flies through an augmentation system.
    Augmented(AugmentedMode),
}

impl Phase {
    /// The target of an autonomous phase.
    pub fn target(&self) -> Option<Target> {
        match self {
            Phase::TakingOff { target }
            | Phase::Holding { target, .. }
            | Phase::Flying { target, .. }
            | Phase::Maneuver { target, .. }
            | Phase::Landing { target, .. } => Some(*target),
            Phase::Calibrating
            | Phase::Manual
            | Phase::GroundFailsafe
            | Phase::BlindDescent
            | Phase::Autorotation { .. }
            | Phase::TakeoffRefused
            | Phase::PreflightCheck { .. }
            | Phase::Landed
            | Phase::Augmented(_) => None,
        }
    }

    /// True in the roll itself (not its run-up, pull-up or recovery): where the helicopter
    /// may be on its side or inverted.
    pub fn rolling(&self) -> bool {
        matches!(
            self,
            Phase::Maneuver {
                stage: RollStage::Rolling { .. },
                ..
            }
        )
    }

    /// Short name for displays and logs.
    pub fn name(&self) -> &'static str {
        match self {
            Phase::Calibrating => "calibrating",
            Phase::Manual => "manual",
            Phase::GroundFailsafe => "ground-failsafe",
            Phase::BlindDescent => "blind-descent",
            Phase::TakeoffRefused => "takeoff-refused",
            Phase::PreflightCheck { .. } => "preflight-check",
            Phase::TakingOff { .. } => "takeoff",
            Phase::Holding { .. } => "hold",
            Phase::Flying { .. } => "fly",
            Phase::Maneuver { stage, .. } => stage.name(),
            Phase::Landing { .. } => "land",
            Phase::Autorotation { .. } => "autorotation",
            Phase::Landed => "landed",
            Phase::Augmented(AugmentedMode::Rate) => "augmented-rate",
            Phase::Augmented(AugmentedMode::Attitude) => "augmented-attitude",
            Phase::Augmented(AugmentedMode::Velocity) => "augmented-velocity",
        }
    }

    /// A hold that follows flight along a trajectory (a path, the roll manoeuvre) from
    /// `previous`: the hover controller unlearns that flight's drag
    /// (`heli_control::HoverController::enter_hold`).
    pub(crate) fn is_hold_after_flight(&self, previous: &Phase) -> bool {
        matches!(self, Phase::Holding { .. })
            && matches!(previous, Phase::Flying { .. } | Phase::Maneuver { .. })
    }

    /// Same kind of phase (a moving target or a turning roll does not count as a change).
    pub(crate) fn same_kind(&self, other: &Phase) -> bool {
        match (self, other) {
            (Phase::Maneuver { stage: a, .. }, Phase::Maneuver { stage: b, .. }) => {
                core::mem::discriminant(a) == core::mem::discriminant(b)
            }
            _ => core::mem::discriminant(self) == core::mem::discriminant(other),
        }
    }
}

/// Where a roll maneuver is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RollStage {
    /// Accelerating to the trim speed along the heading, since `since_us`.
    Accelerate {
        /// Stage start (µs).
        since_us: u64,
    },
    /// Climbing into the roll.
    PullUp {
        /// Stage start (µs).
        since_us: u64,
    },
    /// Rolling; `angle_rad` turned so far.
    Rolling {
        /// Roll angle turned (rad).
        angle_rad: f64,
        /// Stage start (µs).
        since_us: u64,
    },
    /// Back on the trim trajectory.
    Recover {
        /// Stage start (µs).
        since_us: u64,
    },
}

impl RollStage {
    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            RollStage::Accelerate { .. } => "accelerate",
            RollStage::PullUp { .. } => "pull-up",
            RollStage::Rolling { .. } => "rolling",
            RollStage::Recover { .. } => "recover",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_hold_after_a_path_or_the_manoeuvre_is_a_hold_after_flight() {
        let target = Target::hold(Vector3::new(1.0, 2.0, -10.0), 0.0);
        let hold = Phase::Holding {
            target,
            since_us: 0,
        };
        let flying = Phase::Flying {
            target,
            to_ned_m: Vector3::zeros(),
        };
        let rolls = Phase::Maneuver {
            target,
            stage: RollStage::Recover { since_us: 0 },
            rolls_done: 1,
        };
        assert!(hold.is_hold_after_flight(&flying));
        assert!(hold.is_hold_after_flight(&rolls));
        // Not the other way round, nor from a climb, a hold, the pilot's hands.
        assert!(!flying.is_hold_after_flight(&hold));
        assert!(!rolls.is_hold_after_flight(&hold));
        for before in [
            Phase::TakingOff { target },
            hold,
            Phase::Manual,
            Phase::Augmented(AugmentedMode::Velocity),
        ] {
            assert!(!hold.is_hold_after_flight(&before), "{before:?}");
        }
        let landing = Phase::Landing {
            target,
            settled_since_us: None,
        };
        assert!(!landing.is_hold_after_flight(&flying));
    }
}
