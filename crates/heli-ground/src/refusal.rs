//! Why an operator's request did nothing, by kind, and why a transferred log was not saved.
//!
//! The `Display` text is what the page shows in its reply (and the message area, for the
//! operator in control): it names the button, the value or the file and what to do.

use std::fmt;
use std::path::PathBuf;

use heli_link::LinkError;
use heli_link::command::PLANS;

use crate::operators::Refused;
use crate::pack_log::PacksError;

/// An operator's request refused.
#[derive(Debug)]
pub enum Refusal {
    /// The request is not the display's JSON.
    Malformed(serde_json::Error),
    /// The page may not do it (a replay, or another operator is in control).
    Operator(Refused),
    /// Acknowledge with no field rule to acknowledge.
    NothingToAcknowledge,
    /// The last command has not been answered yet.
    CommandPending,
    /// The field rule blocks Start Logging; its text says what to acknowledge.
    FieldRule(String),
    /// Start Logging names a flight pack the packs file does not have.
    Pack(PacksError),
    /// Start Logging's parameters are not ones the vehicle takes.
    Parameters(LinkError),
    /// Start Logging names a plan the vehicle does not know.
    UnknownPlan(String),
    /// Stop's final parameters cannot be used.
    FinalParameters(FinalProblem),
    /// The button is greyed out in the panel's state.
    NotActive {
        /// The button.
        button: &'static str,
        /// The panel's state.
        panel: &'static str,
    },
    /// The parameters do not fit in the link's message.
    TooLongForTheLink,
    /// A flight of this session already logs under this suffix on the vehicle: the vehicle
    /// never replaces a log, so it would refuse.
    SuffixUsed(String),
    /// Kill without the operator's confirmation.
    KillUnconfirmed,
    /// An augmented or autonomous start on a configuration that is not lab-tested, without
    /// the operator's override: the statement and what to do.
    Untested(String),
}

/// Why Stop's final parameters (where to save the flight's log) cannot be used.
#[derive(Debug)]
pub enum FinalProblem {
    /// One of the base directory and the suffix without the other.
    OnlyOne,
    /// The suffix is not a file suffix.
    Suffix(LinkError),
    /// The base directory leaves the save root.
    NotBelowRoot {
        /// The directory given.
        base: String,
        /// The save root.
        root: PathBuf,
    },
    /// No flight has flown since the station started or the last Stop.
    NoFlight,
    /// A log transfer is still under way.
    TransferUnderWay,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Malformed(e) => write!(f, "malformed request: {e}"),
            Refusal::Operator(e) => e.fmt(f),
            Refusal::NothingToAcknowledge => f.write_str("nothing to acknowledge"),
            Refusal::CommandPending => {
                f.write_str("a command is still on its way: wait for its answer")
            }
            Refusal::FieldRule(why) => f.write_str(why),
            Refusal::Pack(e) => e.fmt(f),
            Refusal::Parameters(e) => e.fmt(f),
            Refusal::UnknownPlan(name) => write!(
                f,
                "unknown flight plan '{name}' (the vehicle knows {})",
                PLANS.join(", ")
            ),
            Refusal::FinalParameters(problem) => write!(f, "final parameters: {problem}"),
            Refusal::NotActive { button, panel } => {
                write!(f, "{button} is not active now (the panel is {panel})")
            }
            Refusal::TooLongForTheLink => f.write_str(
                "the parameters cannot go over the link (a suffix is at most 15 characters)",
            ),
            Refusal::KillUnconfirmed => f.write_str(
                "kill not confirmed: it ends the flight process now, in the air too (the helicopter falls); Stop lands it first",
            ),
            Refusal::Untested(why) => f.write_str(why),
            Refusal::SuffixUsed(s) => write!(
                f,
                "the vehicle has a log flight_{s}.mcap already (it never replaces one): choose another suffix"
            ),
        }
    }
}

impl fmt::Display for FinalProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FinalProblem::OnlyOne => {
                f.write_str("give both the base directory and the suffix, or neither")
            }
            FinalProblem::Suffix(e) => e.fmt(f),
            FinalProblem::NotBelowRoot { base, root } => write!(
                f,
                "base directory '{base}' must be a relative path below {} (no '..', no leading '/')",
                root.display()
            ),
            FinalProblem::NoFlight => f.write_str(
                "no flight has flown since this station started (or since the last Stop), so there is no log of it to save; Stop without saving",
            ),
            FinalProblem::TransferUnderWay => f.write_str("a log transfer is still under way"),
        }
    }
}

impl std::error::Error for Refusal {}

impl From<Refused> for Refusal {
    fn from(e: Refused) -> Self {
        Refusal::Operator(e)
    }
}

/// A transferred log that could not be saved.
#[derive(Debug)]
pub enum SaveError {
    /// Its directory could not be created.
    Directory {
        /// The directory.
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file could not be written.
    Write(std::io::Error),
    /// Every name from `NAME.mcap` to `NAME-99.mcap` is taken.
    NamesTaken,
}

impl fmt::Display for SaveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SaveError::Directory { dir, source } => {
                write!(f, "creating {}: {source}", dir.display())
            }
            SaveError::Write(e) => e.fmt(f),
            SaveError::NamesTaken => {
                f.write_str("99 logs of that name already: choose another suffix")
            }
        }
    }
}

impl std::error::Error for SaveError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_refusal_says_what_and_what_to_do() {
        let e = Refusal::NotActive {
            button: "Stop",
            panel: "idle",
        };
        assert_eq!(e.to_string(), "Stop is not active now (the panel is idle)");
        let e = Refusal::FinalParameters(FinalProblem::NotBelowRoot {
            base: "../x".into(),
            root: "/logs".into(),
        });
        assert!(
            e.to_string()
                .starts_with("final parameters: base directory '../x'")
        );
        assert!(e.to_string().contains("/logs"));
        let e = Refusal::UnknownPlan("loop".into());
        assert!(e.to_string().contains("the vehicle knows hover"), "{e}");
        assert_eq!(
            SaveError::NamesTaken.to_string(),
            "99 logs of that name already: choose another suffix"
        );
    }
}
