//! The ground station's messages to the vehicle (thesis §2.3–2.4 and §4.1).

use std::fmt;

use heli_types::FlightMode;

/// Parameters sent with "Start Logging".
#[derive(Clone, Debug, PartialEq)]
pub struct StartParameters {
    /// Suffix appended to the names of this flight's log files.
    pub file_suffix: String,
    /// Control system for the flight.
    pub controller: FlightMode,
    /// The flight plan to fly with the auto switch on: a plan the vehicle knows by name, or
    /// the path of a plan file on the vehicle. `None`: the vehicle's default plan.
    pub plan: Option<String>,
    /// The operator's override: fly an augmented or autonomous flight on a configuration
    /// (build or parameters) that is not lab-tested (`heli certify`). Logged with the flight.
    pub override_untested: bool,
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
    /// Stop: end the flight on the ground (clean shutdown). In the air the flight computer
    /// lands first when it flies, and refuses when the pilot flies.
    Stop,
    /// Kill: end the flight process now, in the air too (the helicopter falls). Sent only
    /// after the operator confirmed it.
    Kill,
    /// Send the freshest telemetry.
    TelemetryRequest,
    /// Where to save the logs, answering the cleanup routine.
    Final(FinalParameters),
}

/// Longest file suffix: what a Start Logging command can carry over the link (five floats
/// of three bytes), and so the one limit everywhere (a suffix typed on the local console may
/// have to be said over the link).
pub const MAX_LINK_SUFFIX: usize = 15;

/// How the vehicle's answer to a Stop in the air begins (its acknowledgement's text): the
/// flight lands first and ends on the ground. A ground waits for that end before it saves
/// the flight's log.
pub const LANDING_FIRST: &str = "landing first: the flight ends on the ground";

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
                    "file suffix '{s}' must be 1-{} letters, digits, '-' or '_'",
                    MAX_LINK_SUFFIX
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
            // One limit everywhere: what the link can carry (a suffix typed on the local
            // console may have to be said over the link).
            && file_suffix.len() <= MAX_LINK_SUFFIX
            && file_suffix
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !ok {
            return Err(LinkError::BadFileSuffix(file_suffix.to_string()));
        }
        Ok(Self {
            file_suffix: file_suffix.to_string(),
            plan: None,
            override_untested: false,
            controller: FlightMode::from_name(controller)
                .ok_or_else(|| LinkError::UnknownController(controller.to_string()))?,
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
        assert_eq!(
            StartParameters::new("a", "velocity").map(|p| p.controller),
            Ok(FlightMode::Augmented(heli_types::AugmentedMode::Velocity))
        );
        assert!(matches!(
            StartParameters::new("a", "loop"),
            Err(LinkError::UnknownController(_))
        ));
    }
}
