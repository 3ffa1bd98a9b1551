//! What the ground display writes: labels that depend on the flight's controller choice.

use heli_types::{AugmentedMode, FlightMode};

/// The labels the display writes over the pilot-uplink columns (aileron, elevator, rudder,
/// collective, throttle): what the sticks mean under `mode` when the auto switch is on (the
/// thesis's display relabels the uplink row).
pub fn uplink_labels(mode: FlightMode) -> [&'static str; 5] {
    match mode {
        FlightMode::Manual | FlightMode::Autonomous => ["Aile", "Elev", "Rudd", "Coll", "Thro"],
        FlightMode::Augmented(AugmentedMode::Rate) => {
            ["RollRate", "PitchRate", "YawRate", "Coll", "Thro"]
        }
        FlightMode::Augmented(AugmentedMode::Attitude) => {
            ["Roll", "Pitch", "YawRate", "Coll", "Thro"]
        }
        FlightMode::Augmented(AugmentedMode::Velocity) => {
            ["Vright", "Vfwd", "YawRate", "Climb", "Thro"]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn augmented_controllers_relabel_the_uplink_row() {
        let velocity = FlightMode::from_name("velocity").unwrap_or(FlightMode::Manual);
        assert_eq!(uplink_labels(velocity)[3], "Climb");
        assert_eq!(uplink_labels(velocity)[1], "Vfwd");
        assert_eq!(
            uplink_labels(FlightMode::Augmented(AugmentedMode::Rate))[0],
            "RollRate"
        );
        assert_eq!(uplink_labels(FlightMode::Manual)[0], "Aile");
    }
}
