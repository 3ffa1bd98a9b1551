//! The autonomous flight plan: a short list of legs the ground sends with "Start Logging" —
//! take off, hold, fly to a point, roll, land. One definition for every side: scenario files
//! write legs in this form, the flight core flies a validated [`Plan`] of them, the log
//! records them and the link serves them as a mission.
//!
//! Fixed size and `Copy`, so the flight core never allocates for a plan.

/// One leg of a flight plan. Positions are relative to the take-off point ("home"), in metres
/// north and east, altitude above it.
///
/// Written (scenario files, the log's metadata, the link) as a table tagged by `leg`:
/// `{ leg = "fly", north_m = 40.0, east_m = 0.0, alt_m = 10.0, speed_mps = 3.0 }`. A hold
/// without end is `seconds = inf` in TOML, `null` in JSON.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(tag = "leg", rename_all = "lowercase", deny_unknown_fields)
)]
pub enum Leg {
    /// Climb vertically to `alt_m` above home.
    Takeoff {
        /// Height above home (m).
        alt_m: f64,
    },
    /// Hold position where the previous leg ended.
    Hold {
        /// How long (s); infinite holds until the plan is changed.
        #[cfg_attr(feature = "serde", serde(deserialize_with = "seconds_or_forever"))]
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

/// A hold's time as written: a number, or `null` (JSON's spelling of an infinite one). The
/// field itself is required.
#[cfg(feature = "serde")]
fn seconds_or_forever<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    struct Seconds;
    impl<'de> serde::de::Visitor<'de> for Seconds {
        type Value = f64;
        fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            f.write_str("a number of seconds, or null for a hold without end")
        }
        fn visit_f64<E>(self, v: f64) -> Result<f64, E> {
            Ok(v)
        }
        #[allow(clippy::cast_precision_loss)]
        fn visit_i64<E>(self, v: i64) -> Result<f64, E> {
            Ok(v as f64)
        }
        #[allow(clippy::cast_precision_loss)]
        fn visit_u64<E>(self, v: u64) -> Result<f64, E> {
            Ok(v as f64)
        }
        fn visit_unit<E>(self) -> Result<f64, E> {
            Ok(f64::INFINITY)
        }
        fn visit_none<E>(self) -> Result<f64, E> {
            Ok(f64::INFINITY)
        }
        fn visit_some<D: serde::Deserializer<'de>>(self, d: D) -> Result<f64, D::Error> {
            d.deserialize_any(Seconds)
        }
    }
    d.deserialize_any(Seconds)
}

impl Leg {
    /// The leg's name as written (`takeoff`, `hold`, `fly`, `rolls`, `land`).
    pub const fn name(&self) -> &'static str {
        match self {
            Leg::Takeoff { .. } => "takeoff",
            Leg::Hold { .. } => "hold",
            Leg::Fly { .. } => "fly",
            Leg::Rolls { .. } => "rolls",
            Leg::Land => "land",
        }
    }
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

impl std::error::Error for PlanError {}

/// A validated flight plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    legs: [Option<Leg>; MAX_LEGS],
}

impl Plan {
    /// Validates legs sent by the ground: heights 1–120 m, distances within 1 km, speeds
    /// 0.5–15 m/s, 1–10 rolls from 3–15 m/s, holds not negative, nothing after a landing.
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

    /// The legs, in order.
    pub fn legs(&self) -> impl Iterator<Item = Leg> + '_ {
        self.legs.iter().map_while(|l| *l)
    }
}

#[cfg(test)]
mod tests;
