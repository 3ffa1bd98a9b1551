//! Opening serial ports, with errors that name the path and the likely fix.

use std::fmt;
use std::io;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serialport::{SerialPort, TTYPort};

/// How long a read waits for bytes before it returns empty-handed (so a driver thread can
/// notice it should stop).
pub const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Why a port could not be opened.
#[derive(Debug)]
pub struct PortError {
    /// The path.
    pub path: PathBuf,
    /// What went wrong.
    pub reason: String,
    /// What usually fixes it.
    pub hint: &'static str,
}

impl fmt::Display for PortError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "serial port {}: {} ({})",
            self.path.display(),
            self.reason,
            self.hint
        )
    }
}

impl std::error::Error for PortError {}

/// Opens `path` as a raw 8N1 serial line at `baud`.
pub fn open(path: &Path, baud: u32) -> Result<TTYPort, PortError> {
    let error = |reason: String, hint: &'static str| PortError {
        path: path.to_path_buf(),
        reason,
        hint,
    };
    let meta = std::fs::metadata(path).map_err(|e| {
        let (reason, hint) = lookup_failure(&e);
        error(reason, hint)
    })?;
    if !meta.file_type().is_char_device() {
        return Err(error(
            "not a terminal device".into(),
            "give the path of a tty such as /dev/ttyS0, /dev/ttyUSB0 or a HILSim pseudo-terminal",
        ));
    }
    // Not TIOCEXCL: the flag outlives a killed process on a terminal someone else holds
    // open (the HILSim's), and would refuse the next flight process. serialport takes a
    // shared flock instead.
    let port = serialport::new(path.to_string_lossy(), baud)
        .timeout(READ_TIMEOUT)
        .exclusive(false)
        .open_native()
        .map_err(|e| {
            let hint = open_hint(e.kind());
            error(e.to_string(), hint)
        })?;
    // Whatever waited in the line's buffer before the flight began is stale: a driver stamps
    // bytes when it reads them, so old bytes would arrive as a burst of "new" samples.
    let _ = port.clear(serialport::ClearBuffer::Input);
    Ok(port)
}

/// What to do about a permission refused.
const DIALOUT_HINT: &str = "add the user to the `dialout` group, or run as root";

/// What an operator reads when the path cannot be looked up: the reason and what to do.
fn lookup_failure(e: &io::Error) -> (String, &'static str) {
    match e.kind() {
        io::ErrorKind::NotFound => (
            "no such device".into(),
            "is the device plugged in and the path right? for HIL, is `heli hilsim --ptys DIR` running?",
        ),
        io::ErrorKind::PermissionDenied => ("permission denied".into(), DIALOUT_HINT),
        _ => (e.to_string(), "check the path"),
    }
}

/// What an operator is told to do when a terminal device is there but will not open.
fn open_hint(kind: serialport::ErrorKind) -> &'static str {
    match kind {
        serialport::ErrorKind::NoDevice => "is another program using the port?",
        serialport::ErrorKind::Io(io::ErrorKind::PermissionDenied) => DIALOUT_HINT,
        _ => "is it a serial device?",
    }
}

/// Reads what is there (up to `buf.len()` bytes), waiting at most [`READ_TIMEOUT`]; `Ok(0)`
/// when nothing came.
pub fn read_some(port: &mut TTYPort, buf: &mut [u8]) -> io::Result<usize> {
    match io::Read::read(port, buf) {
        Ok(n) => Ok(n),
        Err(e) if e.kind() == io::ErrorKind::TimedOut || e.kind() == io::ErrorKind::WouldBlock => {
            Ok(0)
        }
        Err(e) => Err(e),
    }
}

/// Writes all of `bytes` into the port's output buffer. It does not wait for them to be
/// sent (`tcdrain`): 12 bytes take 3 ms on the wire at 38400 baud, which the control loop
/// must not spend waiting.
pub fn write_all(port: &mut TTYPort, bytes: &[u8]) -> io::Result<()> {
    io::Write::write_all(port, bytes)
}

/// A second handle on the same port at `path` (for the loop's writes while a driver thread
/// reads); where it cannot be made, an error naming the port.
pub fn clone(port: &TTYPort, path: &Path) -> Result<TTYPort, PortError> {
    port.try_clone_native().map_err(|e| PortError {
        path: path.to_path_buf(),
        reason: format!("open, but its write half could not be made ({e})"),
        hint: "no file descriptor left? the port is opened again",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_port_and_a_file_that_is_no_tty_say_so() {
        let e = open(Path::new("/nonexistent/ttyHELI"), 115_200).unwrap_err();
        assert!(e.to_string().contains("no such device"), "{e}");
        assert!(e.to_string().contains("/nonexistent/ttyHELI"));
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, b"x").unwrap();
        let e = open(&file, 115_200).unwrap_err();
        assert!(e.to_string().contains("not a terminal device"), "{e}");
    }

    #[test]
    fn each_failure_to_open_says_what_to_do() {
        // Root opens anything, so the permission answers are checked on the mapping.
        let (reason, hint) = lookup_failure(&io::Error::from(io::ErrorKind::PermissionDenied));
        assert_eq!(reason, "permission denied");
        assert!(hint.contains("dialout"), "{hint}");
        let (reason, hint) = lookup_failure(&io::Error::from(io::ErrorKind::NotFound));
        assert_eq!(reason, "no such device");
        assert!(hint.contains("heli hilsim --ptys"), "{hint}");
        let (reason, hint) = lookup_failure(&io::Error::other("disk on fire"));
        assert_eq!((reason.as_str(), hint), ("disk on fire", "check the path"));
        assert!(open_hint(serialport::ErrorKind::NoDevice).contains("another program"));
        let denied = serialport::ErrorKind::Io(io::ErrorKind::PermissionDenied);
        assert!(open_hint(denied).contains("dialout"));
        let other = serialport::ErrorKind::Io(io::ErrorKind::InvalidInput);
        assert_eq!(open_hint(other), "is it a serial device?");
        assert_eq!(
            open_hint(serialport::ErrorKind::InvalidInput),
            "is it a serial device?"
        );
    }

    #[test]
    fn a_pseudo_terminal_opens_and_carries_bytes_unchanged() {
        let (mut master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        let mut port = open(&path, 115_200).unwrap();
        let bytes: Vec<u8> = (0..=255u8).collect();
        write_all(&mut master, &bytes).unwrap();
        let mut got = Vec::new();
        let mut buf = [0u8; 512];
        for _ in 0..20 {
            let n = read_some(&mut port, &mut buf).unwrap();
            got.extend_from_slice(&buf[..n]);
            if got.len() >= bytes.len() {
                break;
            }
        }
        assert_eq!(got, bytes, "raw mode: no echo, no translation");
    }
}
