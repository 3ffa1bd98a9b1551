//! What can go wrong in the onboard program outside the flight logic, by kind.
//!
//! Every variant names what failed and where (a path, a port, a thread, a line); its
//! `Display` is the text the operator reads (the command line's error, the bootstrap's
//! message to the ground).

use std::fmt;
use std::io;
use std::path::PathBuf;

use heli_log::LogError;

use crate::adc::AdcError;
use crate::port::PortError;

/// An error of the onboard program's runtime.
#[derive(Debug)]
pub enum VehicleError {
    /// A file could not be read, written or created.
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// A text (a file's, a line of one, an argument) is not what it should be.
    Invalid {
        /// What was read (`warm-start file /var/heli/warm.txt`, `line 3`, `gpio`); empty
        /// when the problem names it.
        what: String,
        /// What is wrong with it.
        problem: String,
    },
    /// An error met in a named place: the place (`warm-start file …`, `hotswap`), then the
    /// error, which keeps its kind.
    Within {
        /// Where.
        what: String,
        /// The error.
        error: Box<VehicleError>,
    },
    /// A serial port could not be opened.
    Port(PortError),
    /// An analog channel could not be read.
    Adc(AdcError),
    /// A GPIO line could not be requested or read.
    Gpio {
        /// The line (`/dev/gpiochip0:17`).
        line: String,
        /// Why.
        source: gpiocdev::Error,
    },
    /// A device's port failed while its driver talked to it.
    DeviceIo {
        /// What the driver was doing (`reading the device`).
        doing: &'static str,
        /// Why.
        source: io::Error,
    },
    /// A device never gave what its driver needs.
    Device(&'static str),
    /// The flight log could not be created or written.
    Log {
        /// The log's file, when there is one to name.
        path: Option<PathBuf>,
        /// Why.
        source: LogError,
        /// What the operator can do about it (empty when nothing).
        hint: &'static str,
    },
    /// A thread could not be started.
    Thread {
        /// The thread's job (`imu`, `control`, `logger`).
        name: String,
        /// Why.
        source: io::Error,
    },
    /// A thread panicked.
    Panicked(&'static str),
    /// The bootstrap's control socket could not be served.
    Socket {
        /// The socket.
        path: PathBuf,
        /// Why; `None` when another bootstrap answers on it.
        source: Option<io::Error>,
    },
    /// The flight process could not be started.
    Child(ChildProblem),
}

/// Why the bootstrap could not start the flight process.
#[derive(Debug)]
pub enum ChildProblem {
    /// No flight process program is configured.
    NoProgram,
    /// The program could not be started.
    Spawn(io::Error),
    /// The thread reading its reports could not be started.
    Reader(io::Error),
}

impl VehicleError {
    /// A text's problem, named.
    pub fn invalid(what: impl Into<String>, problem: impl fmt::Display) -> Self {
        VehicleError::Invalid {
            what: what.into(),
            problem: problem.to_string(),
        }
    }

    /// A file's error.
    pub fn file(path: impl Into<PathBuf>, source: io::Error) -> Self {
        VehicleError::File {
            path: path.into(),
            source,
        }
    }

    /// The same error read in a named place (`warm-start file …: line 3: …`).
    #[must_use]
    pub fn within(self, what: impl fmt::Display) -> Self {
        VehicleError::Within {
            what: what.to_string(),
            error: Box::new(self),
        }
    }
}

impl fmt::Display for VehicleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VehicleError::File { path, source } => write!(f, "{}: {source}", path.display()),
            VehicleError::Invalid { what, problem } if what.is_empty() => f.write_str(problem),
            VehicleError::Invalid { what, problem } => write!(f, "{what}: {problem}"),
            VehicleError::Within { what, error } => write!(f, "{what}: {error}"),
            VehicleError::Port(e) => e.fmt(f),
            VehicleError::Adc(e) => e.fmt(f),
            VehicleError::Gpio { line, source } => write!(f, "{line}: {source}"),
            VehicleError::DeviceIo { doing, source } => write!(f, "{doing}: {source}"),
            VehicleError::Device(problem) => f.write_str(problem),
            VehicleError::Log {
                path: Some(path),
                source,
                hint,
            } => write!(f, "flight log {}: {source}{hint}", path.display()),
            VehicleError::Log {
                path: None, source, ..
            } => source.fmt(f),
            VehicleError::Thread { name, source } => {
                write!(f, "starting the {name} thread: {source}")
            }
            VehicleError::Panicked(what) => write!(f, "the {what} panicked"),
            VehicleError::Socket { path, source: None } => write!(
                f,
                "control socket {}: another bootstrap is listening",
                path.display()
            ),
            VehicleError::Socket {
                path,
                source: Some(e),
            } => write!(f, "control socket {}: {e}", path.display()),
            VehicleError::Child(ChildProblem::NoProgram) => {
                f.write_str("no flight process program configured")
            }
            VehicleError::Child(ChildProblem::Spawn(e)) => {
                write!(f, "starting the flight process: {e}")
            }
            VehicleError::Child(ChildProblem::Reader(e)) => e.fmt(f),
        }
    }
}

impl std::error::Error for VehicleError {}

impl From<PortError> for VehicleError {
    fn from(e: PortError) -> Self {
        VehicleError::Port(e)
    }
}

impl From<AdcError> for VehicleError {
    fn from(e: AdcError) -> Self {
        VehicleError::Adc(e)
    }
}

impl From<LogError> for VehicleError {
    fn from(source: LogError) -> Self {
        VehicleError::Log {
            path: None,
            source,
            hint: "",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_names_what_and_where() {
        let e = VehicleError::file(
            "/var/heli/params.txt",
            io::Error::from(io::ErrorKind::PermissionDenied),
        );
        assert!(e.to_string().starts_with("/var/heli/params.txt: "), "{e}");
        let e = VehicleError::invalid("line 3", "unknown key 'x'").within("warm.txt");
        assert_eq!(e.to_string(), "warm.txt: line 3: unknown key 'x'");
        assert_eq!(
            VehicleError::invalid("", "no 'start' line").to_string(),
            "no 'start' line"
        );
        let e = VehicleError::Thread {
            name: "imu".into(),
            source: io::Error::from(io::ErrorKind::OutOfMemory),
        };
        assert!(
            e.to_string().starts_with("starting the imu thread: "),
            "{e}"
        );
        let e = VehicleError::Socket {
            path: "/run/heli.sock".into(),
            source: None,
        };
        assert_eq!(
            e.to_string(),
            "control socket /run/heli.sock: another bootstrap is listening"
        );
        assert_eq!(
            VehicleError::Panicked("control loop").to_string(),
            "the control loop panicked"
        );
    }
}
