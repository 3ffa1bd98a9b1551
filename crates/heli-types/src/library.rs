//! The plan library: the flight plans the lab has flown in simulation, by name. The vehicle
//! flies only a plan named here or one from a plan file on the flight computer; every
//! built-in scenario of the simulator takes its plan from here under its own name, so a plan
//! named at Start Logging is the very plan that scenario tested.

use crate::plan::Leg;

/// A plan of the library.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NamedPlan {
    /// Its name, as given at Start Logging (the built-in scenario that flies it).
    pub name: &'static str,
    /// Its legs.
    pub legs: &'static [Leg],
}

/// Take off to 10 m and hold 60 s.
const HOVER: &[Leg] = &[Leg::Takeoff { alt_m: 10.0 }, Leg::Hold { seconds: 60.0 }];

/// Climb to 25 m, three aileron rolls from 8 m/s, hold.
const ROLLS: &[Leg] = &[
    Leg::Takeoff { alt_m: 25.0 },
    Leg::Hold { seconds: 5.0 },
    Leg::Rolls {
        count: 3,
        speed_mps: 8.0,
    },
    Leg::Hold { seconds: 10.0 },
];

/// Take off, hover, fly out to the west end of the flight line (15 m north of the pad, 30 m in front of
/// the pilot's station 15 m behind it) and turn, three rolls back east past the pilot, fly
/// home, land: the thesis's demonstration, flown as a pilot flies a display, in front of
/// the pilot (the first roll some 30 m off, 20 m up, where its shadow is seen from 1.7 m).
const DEMO: &[Leg] = &[
    Leg::Takeoff { alt_m: 10.0 },
    Leg::Hold { seconds: 10.0 },
    Leg::Fly {
        north_m: 15.0,
        east_m: -75.0,
        alt_m: 15.0,
        speed_mps: 4.0,
    },
    // 6 m east: the heading the rolls are flown along.
    Leg::Fly {
        north_m: 15.0,
        east_m: -69.0,
        alt_m: 15.0,
        speed_mps: 2.0,
    },
    Leg::Hold { seconds: 3.0 },
    Leg::Rolls {
        count: 3,
        speed_mps: 8.0,
    },
    Leg::Hold { seconds: 5.0 },
    Leg::Fly {
        north_m: 0.0,
        east_m: 0.0,
        alt_m: 10.0,
        speed_mps: 5.0,
    },
    Leg::Hold { seconds: 5.0 },
    Leg::Land,
];

/// A 150 m path north at 3 m/s, then land.
const PATH: &[Leg] = &[
    Leg::Takeoff { alt_m: 10.0 },
    Leg::Fly {
        north_m: 150.0,
        east_m: 0.0,
        alt_m: 10.0,
        speed_mps: 3.0,
    },
    Leg::Land,
];

/// Take off to 15 m and hold (the pilot takes over by hand).
const HIGH_HOLD: &[Leg] = &[Leg::Takeoff { alt_m: 15.0 }, Leg::Hold { seconds: 1000.0 }];

/// Hover at 80 m.
const HOVER_80: &[Leg] = &[Leg::Takeoff { alt_m: 80.0 }, Leg::Hold { seconds: 60.0 }];

/// Hover 1.5 m up.
const HOVER_LOW: &[Leg] = &[Leg::Takeoff { alt_m: 1.5 }, Leg::Hold { seconds: 60.0 }];

/// North at 10 m/s, 60 m up.
const FORWARD_60: &[Leg] = &[
    Leg::Takeoff { alt_m: 60.0 },
    Leg::Fly {
        north_m: 400.0,
        east_m: 0.0,
        alt_m: 60.0,
        speed_mps: 10.0,
    },
    Leg::Hold { seconds: 10.0 },
];

/// Three rolls at 80 m.
const ROLLS_80: &[Leg] = &[
    Leg::Takeoff { alt_m: 80.0 },
    Leg::Hold { seconds: 5.0 },
    Leg::Rolls {
        count: 3,
        speed_mps: 8.0,
    },
    Leg::Hold { seconds: 10.0 },
];

/// 60 m out and hold there (until the battery sends it home).
const OUT_60: &[Leg] = &[
    Leg::Takeoff { alt_m: 10.0 },
    Leg::Fly {
        north_m: 60.0,
        east_m: 0.0,
        alt_m: 10.0,
        speed_mps: 3.0,
    },
    Leg::Hold { seconds: 1200.0 },
];

const fn named(name: &'static str, legs: &'static [Leg]) -> NamedPlan {
    NamedPlan { name, legs }
}

/// Every plan of the library, in the order of the simulator's built-in scenarios.
pub const LIBRARY: &[NamedPlan] = &[
    named("demo", DEMO),
    named("hover", HOVER),
    named("rolls", ROLLS),
    named("rc-loss", PATH),
    named("gps-outage", HOVER),
    named("manual-sweep", HIGH_HOLD),
    // Flown by the pilot through the velocity augmentation: no autonomous legs.
    named("augmented", &[]),
    named("uplink-silent", PATH),
    named("imu-failure", HIGH_HOLD),
    named("baro-failure", HOVER),
    named("compass-silent", HOVER),
    named("no-gps-takeoff", HOVER),
    named("roll-rc-loss", ROLLS),
    named("brownout", HOVER),
    named("gps-lost", HOVER),
    named("engine-failure-hover", HOVER_80),
    named("engine-failure-low-hover", HOVER_LOW),
    named("engine-failure-forward", FORWARD_60),
    named("engine-failure-roll", ROLLS_80),
    named("battery-swap", HOVER),
    named("weak-battery", OUT_60),
    named("battery-drain", HOVER),
];

/// The plan named `name`, if the library has it.
pub fn plan(name: &str) -> Option<&'static NamedPlan> {
    LIBRARY.iter().find(|p| p.name == name)
}

/// The library's names, comma-separated (for an error that lists them).
pub fn names() -> String {
    LIBRARY
        .iter()
        .map(|p| p.name)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Plan;

    #[test]
    fn every_plan_of_the_library_is_one_the_flight_core_accepts() {
        for p in LIBRARY {
            assert!(Plan::new(p.legs).is_ok(), "{}", p.name);
        }
    }

    #[test]
    fn names_are_unique_and_found() {
        for (i, p) in LIBRARY.iter().enumerate() {
            assert!(
                LIBRARY.iter().skip(i + 1).all(|q| q.name != p.name),
                "{} twice",
                p.name
            );
            assert_eq!(plan(p.name), Some(p));
        }
        assert_eq!(plan("hover").map(|p| p.legs), Some(HOVER));
        assert_eq!(plan("loop-the-loop"), None);
        assert!(names().starts_with("demo, hover, rolls, "));
        assert_eq!(names().split(", ").count(), LIBRARY.len());
    }
}
