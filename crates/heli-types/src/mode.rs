//! The one controller choice of the whole system: the control system the ground operator
//! picks at "Start Logging", the flight core runs, a scenario names and the link carries.

/// The three augmentation systems the pilot can fly through (thesis §4.4: rate, attitude and
/// velocity command).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AugmentedMode {
    /// Aileron and elevator command roll and pitch rates, rudder yaw rate; collective and
    /// throttle pass through.
    Rate,
    /// Aileron and elevator command roll and pitch angles, rudder yaw rate; collective and
    /// throttle pass through.
    Attitude,
    /// Aileron and elevator command velocity right and forward, collective climb rate, rudder
    /// yaw rate; the rotor is governed. Sticks centred: hover in place.
    Velocity,
}

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

/// A mode is written by its name (`"velocity"`), in scenario files as on the link.
#[cfg(feature = "serde")]
impl serde::Serialize for FlightMode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(feature = "serde")]
impl<'de> serde::Deserialize<'de> for FlightMode {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        FlightMode::from_name(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown mode '{name}' (expected manual, autonomous, rate, attitude or velocity)"
            ))
        })
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

    #[test]
    fn only_the_three_augmentation_systems_are_augmented() {
        let augmented: Vec<_> = FlightMode::ALL
            .into_iter()
            .filter(|m| m.is_augmented())
            .map(FlightMode::name)
            .collect();
        assert_eq!(augmented, ["rate", "attitude", "velocity"]);
    }

    #[cfg(feature = "serde")]
    #[test]
    fn a_mode_is_written_by_its_name() {
        let json = serde_json::to_string(&FlightMode::Augmented(AugmentedMode::Attitude));
        assert_eq!(json.unwrap(), "\"attitude\"");
        let back: FlightMode = serde_json::from_str("\"autonomous\"").unwrap();
        assert_eq!(back, FlightMode::Autonomous);
        let err = serde_json::from_str::<FlightMode>("\"loop\"").unwrap_err();
        assert!(err.to_string().contains("unknown mode 'loop'"), "{err}");
    }
}
