//! The one controller choice of the whole system: the control system the ground operator
//! picks at "Start Logging", the flight core runs, a scenario names and the link carries.

use crate::AugmentedMode;

/// The control system for a flight.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlightMode {
    /// Pilot flies; the computer only damps yaw.
    Manual,
    /// With the pilot's auto switch on, the computer flies the flight plan.
    Autonomous,
    /// With the pilot's auto switch on, the pilot flies through an augmentation system.
    Augmented(AugmentedMode),
}

impl FlightMode {
    /// Every choice, in the order the ground display lists them.
    pub const ALL: [FlightMode; 5] = [
        FlightMode::Manual,
        FlightMode::Autonomous,
        FlightMode::Augmented(AugmentedMode::Rate),
        FlightMode::Augmented(AugmentedMode::Attitude),
        FlightMode::Augmented(AugmentedMode::Velocity),
    ];

    /// The name used in scenario files, on the command line and on the link.
    pub const fn name(self) -> &'static str {
        match self {
            FlightMode::Manual => "manual",
            FlightMode::Autonomous => "autonomous",
            FlightMode::Augmented(AugmentedMode::Rate) => "rate",
            FlightMode::Augmented(AugmentedMode::Attitude) => "attitude",
            FlightMode::Augmented(AugmentedMode::Velocity) => "velocity",
        }
    }

    /// The choice named `name` (see [`FlightMode::name`]), if there is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// True for the three augmentation systems.
    pub const fn is_augmented(self) -> bool {
        matches!(self, FlightMode::Augmented(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for m in FlightMode::ALL {
            assert_eq!(FlightMode::from_name(m.name()), Some(m));
        }
        assert_eq!(FlightMode::from_name("loop"), None);
        assert_eq!(FlightMode::from_name("Manual"), None);
    }
}
