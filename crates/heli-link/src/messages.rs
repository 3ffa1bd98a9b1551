//! The ground station's messages to the vehicle (thesis §2.3–2.4 and §4.1).

use std::fmt;

/// The control system the operator picks before "Start Logging" (the ground display
/// relabels the uplink row to what the pilot's sticks mean under it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerChoice {
    /// Pilot flies; computer yaw damping only.
    Manual,
    /// Computer flies the flight plan when the pilot's auto switch is on.
    Autonomous,
    /// Augmented: sticks command roll, pitch and yaw rates.
    Rate,
    /// Augmented: sticks command roll and pitch angles and yaw rate.
    Attitude,
    /// Augmented: sticks command velocity, climb rate and yaw rate.
    Velocity,
}

impl ControllerChoice {
    /// Parses the name used on the ground display and in scenario files.
    pub fn from_name(name: &str) -> Result<Self, LinkError> {
        match name {
            "manual" => Ok(Self::Manual),
            "autonomous" => Ok(Self::Autonomous),
            "rate" => Ok(Self::Rate),
            "attitude" => Ok(Self::Attitude),
            "velocity" => Ok(Self::Velocity),
            other => Err(LinkError::UnknownController(other.to_string())),
        }
    }

    /// The labels the ground display writes over the pilot-uplink columns (aileron,
    /// elevator, rudder, collective, throttle): what the sticks mean under this controller
    /// (the thesis's display relabels the uplink row).
    pub fn uplink_labels(self) -> [&'static str; 5] {
        match self {
            Self::Manual | Self::Autonomous => ["Aile", "Elev", "Rudd", "Coll", "Thro"],
            Self::Rate => ["RollRate", "PitchRate", "YawRate", "Coll", "Thro"],
            Self::Attitude => ["Roll", "Pitch", "YawRate", "Coll", "Thro"],
            Self::Velocity => ["Vright", "Vfwd", "YawRate", "Climb", "Thro"],
        }
    }
}

/// Parameters sent with "Start Logging".
#[derive(Clone, Debug, PartialEq)]
pub struct StartParameters {
    /// Suffix appended to the names of this flight's log files.
    pub file_suffix: String,
    /// Control system for the flight.
    pub controller: ControllerChoice,
}

/// Parameters the cleanup routine asks for after "Stop" (thesis §4.1.4).
#[derive(Clone, Debug, PartialEq)]
pub struct FinalParameters {
    /// Directory the log files are saved under.
    pub base_directory: String,
    /// Suffix appended to the log file names.
    pub file_suffix: String,
}

/// A command from the ground station.
#[derive(Clone, Debug, PartialEq)]
pub enum GroundCommand {
    /// Start the main control process.
    Connect,
    /// Begin logging and control with these parameters.
    StartLogging(StartParameters),
    /// Stop the main control process (clean shutdown).
    Stop,
    /// Send the freshest telemetry.
    TelemetryRequest,
    /// Where to save the logs, answering the cleanup routine.
    Final(FinalParameters),
}

/// A message from the ground that the vehicle refuses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// The controller name is not one the vehicle has.
    UnknownController(String),
    /// A file name part contains characters that could escape the log directory.
    BadFileSuffix(String),
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::UnknownController(n) => write!(
                f,
                "unknown controller '{n}' (expected manual, autonomous, rate, attitude or velocity)"
            ),
            LinkError::BadFileSuffix(s) => {
                write!(
                    f,
                    "file suffix '{s}' must be 1-32 letters, digits, '-' or '_'"
                )
            }
        }
    }
}

impl std::error::Error for LinkError {}

impl StartParameters {
    /// Validates what the operator typed.
    pub fn new(file_suffix: &str, controller: &str) -> Result<Self, LinkError> {
        let ok = !file_suffix.is_empty()
            && file_suffix.len() <= 32
            && file_suffix
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !ok {
            return Err(LinkError::BadFileSuffix(file_suffix.to_string()));
        }
        Ok(Self {
            file_suffix: file_suffix.to_string(),
            controller: ControllerChoice::from_name(controller)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_parameters_are_validated() {
        assert!(StartParameters::new("flight-07", "autonomous").is_ok());
        assert_eq!(
            StartParameters::new("../../etc", "manual"),
            Err(LinkError::BadFileSuffix("../../etc".into()))
        );
        assert!(matches!(
            StartParameters::new("a", "loop"),
            Err(LinkError::UnknownController(_))
        ));
    }

    #[test]
    fn augmented_controllers_relabel_the_uplink_row() {
        assert_eq!(
            ControllerChoice::from_name("velocity"),
            Ok(ControllerChoice::Velocity)
        );
        assert_eq!(ControllerChoice::Velocity.uplink_labels()[3], "Climb");
        assert_eq!(ControllerChoice::Manual.uplink_labels()[0], "Aile");
    }
}
