//! The autonomous flight plan: a short list of legs the ground sends with "Start Logging" —
//! take off, hold, fly to a point, roll, land — and the stages of the roll maneuver.
//! Fixed size and `Copy`, so the core never allocates for it.

/// One leg of a flight plan. Positions are relative to the take-off point ("home"), in metres
/// north and east, altitude above it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Leg {
    /// Climb vertically to `alt_m` above home.
    Takeoff {
        /// Height above home (m).
        alt_m: f64,
    },
    /// Hold position where the previous leg ended.
    Hold {
        /// How long (s); infinite holds until the plan is changed.
        seconds: f64,
    },
    /// Fly a straight path to a point at a speed (velocity tracking along the path).
    Fly {
        /// Destination north of home (m).
        north_m: f64,
        /// Destination east of home (m).
        east_m: f64,
        /// Destination height above home (m).
        alt_m: f64,
        /// Path speed (m/s).
        speed_mps: f64,
    },
    /// Accelerate along the current heading to `speed_mps`, then fly `count` aileron rolls,
    /// each from a pull-up and back to the forward-flight trim.
    Rolls {
        /// Number of rolls (at most 10).
        count: u32,
        /// Trim speed the rolls start from and return to (m/s).
        speed_mps: f64,
    },
    /// Descend vertically where the helicopter is and settle on the skids.
    Land,
}

/// Most legs in a plan.
pub const MAX_LEGS: usize = 12;

/// Why the ground's plan was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanError {
    /// More than [`MAX_LEGS`] legs.
    TooManyLegs,
    /// A leg's number is out of range or not finite; the text names it.
    BadValue(&'static str),
}

impl core::fmt::Display for PlanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PlanError::TooManyLegs => write!(f, "a plan has at most {MAX_LEGS} legs"),
            PlanError::BadValue(what) => write!(f, "bad plan value: {what}"),
        }
    }
}

/// A validated flight plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    legs: [Option<Leg>; MAX_LEGS],
}

impl Plan {
    /// Validates legs sent by the ground: heights 0–120 m, distances within 1 km, speeds
    /// 0.5–15 m/s, 1–10 rolls, holds not negative.
    pub fn new(legs: &[Leg]) -> Result<Self, PlanError> {
        if legs.len() > MAX_LEGS {
            return Err(PlanError::TooManyLegs);
        }
        if legs
            .iter()
            .position(|l| *l == Leg::Land)
            .is_some_and(|i| i.saturating_add(1) < legs.len())
        {
            return Err(PlanError::BadValue("nothing can follow a landing"));
        }
        let mut plan = Self {
            legs: [None; MAX_LEGS],
        };
        for (slot, leg) in plan.legs.iter_mut().zip(legs) {
            let ok = match *leg {
                Leg::Takeoff { alt_m } => (1.0..=120.0).contains(&alt_m),
                Leg::Hold { seconds } => seconds >= 0.0 && !seconds.is_nan(),
                Leg::Fly {
                    north_m,
                    east_m,
                    alt_m,
                    speed_mps,
                } => {
                    north_m.abs() <= 1000.0
                        && east_m.abs() <= 1000.0
                        && (1.0..=120.0).contains(&alt_m)
                        && (0.5..=15.0).contains(&speed_mps)
                }
                Leg::Rolls { count, speed_mps } => {
                    (1..=10).contains(&count) && (3.0..=15.0).contains(&speed_mps)
                }
                Leg::Land => true,
            };
            if !ok {
                return Err(PlanError::BadValue(match leg {
                    Leg::Takeoff { .. } => "take-off height must be 1-120 m",
                    Leg::Hold { .. } => "hold time must not be negative",
                    Leg::Fly { .. } => "fly: within 1 km, 1-120 m up, 0.5-15 m/s",
                    Leg::Rolls { .. } => "rolls: 1-10 of them, from 3-15 m/s",
                    Leg::Land => "land",
                }));
            }
            *slot = Some(*leg);
        }
        Ok(plan)
    }

    /// Take off to `alt_m` and hold for `seconds`.
    pub fn hover(alt_m: f64, seconds: f64) -> Self {
        let mut legs = [None; MAX_LEGS];
        if let Some(first) = legs.first_mut() {
            *first = Some(Leg::Takeoff { alt_m });
        }
        if let Some(second) = legs.get_mut(1) {
            *second = Some(Leg::Hold { seconds });
        }
        Self { legs }
    }

    /// Leg number `i`.
    pub fn get(&self, i: usize) -> Option<Leg> {
        self.legs.get(i).copied().flatten()
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
    fn plans_from_the_ground_are_validated() {
        assert!(
            Plan::new(&[
                Leg::Takeoff { alt_m: 10.0 },
                Leg::Rolls {
                    count: 3,
                    speed_mps: 8.0
                },
                Leg::Land
            ])
            .is_ok()
        );
        assert_eq!(
            Plan::new(&[Leg::Takeoff { alt_m: 500.0 }]),
            Err(PlanError::BadValue("take-off height must be 1-120 m"))
        );
        assert!(
            Plan::new(&[Leg::Rolls {
                count: 3,
                speed_mps: f64::NAN
            }])
            .is_err()
        );
        assert_eq!(
            Plan::new(&[Leg::Land; MAX_LEGS + 1]),
            Err(PlanError::TooManyLegs)
        );
        assert_eq!(
            Plan::new(&[
                Leg::Takeoff { alt_m: 5.0 },
                Leg::Land,
                Leg::Hold { seconds: 1.0 }
            ]),
            Err(PlanError::BadValue("nothing can follow a landing"))
        );
        let p = Plan::hover(10.0, 60.0);
        assert_eq!(p.get(1), Some(Leg::Hold { seconds: 60.0 }));
        assert_eq!(p.get(2), None);
    }
}
