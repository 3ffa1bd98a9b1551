//! The vehicle's lab statement as the ground keeps it (`heli certify`): the heartbeat says
//! whether the vehicle's build and parameters are the lab-tested ones, and the bootstrap's
//! status text says why not (`bootstrap: NOT lab-tested: parameters changed …`). The display
//! shows both; Start Logging of an augmented or autonomous flight on a configuration that is
//! not lab-tested is sent only with the operator's explicit override, which the vehicle logs.

use heli_link::status::{LAB_TESTED, NOT_LAB_TESTED, Tested};
use heli_types::FlightMode;
use serde::Serialize;

/// The statement in a status text of the vehicle's bootstrap, if it is one.
pub fn statement_of(text: &str) -> Option<&str> {
    let said = text.strip_prefix("bootstrap: ")?;
    (said.starts_with(&format!("{NOT_LAB_TESTED}: "))
        || said.starts_with(&format!("{LAB_TESTED}: ")))
    .then_some(said)
}

/// What the display shows of it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct LabView {
    /// `lab-tested`, `NOT lab-tested` or `unknown` (the heartbeat's).
    pub tested: &'static str,
    /// The vehicle's statement, when heard since it last changed.
    pub statement: Option<String>,
}

/// The view of the heartbeat's `tested` and the last statement heard.
pub fn view(tested: Tested, statement: Option<&str>) -> LabView {
    // A statement of the other kind is from before the change: not shown.
    let agrees = |s: &&str| match tested {
        Tested::LabTested => s.starts_with(LAB_TESTED),
        Tested::NotTested | Tested::BenchOverride => s.starts_with(NOT_LAB_TESTED),
        Tested::Unknown => false,
    };
    LabView {
        tested: tested.name(),
        statement: statement.filter(agrees).map(str::to_string),
    }
}

/// Why Start Logging of `controller` is not sent as it is: the configuration is not
/// lab-tested and the operator has not overridden it (none: it may be sent). A bench
/// vehicle's standing override (`Tested::BenchOverride`) asks none.
pub fn needs_override(
    tested: Tested,
    statement: Option<&str>,
    controller: FlightMode,
    override_untested: bool,
) -> Option<String> {
    if tested != Tested::NotTested || controller == FlightMode::Manual || override_untested {
        return None;
    }
    let why = view(tested, statement)
        .statement
        .unwrap_or_else(|| NOT_LAB_TESTED.to_string());
    Some(format!(
        "{why}: {} flight needs your override (it is logged)",
        controller.name()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bootstraps_statement_is_read_and_shown_while_the_heartbeat_agrees() {
        let not = "bootstrap: NOT lab-tested: parameters changed since the lab's tests: HOV_VEL_P 1.6 (tested 1.4)";
        let s = statement_of(not).unwrap();
        assert!(s.starts_with("NOT lab-tested: parameters"));
        assert!(statement_of("bootstrap: lab-tested: build 1a2b3c4d").is_some());
        // A flight's event that mentions it is not the statement.
        assert!(statement_of("flight: event WarningHi autonomous flight by the operator's override on a configuration that is NOT lab-tested: x").is_none());
        assert!(statement_of("NOT lab-tested: x").is_none());
        assert_eq!(
            view(Tested::NotTested, Some(s)).statement.as_deref(),
            Some(s)
        );
        assert_eq!(view(Tested::LabTested, Some(s)).statement, None);
        assert_eq!(view(Tested::Unknown, Some(s)).tested, "unknown");
    }

    #[test]
    fn only_an_augmented_or_autonomous_start_on_an_untested_vehicle_needs_the_override() {
        let s = Some("NOT lab-tested: the build changed");
        let why = needs_override(Tested::NotTested, s, FlightMode::Autonomous, false).unwrap();
        assert_eq!(
            why,
            "NOT lab-tested: the build changed: autonomous flight needs your override (it is logged)"
        );
        assert!(needs_override(Tested::NotTested, s, FlightMode::Autonomous, true).is_none());
        assert!(needs_override(Tested::NotTested, s, FlightMode::Manual, false).is_none());
        assert!(needs_override(Tested::LabTested, s, FlightMode::Autonomous, false).is_none());
        assert!(needs_override(Tested::Unknown, None, FlightMode::Autonomous, false).is_none());
        assert!(needs_override(Tested::BenchOverride, s, FlightMode::Autonomous, false).is_none());
        assert_eq!(
            view(Tested::BenchOverride, s).statement.as_deref(),
            s,
            "the bench's statement is shown"
        );
        let velocity = FlightMode::from_name("velocity").unwrap();
        assert!(
            needs_override(Tested::NotTested, None, velocity, false)
                .unwrap()
                .starts_with("NOT lab-tested: velocity")
        );
    }
}
