//! The flight plan named at Start Logging: a plan of the library (`heli_types::library`: the
//! plans the lab flew in simulation, by the name of the scenario that flew them), or a plan
//! file on the flight computer.
//!
//! A plan file is TOML with the legs of `docs/scenarios.md` — a scenario file is one: only
//! its `plan` and `base` are read here. Without `plan` the file flies the plan of its `base`
//! (default `hover`).

use std::fmt;
use std::path::PathBuf;

use heli_types::{Leg, Plan, PlanError, library};

/// The plan flown when Start Logging names none.
pub const DEFAULT_PLAN: &str = "hover";

/// A flight plan ready to fly, with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct FlightPlan {
    /// The name it was asked for by (a library name or a file's path).
    pub name: String,
    /// Its legs, as written.
    pub legs: Vec<Leg>,
    /// The validated plan the flight core flies.
    pub plan: Plan,
}

impl FlightPlan {
    /// The legs as JSON: recorded in the log (so that a replay needs no file) and served over
    /// the link's mission protocol.
    pub fn legs_json(&self) -> String {
        serde_json::to_string(&self.legs).unwrap_or_else(|_| "[]".into())
    }
}

/// Why the named plan cannot be flown.
#[derive(Debug)]
pub enum PlanLoadError {
    /// No plan of the library has the name, and no file can be read at it.
    NotFound {
        /// The name.
        name: String,
        /// The system's answer on reading it as a file.
        error: std::io::Error,
    },
    /// The plan file is not valid TOML, or its legs are not legs.
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: PlanFileProblem,
    },
    /// The legs are out of the flight core's ranges.
    Invalid {
        /// The plan's name.
        name: String,
        /// Which value.
        error: PlanError,
    },
}

impl fmt::Display for PlanLoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanLoadError::NotFound { name, error } => write!(
                f,
                "flight plan '{name}': neither a plan of the library ({}) nor a plan file ({error})",
                library::names()
            ),
            PlanLoadError::File { path, why } => {
                write!(f, "flight plan file {}: {why}", path.display())
            }
            PlanLoadError::Invalid { name, error } => write!(f, "flight plan '{name}': {error}"),
        }
    }
}

impl std::error::Error for PlanLoadError {}

/// What is wrong with a plan file.
#[derive(Debug)]
pub enum PlanFileProblem {
    /// The text is not TOML.
    Toml(toml::de::Error),
    /// Its `plan` is not a list of legs.
    Legs(toml::de::Error),
    /// Its `base` is not a name.
    BaseNotAName(toml::Value),
    /// Its `base` names no plan of the library.
    UnknownBase(String),
}

impl fmt::Display for PlanFileProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanFileProblem::Toml(e) => e.fmt(f),
            PlanFileProblem::Legs(e) => write!(f, "plan: {e}"),
            PlanFileProblem::BaseNotAName(other) => {
                write!(f, "'base' must be a plan's name, not {other}")
            }
            PlanFileProblem::UnknownBase(base) => write!(
                f,
                "unknown base plan '{base}' (the library: {})",
                library::names()
            ),
        }
    }
}

/// The plan named `name` (the default plan without one): the library's, or a plan file's.
pub fn named(name: Option<&str>) -> Result<FlightPlan, PlanLoadError> {
    let name = name.unwrap_or(DEFAULT_PLAN);
    let legs = match library::plan(name) {
        Some(p) => p.legs.to_vec(),
        None => {
            let text = std::fs::read_to_string(name).map_err(|error| PlanLoadError::NotFound {
                name: name.to_string(),
                error,
            })?;
            from_file_text(&text).map_err(|why| PlanLoadError::File {
                path: PathBuf::from(name),
                why,
            })?
        }
    };
    let plan = Plan::new(&legs).map_err(|error| PlanLoadError::Invalid {
        name: name.to_string(),
        error,
    })?;
    Ok(FlightPlan {
        name: name.to_string(),
        legs,
        plan,
    })
}

/// The legs of a plan file's text: its `plan`, or its `base`'s.
fn from_file_text(text: &str) -> Result<Vec<Leg>, PlanFileProblem> {
    let mut table: toml::Table = text.parse().map_err(PlanFileProblem::Toml)?;
    if let Some(plan) = table.remove("plan") {
        return plan.try_into().map_err(PlanFileProblem::Legs);
    }
    let base = match table.remove("base") {
        None => DEFAULT_PLAN.to_string(),
        Some(toml::Value::String(s)) => s,
        Some(other) => return Err(PlanFileProblem::BaseNotAName(other)),
    };
    library::plan(&base)
        .map(|p| p.legs.to_vec())
        .ok_or(PlanFileProblem::UnknownBase(base))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_library_name_flies_its_plan_and_none_flies_the_hover() {
        let rolls = named(Some("rolls")).unwrap();
        assert_eq!(rolls.name, "rolls");
        assert_eq!(rolls.legs, library::plan("rolls").unwrap().legs);
        assert_eq!(rolls.plan.legs().count(), rolls.legs.len());
        let default = named(None).unwrap();
        assert_eq!(default.name, "hover");
        assert_eq!(
            default.legs_json(),
            r#"[{"leg":"takeoff","alt_m":10.0},{"leg":"hold","seconds":60.0}]"#
        );
    }

    #[test]
    fn a_plan_file_flies_its_legs_or_its_base() {
        let dir = tempfile::tempdir().unwrap();
        let own = dir.path().join("own.toml");
        std::fs::write(
            &own,
            "name = \"x\"\nwind_ned_mps = [1.0, 0.0, 0.0]\n[[plan]]\nleg = \"takeoff\"\nalt_m = 12.0\n[[plan]]\nleg = \"land\"\n",
        )
        .unwrap();
        let p = named(own.to_str()).unwrap();
        assert_eq!(p.legs, [Leg::Takeoff { alt_m: 12.0 }, Leg::Land]);
        let based = dir.path().join("based.toml");
        std::fs::write(&based, "base = \"demo\"\nseed = 4\n").unwrap();
        assert_eq!(
            named(based.to_str()).unwrap().legs,
            library::plan("demo").unwrap().legs
        );
        let plain = dir.path().join("plain.toml");
        std::fs::write(&plain, "seed = 4\n").unwrap();
        assert_eq!(
            named(plain.to_str()).unwrap().legs,
            library::plan("hover").unwrap().legs
        );
    }

    #[test]
    fn what_cannot_be_flown_says_why() {
        let e = named(Some("loop-the-loop")).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "flight plan 'loop-the-loop': neither a plan of the library (demo, hover, "
            ),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            ("bad.toml", "plan = [", "flight plan file"),
            (
                "base.toml",
                "base = \"nowhere\"",
                "unknown base plan 'nowhere'",
            ),
            (
                "base2.toml",
                "base = 3",
                "'base' must be a plan's name, not 3",
            ),
            ("leg.toml", "[[plan]]\nleg = \"loop\"", "plan: "),
        ];
        for (file, text, expected) in cases {
            let path = dir.path().join(file);
            std::fs::write(&path, text).unwrap();
            let e = named(path.to_str()).unwrap_err().to_string();
            assert!(e.contains(expected), "{file}: {e}");
        }
        let high = dir.path().join("high.toml");
        std::fs::write(&high, "[[plan]]\nleg = \"takeoff\"\nalt_m = 500.0\n").unwrap();
        let e = named(high.to_str()).unwrap_err().to_string();
        assert!(
            e.ends_with("bad plan value: take-off height must be 1-120 m"),
            "{e}"
        );
    }
}
