//! The stages of the roll maneuver, as the flight core flies a plan's `rolls` leg. (The plan
//! itself, its legs and their validation are the shared vocabulary of `heli-types`.)

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
