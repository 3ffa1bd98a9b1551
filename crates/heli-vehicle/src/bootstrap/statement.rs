//! The bootstrap's statement of the lab attestation ([`crate::lab`]): whether what the next
//! flight would fly — the program that runs the flight process and the parameter file — is
//! what the lab tested. Judged again every [`JUDGE_EVERY`] (a parameter set over the link
//! changes the file), said when it changes and, while not lab-tested, every
//! [`REPEAT_NOT_TESTED`] and as soon as a ground is heard again (a ground that joins does not
//! wait a minute for the reason); the heartbeat carries it and `status` gives the line.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use heli_fsw::core::Severity;
use heli_link::status::Tested;

use super::Bootstrap;
use crate::lab::Lab;
use heli_link::attest::{Identity, Verdict};

/// How often the statement is judged again.
pub const JUDGE_EVERY: Duration = Duration::from_secs(1);
/// How often a configuration that is not lab-tested is said again.
pub const REPEAT_NOT_TESTED: Duration = Duration::from_secs(60);
/// How long after it was last said to a ground a ground heard again does not hear it again
/// (a link that comes and goes would otherwise repeat it at every return).
pub const JOINED_QUIET: Duration = Duration::from_secs(10);

/// The statement and what it is judged on.
pub struct LabStatement {
    lab: Lab,
    log_dir: PathBuf,
    /// The program's hash, taken once (or why it could not be).
    build: Result<String, String>,
    line: Option<String>,
    tested: Tested,
    judged_at: Option<Instant>,
    said_at: Option<Instant>,
    /// A ground was heard at the last tick.
    ground_heard: bool,
    /// A ground was heard again since the statement was last judged.
    ground_joined: bool,
    /// When it was last said while a ground was heard.
    said_to_ground_at: Option<Instant>,
}

impl LabStatement {
    /// The statement on `program` (the flight process's) flying `log_dir`'s parameters.
    pub fn new(lab: Lab, program: &std::path::Path, log_dir: PathBuf) -> Self {
        let build = heli_link::attest::file_sha256(program)
            .map_err(|e| format!("the flight software's program: {e}"));
        Self {
            lab,
            log_dir,
            build,
            line: None,
            tested: Tested::Unknown,
            judged_at: None,
            said_at: None,
            ground_heard: false,
            ground_joined: false,
            said_to_ground_at: None,
        }
    }

    /// The last statement, if judged.
    pub fn line(&self) -> Option<&str> {
        self.line.as_deref()
    }

    fn verdict(&self) -> Verdict {
        let build = match &self.build {
            Ok(build) => build.clone(),
            Err(why) => {
                return Verdict::NotTested {
                    why: vec![why.clone()],
                };
            }
        };
        let table = if crate::params::path_in(&self.log_dir).exists() {
            match crate::params::load(&self.log_dir) {
                Ok(table) => table,
                Err(e) => {
                    return Verdict::NotTested {
                        why: vec![e.to_string()],
                    };
                }
            }
        } else {
            crate::params::defaults()
        };
        self.lab.check.judge(&Identity::new(build, &table))
    }

    /// Judges again when due; what to say (and the heartbeat's value) when the statement
    /// changed, or is a not-tested one due to be repeated (a minute on, or a ground heard
    /// again: `ground_heard` is whether one is heard now).
    fn tick(&mut self, now: Instant, ground_heard: bool) -> Option<(Severity, String, Tested)> {
        let due = |at: Option<Instant>, every: Duration| {
            at.is_none_or(|t| now.saturating_duration_since(t) >= every)
        };
        self.ground_joined |= ground_heard && !self.ground_heard;
        self.ground_heard = ground_heard;
        if !due(self.judged_at, JUDGE_EVERY) {
            return None;
        }
        self.judged_at = Some(now);
        let verdict = self.verdict();
        // On a bench with the standing override the grounds ask no per-flight override.
        let (line, tested) = match verdict.tested() {
            Tested::NotTested if self.lab.fly_untested => (
                format!(
                    "{}; flown on the bench's standing override (--fly-untested)",
                    verdict.line()
                ),
                Tested::BenchOverride,
            ),
            tested => (verdict.line(), tested),
        };
        let changed = self.line.as_deref() != Some(line.as_str());
        let repeat = tested != Tested::LabTested
            && (due(self.said_at, REPEAT_NOT_TESTED)
                || (self.ground_joined && due(self.said_to_ground_at, JOINED_QUIET)));
        self.ground_joined = false;
        self.tested = tested;
        self.line = Some(line.clone());
        if !(changed || repeat) {
            return None;
        }
        self.said_at = Some(now);
        if ground_heard {
            self.said_to_ground_at = Some(now);
        }
        let severity = match verdict {
            Verdict::LabTested { .. } => Severity::ActivityHi,
            Verdict::NotTested { .. } => Severity::WarningLo,
        };
        Some((severity, line, self.tested))
    }
}

impl Bootstrap {
    /// States the lab attestation of what the flight process would fly.
    pub fn with_lab(mut self, statement: LabStatement) -> Self {
        self.lab = Some(statement);
        self
    }

    /// The statement judged again when due, said and put in the heartbeat on a change.
    pub(super) fn state_lab(&mut self) {
        let heard = self.link.as_ref().is_some_and(|l| l.ground_fresh());
        let Some(said) = self
            .lab
            .as_mut()
            .and_then(|l| l.tick(Instant::now(), heard))
        else {
            return;
        };
        let (severity, line, tested) = said;
        if let Some(link) = &self.link {
            link.set_tested(tested);
        }
        self.say(severity, &line);
    }

    /// The statement for `status`.
    pub(super) fn lab_line(&self) -> Option<String> {
        self.lab.as_ref().and_then(|l| l.line().map(str::to_string))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::testing::{attest, lab};

    fn statement(dir: &std::path::Path) -> (LabStatement, PathBuf) {
        let program = dir.join("heli-vehicle");
        std::fs::write(&program, b"build one").unwrap();
        (
            LabStatement::new(lab(dir, false), &program, dir.to_path_buf()),
            program,
        )
    }

    #[test]
    fn said_at_first_on_a_change_and_again_each_minute_while_not_tested() {
        let dir = tempfile::tempdir().unwrap();
        let (mut s, program) = statement(dir.path());
        let t0 = Instant::now();
        let at = |secs: f64| t0 + Duration::from_secs_f64(secs);
        assert_eq!(s.line(), None);
        let (severity, line, tested) = s.tick(at(0.0), false).unwrap();
        assert_eq!((severity, tested), (Severity::WarningLo, Tested::NotTested));
        assert!(
            line.starts_with("NOT lab-tested: no lab attestation"),
            "{line}"
        );
        assert_eq!(s.line(), Some(line.as_str()));
        // Not judged again before a second, and not said again before a minute.
        attest(
            dir.path(),
            crate::lab::identity(&program, dir.path()).unwrap(),
        );
        assert_eq!(s.tick(at(0.5), false), None);
        assert_eq!(s.line(), Some(line.as_str()), "not judged yet");
        // Judged again: lab-tested now, said at once.
        let (severity, line, tested) = s.tick(at(1.0), false).unwrap();
        assert_eq!(
            (severity, tested),
            (Severity::ActivityHi, Tested::LabTested)
        );
        assert!(line.starts_with("lab-tested: build"), "{line}");
        // A lab-tested statement is not repeated.
        assert_eq!(s.tick(at(2.0), false), None);
        assert_eq!(s.tick(at(200.0), false), None);
        // A gain changed: said at the next judgement, then once a minute.
        std::fs::write(dir.path().join("params"), "HOV_VEL_P = 1.6\n").unwrap();
        let (_, line, tested) = s.tick(at(201.0), false).unwrap();
        assert_eq!(tested, Tested::NotTested);
        assert!(line.contains("HOV_VEL_P 1.6 (tested 1.4)"), "{line}");
        assert_eq!(s.tick(at(202.0), false), None);
        assert_eq!(s.tick(at(260.5), false), None);
        assert!(
            s.tick(at(261.5), false).is_some(),
            "repeated after a minute"
        );
        assert_eq!(s.tick(at(262.5), false), None);
        // A ground heard again: said at the next judgement, not a minute on; once.
        assert_eq!(s.tick(at(263.5), false), None);
        assert!(s.tick(at(263.7), true).is_none(), "not judged yet");
        assert!(
            s.tick(at(264.5), true).is_some(),
            "said to the ground that joined"
        );
        assert_eq!(s.tick(at(265.5), true), None);
        assert_eq!(
            s.tick(at(266.5), false),
            None,
            "a ground lost is not a ground joined"
        );
        // A link that comes and goes: not said again within ten seconds of the last time a
        // ground heard it.
        assert_eq!(
            s.tick(at(267.5), true),
            None,
            "3 s after the ground heard it"
        );
        assert_eq!(s.tick(at(268.5), false), None);
        assert_eq!(s.tick(at(273.5), true), None, "9 s after");
        assert_eq!(s.tick(at(274.5), false), None);
        assert!(s.tick(at(275.5), true).is_some(), "11 s after");
    }

    #[test]
    fn on_a_bench_with_the_standing_override_the_heartbeat_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let program = dir.path().join("p");
        std::fs::write(&program, b"x").unwrap();
        let mut s = LabStatement::new(lab(dir.path(), true), &program, dir.path().to_path_buf());
        let (_, line, tested) = s.tick(Instant::now(), false).unwrap();
        assert_eq!(tested, Tested::BenchOverride);
        assert!(
            line.starts_with("NOT lab-tested: no lab attestation")
                && line.ends_with("flown on the bench's standing override (--fly-untested)"),
            "{line}"
        );
    }

    #[test]
    fn an_unreadable_parameter_file_or_program_is_not_tested_with_why() {
        let dir = tempfile::tempdir().unwrap();
        let (mut s, program) = statement(dir.path());
        attest(
            dir.path(),
            crate::lab::identity(&program, dir.path()).unwrap(),
        );
        std::fs::write(dir.path().join("params"), "NOPE = 1\n").unwrap();
        let (_, line, _) = s.tick(Instant::now(), false).unwrap();
        assert!(
            line.starts_with("NOT lab-tested:") && line.contains("NOPE"),
            "{line}"
        );
        let lab = s.lab.clone();
        let mut gone = LabStatement::new(lab, &dir.path().join("none"), dir.path().to_path_buf());
        let (_, line, _) = gone.tick(Instant::now(), false).unwrap();
        assert!(line.contains("the flight software's program"), "{line}");
    }
}
