//! What a trial is judged by besides the HILSim's truth: the logs, read by the official
//! Python MCAP reader and timed against the fault, and what the operator was told.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Serialize;

use crate::FieldDayError;

/// How much of a log a fault may cost: 100 ms and one flush interval of the writer, with
/// 50 ms for the machine's scheduling.
pub const LOSS_ALLOWED_MS: f64 = 100.0 + heli_log::FLUSH_EVERY_US as f64 / 1000.0 + 50.0;

/// The official reader, run over every message of a log: prints the count.
const READ_ALL: &str = "import sys\nfrom mcap.reader import make_reader\nn = 0\nwith open(sys.argv[1], 'rb') as f:\n    for _ in make_reader(f).iter_messages():\n        n += 1\nprint(n)\n";

/// Whether `python` has the official `mcap` package.
pub fn python_has_mcap(python: &Path) -> bool {
    Command::new(python)
        .args(["-c", "import mcap.reader"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The number of messages the official Python reader reads from `log`, or its error.
pub fn python_reads(python: &Path, log: &Path) -> Result<u64, String> {
    let out = Command::new(python)
        .args(["-c", READ_ALL])
        .arg(log)
        .output()
        .map_err(|e| format!("running {}: {e}", python.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").trim();
        return Err(format!("the Python reader failed: {last}"));
    }
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .map_err(|e| format!("the Python reader printed no count: {e}"))
}

/// The wall-clock time (Unix ms) of a log's last message: its flight's wall-clock start
/// plus the flight clock of the message.
pub fn wall_end_ms(log: &Path) -> Option<f64> {
    let contents = heli_log::reader::read(&std::fs::read(log).ok()?);
    let start: f64 = contents
        .metadata
        .iter()
        .find_map(|m| m.entries.get("wall_clock_start_unix_ms"))?
        .parse()
        .ok()?;
    let last_us = contents.messages.iter().map(|m| m.t_us).max()?;
    Some(start + last_us as f64 / 1000.0)
}

/// One log, as the official reader and the fault's time see it.
#[derive(Clone, Debug, Serialize)]
pub struct LogCheck {
    /// The file's name.
    pub file: String,
    /// Messages the official Python reader read.
    pub python_messages: Option<u64>,
    /// Why it could not read the file.
    pub python_error: Option<String>,
    /// How long before the fault the log ends (ms; negative: it goes on after the fault).
    pub ends_before_fault_ms: Option<f64>,
}

impl LogCheck {
    /// Reads `log` with `python` and times its end against the fault at `fault_ms` (Unix ms).
    pub fn of(python: &Path, log: &Path, fault_ms: f64) -> Self {
        let read = python_reads(python, log);
        Self {
            file: log
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            python_messages: read.as_ref().ok().copied(),
            python_error: read.err(),
            ends_before_fault_ms: wall_end_ms(log).map(|end| fault_ms - end),
        }
    }

    /// Opened by the official reader with messages in it.
    pub fn readable(&self) -> bool {
        self.python_messages.is_some_and(|n| n > 0)
    }
}

/// Copies every `.mcap` file of `from` into `to`; the copies.
pub fn copy_logs(from: &Path, to: &Path) -> Result<Vec<PathBuf>, FieldDayError> {
    std::fs::create_dir_all(to)
        .map_err(|e| FieldDayError::Io(format!("creating {}", to.display()), e))?;
    let mut copies = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(from)
        .map_err(|e| FieldDayError::Io(format!("reading {}", from.display()), e))?
        .filter_map(|e| Some(e.ok()?.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    entries.sort();
    for log in entries {
        let Some(name) = log.file_name() else {
            continue;
        };
        let copy = to.join(name);
        std::fs::copy(&log, &copy)
            .map_err(|e| FieldDayError::Io(format!("copying {}", log.display()), e))?;
        copies.push(copy);
    }
    Ok(copies)
}

/// The parts of `told` (what the fault requires) that no line of `lines` contains.
pub fn untold<'a>(told: &[&'a str], lines: &[String]) -> Vec<&'a str> {
    told.iter()
        .copied()
        .filter(|needle| !lines.iter().any(|l| l.contains(needle)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_the_operator_was_not_told_is_named() {
        let lines = vec![
            "bootstrap: flight process CRASHED: signal 9 (SIGKILL)".to_string(),
            "bootstrap: state idle".to_string(),
        ];
        assert!(untold(&["CRASHED: signal 9"], &lines).is_empty());
        assert_eq!(
            untold(&["CRASHED: signal 9", "restarting"], &lines),
            ["restarting"]
        );
    }

    #[test]
    fn a_log_that_is_not_one_is_not_readable_and_has_no_end() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("flight_x.mcap");
        std::fs::write(&log, b"not a log").unwrap();
        assert_eq!(wall_end_ms(&log), None);
        let check = LogCheck::of(Path::new("/nonexistent/python"), &log, 0.0);
        assert!(!check.readable());
        assert!(check.python_error.unwrap().contains("running"));
        let copies = copy_logs(dir.path(), &dir.path().join("copies")).unwrap();
        assert_eq!(copies.len(), 1);
    }
}
