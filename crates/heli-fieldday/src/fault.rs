//! The faults of a field day and the moments they strike: what each is, how it is injected,
//! what the operator must be told, and how long the flight goes on after it.

use std::fmt;
use std::time::Duration;

use crate::FieldDayError;

/// One single fault of a field day.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// `kill -9` of the flight process, three times in a minute (20 s apart).
    KillFlight,
    /// `kill -9` of the bootstrap; the init system starts it again 0.2 s later.
    KillBootstrap,
    /// The log storage fills (a small tmpfs filled to the last byte when run as root, else
    /// a file-size limit on the flight process: its writes fail) for 60 s, then frees.
    DiskFull,
    /// The log storage turns read-only (the tmpfs remounted read-only when run as root, else
    /// the directory made read-only and the writes refused) for 15 s, then writable again.
    ReadOnly,
    /// The IMU's serial port hung up (`TIOCVHANGUP`: every open file of the terminal is cut
    /// off, as an unplugged USB adapter) for 1 s, then it can be opened again.
    PortHangup,
    /// The HILSim stopped (`SIGSTOP`) for this many milliseconds, then continued: every
    /// device line silent at once.
    Stall(u32),
    /// The servo controller board sends nothing for 3 s.
    ServoSilent,
    /// The flight computer browns out: the bootstrap and the flight process die at once, its
    /// RAM (the fallback directory) is lost, and it powers on again 0.5 s later.
    Brownout,
}

/// Every fault, in the campaign's order.
pub const ALL: [Fault; 10] = [
    Fault::KillFlight,
    Fault::KillBootstrap,
    Fault::DiskFull,
    Fault::ReadOnly,
    Fault::PortHangup,
    Fault::Stall(200),
    Fault::Stall(1000),
    Fault::Stall(3000),
    Fault::ServoSilent,
    Fault::Brownout,
];

/// How long the log storage stays full: a minute, through which the flight process's memory
/// must stay flat (within [`MEMORY_GROWTH_MIB`]).
pub const DISK_FULL: Duration = Duration::from_secs(60);
/// How long the log storage stays read-only.
pub const READ_ONLY: Duration = Duration::from_secs(15);
/// How much the flight process's memory may grow while the disk is full (MiB).
pub const MEMORY_GROWTH_MIB: f64 = 2.0;
/// How long the IMU's port stays hung up.
pub const HANGUP: Duration = Duration::from_secs(1);
/// How long the servo board is silent.
pub const SERVO_SILENT_S: f64 = 3.0;
/// The interval of the three kills of the flight process.
pub const KILL_EVERY: Duration = Duration::from_secs(20);
/// How long the init system takes to start the bootstrap again.
pub const INIT_RESTART: Duration = Duration::from_millis(200);
/// How long the flight computer is without power in a brown-out.
pub const POWER_OFF: Duration = Duration::from_millis(500);

impl Fault {
    /// The fault's name on the command line and in the table.
    pub fn name(self) -> String {
        match self {
            Fault::KillFlight => "kill-flight".into(),
            Fault::KillBootstrap => "kill-bootstrap".into(),
            Fault::DiskFull => "disk-full".into(),
            Fault::ReadOnly => "read-only".into(),
            Fault::PortHangup => "port-hangup".into(),
            Fault::Stall(ms) => format!("stall-{}", f64::from(ms) / 1000.0),
            Fault::ServoSilent => "servo-silent".into(),
            Fault::Brownout => "brownout".into(),
        }
    }

    /// The fault of a name ([`Fault::name`]).
    pub fn parse(name: &str) -> Result<Self, FieldDayError> {
        ALL.into_iter().find(|f| f.name() == name).ok_or_else(|| {
            FieldDayError::Usage(format!(
                "no fault '{name}': the faults are {}",
                ALL.map(Fault::name).join(", ")
            ))
        })
    }

    /// What is done, in words, for the table.
    pub fn injected(self) -> String {
        match self {
            Fault::KillFlight => "`kill -9` of the flight process, 3 times 20 s apart".into(),
            Fault::KillBootstrap => {
                "`kill -9` of the bootstrap, started again 0.2 s later (as systemd does)".into()
            }
            Fault::DiskFull => "log storage full for 60 s".into(),
            Fault::ReadOnly => "log storage read-only for 15 s".into(),
            Fault::PortHangup => "IMU port hung up (`TIOCVHANGUP`) for 1 s".into(),
            Fault::Stall(ms) => format!(
                "HILSim stopped (`SIGSTOP`) for {} s",
                f64::from(ms) / 1000.0
            ),
            Fault::ServoSilent => "servo board silent for 3 s".into(),
            Fault::Brownout => {
                "bootstrap and flight process killed at once, RAM lost, power back after 0.5 s"
                    .into()
            }
        }
    }

    /// What the operator must have been told (each a part of a line the bootstraps said:
    /// their lines are the ground station's status texts).
    pub fn told(self) -> &'static [&'static str] {
        match self {
            Fault::KillFlight => &[
                "CRASHED: signal 9",
                "restarting the flight process",
                "aligned in the air",
            ],
            Fault::KillBootstrap => &["took back the flight process"],
            Fault::DiskFull | Fault::ReadOnly => &["flight log ", "the storage takes writes again"],
            Fault::PortHangup => &["driver thread of imu died", "aligned in the air"],
            Fault::Stall(ms) if ms >= 1000 => {
                &["imu silent", "estimate invalid", "aligned in the air"]
            }
            Fault::Stall(_) => &["imu silent", "imu ok"],
            Fault::ServoSilent => &["uplink silent", "uplink ok"],
            Fault::Brownout => &[
                "power-on with a fresh warm-start record",
                "aligned in the air",
            ],
        }
    }

    /// How long the trial goes on after the fault was injected, for the flight to settle.
    pub fn settle(self) -> Duration {
        match self {
            Fault::KillFlight => KILL_EVERY * 2 + Duration::from_secs(20),
            Fault::DiskFull | Fault::ReadOnly => self.storage_fault() + Duration::from_secs(10),
            _ => Duration::from_secs(20),
        }
    }

    /// How long a storage fault lasts (zero for the others).
    pub fn storage_fault(self) -> Duration {
        match self {
            Fault::DiskFull => DISK_FULL,
            Fault::ReadOnly => READ_ONLY,
            _ => Duration::ZERO,
        }
    }

    /// Whether the fault needs the log directory on a storage of its own.
    pub fn storage(self) -> bool {
        matches!(self, Fault::DiskFull | Fault::ReadOnly)
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// When the fault strikes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Hovering: the `hover` plan, 3 s into its hold.
    Hover,
    /// Rolling: the `rolls` plan, as its first roll begins.
    Rolls,
}

/// Both phases.
pub const PHASES: [Phase; 2] = [Phase::Hover, Phase::Rolls];

impl Phase {
    /// The phase's name, which is also the scenario and the plan flown.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Hover => "hover",
            Phase::Rolls => "rolls",
        }
    }

    /// The phase of a name.
    pub fn parse(name: &str) -> Result<Self, FieldDayError> {
        PHASES
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| FieldDayError::Usage(format!("no phase '{name}': hover or rolls")))
    }

    /// The line the flight process says when the phase begins, and how long after it the
    /// fault strikes.
    pub fn cue(self) -> (&'static str, Duration) {
        match self {
            Phase::Hover => ("phase hold", Duration::from_secs(3)),
            Phase::Rolls => ("phase rolling", Duration::ZERO),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fault_and_phase_is_named_and_read_back() {
        for f in ALL {
            assert_eq!(Fault::parse(&f.name()).unwrap(), f);
            assert!(!f.told().is_empty() && !f.injected().is_empty());
        }
        assert_eq!(
            ALL.map(Fault::name),
            [
                "kill-flight",
                "kill-bootstrap",
                "disk-full",
                "read-only",
                "port-hangup",
                "stall-0.2",
                "stall-1",
                "stall-3",
                "servo-silent",
                "brownout"
            ]
        );
        for p in PHASES {
            assert_eq!(Phase::parse(p.name()).unwrap(), p);
        }
        let e = Fault::parse("meteor").unwrap_err().to_string();
        assert!(
            e.contains("no fault 'meteor'") && e.contains("brownout"),
            "{e}"
        );
        assert!(Phase::parse("loop").is_err());
    }

    #[test]
    fn the_three_kills_and_the_storage_faults_are_waited_out() {
        assert!(Fault::KillFlight.settle() > KILL_EVERY * 2);
        assert!(Fault::DiskFull.settle() > DISK_FULL);
        assert!(Fault::ReadOnly.settle() > READ_ONLY);
        assert_eq!(Fault::Stall(1000).storage_fault(), Duration::ZERO);
        assert!(Fault::DiskFull.storage() && Fault::ReadOnly.storage());
        assert!(!Fault::Stall(3000).storage());
    }
}
