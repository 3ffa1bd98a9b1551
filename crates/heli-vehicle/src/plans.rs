//! The flight plan named at Start Logging: a plan of the library (`heli_types::library`: the
//! plans the lab flew in simulation, by the name of the scenario that flew them), or a plan
//! file of the vehicle's plan directory (`--plans-dir DIR`: `DIR/NAME.toml`).
//!
//! A plan is asked for by a *name* — letters, digits, `-` and `_` — never by a path: a name
//! that is no library plan is looked up in the plan directory only, so that no route to the
//! vehicle (the console, the link) can make it read another file. Errors name the plan and
//! where its file went wrong (a line and column), never its contents: they go to every
//! ground station.
//!
//! A plan file is TOML with the legs of `docs/scenarios.md` — a scenario file is one: only
//! its `plan` and `base` are read here. Without `plan` the file flies the plan of its `base`
//! (default `hover`).

use std::fmt;
use std::path::{Path, PathBuf};

use heli_types::{Leg, Plan, PlanError, library};

/// The plan flown when Start Logging names none.
pub const DEFAULT_PLAN: &str = "hover";
/// Longest plan name.
pub const MAX_PLAN_NAME: usize = 64;

/// A flight plan ready to fly, with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct FlightPlan {
    /// The name it was asked for by.
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
    /// Not a plan name (a path, or characters a name does not have).
    NotAName(String),
    /// No plan of the library has the name, and the plan directory has no file of it (or
    /// the vehicle has no plan directory).
    NotFound {
        /// The name.
        name: String,
        /// Where it was looked for, and the system's answer (`None`: no plan directory).
        looked: Option<(PathBuf, std::io::ErrorKind)>,
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
            PlanLoadError::NotAName(name) => write!(
                f,
                "flight plan '{:.80}': not a plan name (letters, digits, '-' and '_', at most {MAX_PLAN_NAME}): plans are named, never given by path",
                name.escape_default()
            ),
            PlanLoadError::NotFound { name, looked } => {
                write!(
                    f,
                    "flight plan '{name}': neither a plan of the library ({})",
                    library::names()
                )?;
                match looked {
                    Some((path, kind)) => {
                        write!(f, " nor a plan file ({}: {kind})", path.display())
                    }
                    None => write!(f, " nor a plan file (this vehicle has no --plans-dir)"),
                }
            }
            PlanLoadError::File { path, why } => {
                write!(f, "flight plan file {}: {why}", path.display())
            }
            PlanLoadError::Invalid { name, error } => write!(f, "flight plan '{name}': {error}"),
        }
    }
}

impl std::error::Error for PlanLoadError {}

/// What is wrong with a plan file: where, never what it says.
#[derive(Debug, PartialEq, Eq)]
pub enum PlanFileProblem {
    /// The text is not TOML (at this line and column, from 1).
    Toml(Option<(usize, usize)>),
    /// Its `plan` is not a list of legs.
    Legs,
    /// Its `base` is not a name.
    BaseNotAName,
    /// Its `base` names no plan of the library.
    UnknownBase,
}

impl fmt::Display for PlanFileProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanFileProblem::Toml(Some((line, column))) => {
                write!(f, "not valid TOML at line {line}, column {column}")
            }
            PlanFileProblem::Toml(None) => write!(f, "not valid TOML"),
            PlanFileProblem::Legs => write!(
                f,
                "its 'plan' is not a list of legs (docs/scenarios.md: takeoff, hold, fly, rolls, land)"
            ),
            PlanFileProblem::BaseNotAName => write!(f, "its 'base' must be a plan's name"),
            PlanFileProblem::UnknownBase => write!(
                f,
                "its 'base' names no plan of the library ({})",
                library::names()
            ),
        }
    }
}

/// Whether `name` is a plan name: letters, digits, `-` and `_`, 1 to [`MAX_PLAN_NAME`].
pub fn is_plan_name(name: &str) -> bool {
    (1..=MAX_PLAN_NAME).contains(&name.len())
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
}

/// The plan named `name` (the default plan without one): the library's, or the plan
/// directory's `NAME.toml`.
pub fn named(name: Option<&str>, plans_dir: Option<&Path>) -> Result<FlightPlan, PlanLoadError> {
    let name = name.unwrap_or(DEFAULT_PLAN);
    if !is_plan_name(name) {
        return Err(PlanLoadError::NotAName(name.to_string()));
    }
    let legs = match library::plan(name) {
        Some(p) => p.legs.to_vec(),
        None => {
            let Some(dir) = plans_dir else {
                return Err(PlanLoadError::NotFound {
                    name: name.to_string(),
                    looked: None,
                });
            };
            let path = dir.join(format!("{name}.toml"));
            let text = std::fs::read_to_string(&path).map_err(|error| PlanLoadError::NotFound {
                name: name.to_string(),
                looked: Some((path.clone(), error.kind())),
            })?;
            from_file_text(&text).map_err(|why| PlanLoadError::File { path, why })?
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

/// Line and column (from 1) of byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = text.get(..at).unwrap_or(text);
    let line = before.matches('\n').count().saturating_add(1);
    let column = before
        .rsplit('\n')
        .next()
        .map_or(0, |l| l.chars().count())
        .saturating_add(1);
    (line, column)
}

/// The legs of a plan file's text: its `plan`, or its `base`'s.
fn from_file_text(text: &str) -> Result<Vec<Leg>, PlanFileProblem> {
    let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        PlanFileProblem::Toml(e.span().map(|span| line_column(text, span.start)))
    })?;
    if let Some(plan) = table.remove("plan") {
        return plan.try_into().map_err(|_| PlanFileProblem::Legs);
    }
    let base = match table.remove("base") {
        None => DEFAULT_PLAN.to_string(),
        Some(toml::Value::String(s)) => s,
        Some(_) => return Err(PlanFileProblem::BaseNotAName),
    };
    library::plan(&base)
        .map(|p| p.legs.to_vec())
        .ok_or(PlanFileProblem::UnknownBase)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_library_name_flies_its_plan_and_none_flies_the_hover() {
        let rolls = named(Some("rolls"), None).unwrap();
        assert_eq!(rolls.name, "rolls");
        assert_eq!(rolls.legs, library::plan("rolls").unwrap().legs);
        assert_eq!(rolls.plan.legs().count(), rolls.legs.len());
        let default = named(None, None).unwrap();
        assert_eq!(default.name, "hover");
        assert_eq!(
            default.legs_json(),
            r#"[{"leg":"takeoff","alt_m":10.0},{"leg":"hold","seconds":60.0}]"#
        );
    }

    #[test]
    fn a_plan_file_of_the_plan_directory_flies_its_legs_or_its_base() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("own.toml"),
            "name = \"x\"\nwind_ned_mps = [1.0, 0.0, 0.0]\n[[plan]]\nleg = \"takeoff\"\nalt_m = 12.0\n[[plan]]\nleg = \"land\"\n",
        )
        .unwrap();
        let p = named(Some("own"), Some(dir.path())).unwrap();
        assert_eq!(p.legs, [Leg::Takeoff { alt_m: 12.0 }, Leg::Land]);
        std::fs::write(dir.path().join("based.toml"), "base = \"demo\"\nseed = 4\n").unwrap();
        assert_eq!(
            named(Some("based"), Some(dir.path())).unwrap().legs,
            library::plan("demo").unwrap().legs
        );
        std::fs::write(dir.path().join("plain.toml"), "seed = 4\n").unwrap();
        assert_eq!(
            named(Some("plain"), Some(dir.path())).unwrap().legs,
            library::plan("hover").unwrap().legs
        );
    }

    #[test]
    fn a_path_is_never_read_and_no_error_quotes_a_file() {
        let dir = tempfile::tempdir().unwrap();
        // A secret elsewhere, and the finding's path: neither is opened.
        let secret = dir.path().join("secret.toml");
        std::fs::write(&secret, "root:$6$SECRETHASH:19000:0:99999:7:::\n").unwrap();
        for name in [
            "/etc/shadow",
            secret.to_str().unwrap(),
            "../secret",
            "a b",
            "",
        ] {
            let e = named(Some(name), Some(dir.path())).unwrap_err();
            assert!(matches!(e, PlanLoadError::NotAName(_)), "{name}: {e}");
            assert!(e.to_string().contains("never given by path"), "{e}");
        }
        // A file of the plan directory that is not a plan: where, never what it says.
        std::fs::write(dir.path().join("shadow.toml"), "root:$6$SECRETHASH:19000\n").unwrap();
        let e = named(Some("shadow"), Some(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not valid TOML at line 1, column"), "{e}");
        assert!(!e.contains("SECRETHASH") && !e.contains("root"), "{e}");
    }

    #[test]
    fn what_cannot_be_flown_says_why() {
        let e = named(Some("loop-the-loop"), None).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "flight plan 'loop-the-loop': neither a plan of the library (demo, hover, "
            ) && e.ends_with("nor a plan file (this vehicle has no --plans-dir)"),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let e = named(Some("nowhere"), Some(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nowhere.toml: entity not found"), "{e}");
        let cases = [
            ("bad", "plan = [", "not valid TOML at line 1, column 9"),
            (
                "base",
                "base = \"nowhere\"",
                "its 'base' names no plan of the library",
            ),
            ("base2", "base = 3", "its 'base' must be a plan's name"),
            (
                "leg",
                "[[plan]]\nleg = \"loop\"",
                "its 'plan' is not a list of legs",
            ),
        ];
        for (name, text, expected) in cases {
            std::fs::write(dir.path().join(format!("{name}.toml")), text).unwrap();
            let e = named(Some(name), Some(dir.path())).unwrap_err().to_string();
            assert!(e.contains(expected), "{name}: {e}");
            assert!(!e.contains("nowhere\"") && !e.contains("loop\""), "{e}");
        }
        std::fs::write(
            dir.path().join("high.toml"),
            "[[plan]]\nleg = \"takeoff\"\nalt_m = 500.0\n",
        )
        .unwrap();
        let e = named(Some("high"), Some(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("bad plan value: take-off height must be 1-120 m"),
            "{e}"
        );
    }
}
