//! The control loop's writes to the devices (servo commands to the servo controller board,
//! handshakes to the altimeter): why one failed, and the tally of failures per port.
//!
//! A failed write is a command lost, so each port's failures are said, not only counted: the
//! first of a run of failures with its reason, the write that works again after them, and at
//! the end of the flight each port's total. One port's failures never hide another's (an
//! absent altimeter's closed port does not stand for the servo board's).
//!
//! A lost command changes what the helicopter does, so a failure is said at
//! [`Severity::WarningHi`] (the ground pins it) and a recovery at [`Severity::ActivityHi`];
//! the control loop also writes both into the flight's log.
//!
//! What it is not: the ports themselves ([`crate::threads::Writers`] holds their write halves).

use heli_fsw::core::Severity;
use heli_types::Port;

/// Why a write to a device did not go out.
#[derive(Debug)]
pub enum WriteError {
    /// The port is not open (its driver has not opened it, or lost it and is reopening it).
    NotOpen,
    /// The port is open and the write failed.
    Io(std::io::Error),
}

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WriteError::NotOpen => f.write_str("port not open"),
            WriteError::Io(e) => write!(f, "{e}"),
        }
    }
}

/// How many runs of failures of one port are said (their first failure and their end); a
/// port that keeps failing and recovering says no more after them, counted to the end.
pub const RUNS_SAID: u64 = 5;

/// Something to say about a port's writes, with how much it matters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Said {
    /// [`Severity::WarningHi`] for commands being lost, [`Severity::ActivityHi`] when they go
    /// out again.
    pub severity: Severity,
    /// What to say.
    pub text: String,
}

impl Said {
    fn lost(text: String) -> Self {
        Self {
            severity: Severity::WarningHi,
            text,
        }
    }
}

/// One port's failed writes.
#[derive(Debug, Default, Clone, Copy)]
struct PortTally {
    /// Failures since the last write that went out.
    run: u64,
    /// Runs of failures in the flight.
    runs: u64,
    /// Failures in the flight.
    total: u64,
}

/// The failed writes of a flight, per port.
#[derive(Debug, Default)]
pub struct WriteTally {
    ports: [PortTally; Port::ALL.len()],
}

impl WriteTally {
    fn of(&mut self, port: Port) -> Option<&mut PortTally> {
        let i = Port::ALL.iter().position(|p| *p == port)?;
        self.ports.get_mut(i)
    }

    /// Counts the outcome of a write to `port`; returns what to say: the first failure of a
    /// run, with its reason, or the first write that goes out after a run of failures (for
    /// the port's first [`RUNS_SAID`] runs).
    pub fn record(&mut self, port: Port, outcome: &Result<(), WriteError>) -> Option<Said> {
        let tally = self.of(port)?;
        match outcome {
            Err(why) => {
                let first = tally.run == 0;
                tally.run = tally.run.saturating_add(1);
                tally.total = tally.total.saturating_add(1);
                if !first {
                    return None;
                }
                tally.runs = tally.runs.saturating_add(1);
                let name = port.name();
                match tally.runs.cmp(&RUNS_SAID) {
                    std::cmp::Ordering::Less => Some(Said::lost(format!(
                        "write to {name} failed ({why}): commands to it are being lost"
                    ))),
                    std::cmp::Ordering::Equal => Some(Said::lost(format!(
                        "write to {name} failed ({why}): commands to it are being lost (its {RUNS_SAID}th run of failures: more are counted, not said)"
                    ))),
                    std::cmp::Ordering::Greater => None,
                }
            }
            Ok(()) if tally.run > 0 => {
                let lost = std::mem::take(&mut tally.run);
                (tally.runs <= RUNS_SAID).then(|| Said {
                    severity: Severity::ActivityHi,
                    text: format!(
                        "writes to {} go out again, after {lost} failed",
                        port.name()
                    ),
                })
            }
            Ok(()) => None,
        }
    }

    /// Failed writes in the flight, all ports.
    pub fn total(&self) -> u64 {
        self.ports
            .iter()
            .fold(0u64, |n, t| n.saturating_add(t.total))
    }

    /// The flight's closing account, if any write failed: each port's failures (commands
    /// lost: [`Severity::WarningHi`]).
    pub fn summary(&self) -> Option<Said> {
        let ports: Vec<String> = Port::ALL
            .iter()
            .zip(&self.ports)
            .filter(|(_, t)| t.total > 0)
            .map(|(p, t)| format!("{} {}", p.name(), t.total))
            .collect();
        (!ports.is_empty()).then(|| {
            Said::lost(format!(
                "{} device writes failed during the flight ({})",
                self.total(),
                ports.join(", ")
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(said: Option<Said>) -> Option<String> {
        said.map(|s| s.text)
    }

    fn broken() -> Result<(), WriteError> {
        Err(WriteError::Io(std::io::Error::from_raw_os_error(5)))
    }

    #[test]
    fn each_port_says_its_first_failure_with_why_and_its_recovery() {
        let mut tally = WriteTally::default();
        assert_eq!(tally.record(Port::Scb, &Ok(())), None);
        assert_eq!(tally.summary(), None);
        // The altimeter's closed port is said; the servo board's failure is said too, with
        // its own reason, not hidden behind the altimeter's.
        let baro = tally.record(Port::Baro, &Err(WriteError::NotOpen)).unwrap();
        assert_eq!(
            baro.text,
            "write to baro failed (port not open): commands to it are being lost"
        );
        assert_eq!(baro.severity, Severity::WarningHi);
        assert_eq!(tally.record(Port::Baro, &Err(WriteError::NotOpen)), None);
        let scb = tally.record(Port::Scb, &broken()).unwrap();
        assert_eq!(scb.severity, Severity::WarningHi);
        let scb = scb.text;
        assert!(
            scb.starts_with("write to scb failed (") && scb.contains("os error 5"),
            "{scb}"
        );
        assert_eq!(tally.record(Port::Scb, &broken()), None);
        assert_eq!(tally.record(Port::Scb, &broken()), None);
        // The servo board's writes go out again: said once, with the run lost.
        assert_eq!(
            tally.record(Port::Scb, &Ok(())),
            Some(Said {
                severity: Severity::ActivityHi,
                text: "writes to scb go out again, after 3 failed".into()
            })
        );
        assert_eq!(tally.record(Port::Scb, &Ok(())), None);
        // A new run of failures is said again.
        assert!(tally.record(Port::Scb, &broken()).is_some());
        assert_eq!(tally.total(), 6);
        assert_eq!(
            tally.summary(),
            Some(Said {
                severity: Severity::WarningHi,
                text: "6 device writes failed during the flight (scb 4, baro 2)".into()
            })
        );
    }

    #[test]
    fn a_port_that_keeps_failing_and_recovering_says_its_first_runs_and_counts_the_rest() {
        let mut tally = WriteTally::default();
        let mut said = Vec::new();
        for _ in 0..100 {
            said.extend(text(tally.record(Port::Scb, &broken())));
            said.extend(text(tally.record(Port::Scb, &Ok(()))));
        }
        // Each said run is its failure and its end; the last said run says so.
        assert_eq!(said.len() as u64, 2 * RUNS_SAID, "{said:#?}");
        assert!(
            said[2 * RUNS_SAID as usize - 2].ends_with("more are counted, not said)"),
            "{said:#?}"
        );
        assert!(!said[2 * RUNS_SAID as usize - 4].contains("more are counted"));
        assert_eq!(
            text(tally.summary()).as_deref(),
            Some("100 device writes failed during the flight (scb 100)")
        );
        // Another port's runs are its own.
        assert!(tally.record(Port::Baro, &broken()).is_some());
    }
}
