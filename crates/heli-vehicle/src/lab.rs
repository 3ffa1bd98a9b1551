//! The vehicle's side of the lab attestation ([`heli_link::attest`]): what flies (the program
//! that runs the flight process and the parameter file), judged against the lab's signed
//! attestation, and whether a start may fly it.
//!
//! Manual flight is never refused (the pilot flies; the statement is said). Augmented and
//! autonomous flight on a configuration that is not lab-tested needs an override: the
//! operator's, given with that start (`start-logging … override-untested`, the link's flag,
//! the display's confirmation), or a lab bench's standing one (`--fly-untested`, for the
//! HILSim bench where every build is untested). Either is said as an event and recorded in
//! the flight's log.

use std::path::Path;

use heli_fsw::core::Severity;
use heli_link::StartParameters;
use heli_types::FlightMode;

use heli_link::attest::{Identity, LabCheck, Verdict};

/// The vehicle's lab check: where the attestation is, the key, and the bench's override.
#[derive(Clone, Debug)]
pub struct Lab {
    /// The attestation and the key that checks it.
    pub check: LabCheck,
    /// The bench's standing override (`--fly-untested`).
    pub fly_untested: bool,
}

impl Lab {
    /// The verdict on `program` flying the parameters of `log_dir` (the defaults without a
    /// file). A program or a parameter file that cannot be read is not lab-tested, and
    /// says why.
    pub fn judge(&self, program: &Path, log_dir: &Path) -> Verdict {
        match identity(program, log_dir) {
            Ok(identity) => self.check.judge(&identity),
            Err(why) => Verdict::NotTested { why: vec![why] },
        }
    }

    /// Whether `start` may fly on `verdict`: `Ok` with what to say of it (none for a
    /// lab-tested configuration), or `Err` with the refusal.
    pub fn start(
        &self,
        verdict: &Verdict,
        start: &StartParameters,
    ) -> Result<Option<Said>, String> {
        let Verdict::NotTested { .. } = verdict else {
            return Ok(None);
        };
        let line = verdict.line();
        if start.controller == FlightMode::Manual {
            return Ok(Some(Said {
                severity: Severity::WarningLo,
                text: format!("manual flight; {line}"),
                override_by: None,
            }));
        }
        let by = if start.override_untested {
            "the operator's override"
        } else if self.fly_untested {
            "the bench's standing override (--fly-untested)"
        } else {
            return Err(format!(
                "{line}: {} flight needs the operator's override (the display asks for it; `heli ground start … --override-untested`; `heli vehicle ctl start-logging SUFFIX MODE [PLAN] override-untested`)",
                start.controller.name()
            ));
        };
        Ok(Some(Said {
            severity: Severity::WarningHi,
            text: format!(
                "{} flight by {by} on a configuration that is {line}",
                start.controller.name()
            ),
            override_by: Some(if start.override_untested {
                "operator"
            } else {
                "bench"
            }),
        }))
    }
}

/// What a start on a configuration that is not lab-tested says (an event of the flight),
/// and whose override it flies by.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Said {
    /// How much it matters.
    pub severity: Severity,
    /// The event's text.
    pub text: String,
    /// `operator` or `bench`; none for a manual flight.
    pub override_by: Option<&'static str>,
}

/// The identity of `program` flying `log_dir`'s parameters.
pub fn identity(program: &Path, log_dir: &Path) -> Result<Identity, String> {
    let table = if crate::params::path_in(log_dir).exists() {
        crate::params::load(log_dir).map_err(|e| e.to_string())?
    } else {
        crate::params::defaults()
    };
    Identity::of(program, &table).map_err(|e| format!("the flight software's program: {e}"))
}

/// What the tests of the lab check share: a key, a lab on a directory, and an attestation
/// of an identity signed with the key.
#[cfg(test)]
pub(crate) mod testing {
    use super::*;
    use heli_link::attest::{Body, SuiteEvidence, sign, to_text};
    use heli_link::signing::Key;

    /// A key (32 different bytes).
    pub fn key() -> Key {
        let mut bytes = [0u8; 32];
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = u8::try_from(i).unwrap().wrapping_mul(73).wrapping_add(5);
        }
        Key::new(bytes)
    }

    /// A lab whose attestation is `dir/attestation.json`, checked with [`key`].
    pub fn lab(dir: &Path, fly_untested: bool) -> Lab {
        Lab {
            check: LabCheck {
                attestation: dir.join("attestation.json"),
                key: Some(key()),
            },
            fly_untested,
        }
    }

    /// Writes `dir/attestation.json` attesting `identity` (its tests passed).
    pub fn attest(dir: &Path, identity: Identity) {
        let body = Body {
            format: heli_link::attest::FORMAT,
            identity,
            certified_unix_s: 0,
            certified_by: "test".into(),
            replays: Vec::new(),
            suite: SuiteEvidence {
                dir: "s".into(),
                flights: 10,
                pass: 10,
                crash: 0,
                error: 0,
                min_pass_permille: 990,
            },
        };
        let text = to_text(&sign(body, &key()).unwrap()).unwrap();
        std::fs::write(dir.join("attestation.json"), text).unwrap();
    }
}

#[cfg(test)]
mod tests {
    use super::testing::{attest, lab};
    use super::*;

    fn start(mode: &str, override_untested: bool) -> StartParameters {
        StartParameters {
            override_untested,
            ..StartParameters::new("s", mode).unwrap()
        }
    }

    #[test]
    fn the_program_and_parameter_file_judged_tested_until_a_gain_changes() {
        let dir = tempfile::tempdir().unwrap();
        let program = dir.path().join("heli-vehicle");
        std::fs::write(&program, b"the flight software").unwrap();
        attest(dir.path(), identity(&program, dir.path()).unwrap());
        let lab = lab(dir.path(), false);
        let verdict = lab.judge(&program, dir.path());
        assert!(
            matches!(verdict, Verdict::LabTested { .. }),
            "{}",
            verdict.line()
        );
        assert_eq!(lab.start(&verdict, &start("autonomous", false)), Ok(None));
        // One gain set over the link: the file the flight process reads changes.
        std::fs::write(dir.path().join("params"), "HOV_VEL_P = 1.6\n").unwrap();
        let verdict = lab.judge(&program, dir.path());
        let line = verdict.line();
        assert!(line.contains("HOV_VEL_P 1.6 (tested 1.4)"), "{line}");
        let refused = lab
            .start(&verdict, &start("autonomous", false))
            .unwrap_err();
        assert!(
            refused.contains("autonomous flight needs the operator's override"),
            "{refused}"
        );
        // How to give it, from each of the operator's tools.
        assert!(
            refused.contains("heli ground start … --override-untested")
                && refused.contains("ctl start-logging SUFFIX MODE [PLAN] override-untested"),
            "{refused}"
        );
        assert!(
            refused.starts_with("NOT lab-tested: parameters changed"),
            "{refused}"
        );
        let said = lab
            .start(&verdict, &start("velocity", true))
            .unwrap()
            .unwrap();
        assert_eq!(said.override_by, Some("operator"));
        assert_eq!(said.severity, Severity::WarningHi);
        assert!(
            said.text
                .starts_with("velocity flight by the operator's override"),
            "{}",
            said.text
        );
        let manual = lab
            .start(&verdict, &start("manual", false))
            .unwrap()
            .unwrap();
        assert_eq!(manual.override_by, None);
        // The program replaced: the build changed.
        std::fs::write(dir.path().join("params"), "").unwrap();
        std::fs::write(&program, b"another build").unwrap();
        let line = lab.judge(&program, dir.path()).line();
        assert!(line.contains("the build changed"), "{line}");
    }

    #[test]
    fn the_benchs_standing_override_flies_untested_and_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let program = dir.path().join("p");
        std::fs::write(&program, b"x").unwrap();
        let lab = lab(dir.path(), true);
        let verdict = lab.judge(&program, dir.path());
        assert!(
            verdict.line().contains("no lab attestation"),
            "{}",
            verdict.line()
        );
        let said = lab
            .start(&verdict, &start("autonomous", false))
            .unwrap()
            .unwrap();
        assert_eq!(said.override_by, Some("bench"));
        assert!(said.text.contains("--fly-untested"), "{}", said.text);
        // A parameter file that cannot be read, or no program: not lab-tested, with why.
        std::fs::write(dir.path().join("params"), "NOPE = 1\n").unwrap();
        assert!(lab.judge(&program, dir.path()).line().contains("params"));
        let gone = lab.judge(&dir.path().join("gone"), Path::new("/nonexistent"));
        assert!(
            gone.line().contains("the flight software's program"),
            "{}",
            gone.line()
        );
    }
}
