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
    let in_use = || {
        error(
            format!("in use by {}", holder(path)),
            "another flight process or stand-alone driver has this device: stop it first",
        )
    };
    if !meta.file_type().is_char_device() {
        return Err(error(
            "not a terminal device".into(),
            "give the path of a tty such as /dev/ttyS0, /dev/ttyUSB0 or a HILSim pseudo-terminal",
        ));
    }
    // Not TIOCEXCL: the flag outlives a killed process on a terminal someone else holds
    // open (the HILSim's), and would refuse the next flight process. serialport takes a
    // shared flock; it is made exclusive below.
    let port = serialport::new(path.to_string_lossy(), baud)
        .timeout(READ_TIMEOUT)
        .exclusive(false)
        .open_native()
        .map_err(|e| match e.kind() {
            // Its lock refused: another program holds the device.
            serialport::ErrorKind::NoDevice => in_use(),
            kind => error(e.to_string(), open_hint(kind)),
        })?;
    // One program per device: a second flight process reading the same IMU and writing the
    // same servo board fights the first for the helicopter. The lock is the port's own (its
    // write half shares it) and goes with its last handle, or with a killed process.
    if lock_exclusive(&port).is_err() {
        return Err(in_use());
    }
    // Whatever waited in the line's buffer before the flight began is stale: a driver stamps
    // bytes when it reads them, so old bytes would arrive as a burst of "new" samples.
    let _ = port.clear(serialport::ClearBuffer::Input);
    Ok(port)
}

/// Makes the port's shared lock exclusive, without waiting.
// nix's `Flock` owns a descriptor of its own; this lock must live and die with the port's.
#[allow(deprecated)]
fn lock_exclusive(port: &TTYPort) -> nix::Result<()> {
    use std::os::fd::AsRawFd;
    nix::fcntl::flock(
        port.as_raw_fd(),
        nix::fcntl::FlockArg::LockExclusiveNonblock,
    )
}

/// Who holds a lock on the device at `path`, as `/proc/locks` and the holder's
/// `/proc/PID/comm` say (`process 1234 (heli-vehicle)`), or `another program`.
fn holder(path: &Path) -> String {
    use std::os::unix::fs::MetadataExt;
    let Ok(meta) = std::fs::metadata(path) else {
        return "another program".into();
    };
    let dev = meta.dev();
    let (major, minor) = (nix::sys::stat::major(dev), nix::sys::stat::minor(dev));
    let id = format!("{major:02x}:{minor:02x}:{}", meta.ino());
    let pid = std::fs::read_to_string("/proc/locks")
        .ok()
        .and_then(|locks| {
            locks.lines().find_map(|line| {
                let fields: Vec<&str> = line.split_whitespace().collect();
                // `1: FLOCK  ADVISORY  READ  1234 00:19:7 0 EOF`
                let at = fields.iter().position(|f| *f == id)?;
                let pid = fields.get(at.checked_sub(1)?)?;
                (pid.parse::<u32>().ok()? != std::process::id()).then(|| pid.to_string())
            })
        });
    match pid {
        Some(pid) => {
            let comm = std::fs::read_to_string(format!("/proc/{pid}/comm")).unwrap_or_default();
            format!("process {pid} ({})", comm.trim())
        }
        None => "another program".into(),
    }
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
    fn a_device_one_program_holds_is_refused_to_another_and_free_once_it_lets_go() {
        let (_master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        let first = open(&path, 115_200).unwrap();
        // Its write half shares the lock.
        let half = clone(&first, &path).unwrap();
        // In this process the holder is not named (it is this one); the hint says what to do.
        let e = open(&path, 115_200).unwrap_err();
        assert!(e.to_string().contains("in use by"), "{e}");
        assert!(e.hint.contains("stop it first"), "{e}");
        drop(first);
        assert!(
            open(&path, 115_200).is_err(),
            "the write half still holds it"
        );
        drop(half);
        open(&path, 115_200).unwrap();
    }

    #[test]
    fn the_holder_of_a_device_is_named_by_its_process() {
        let (_master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        // flock(1) holds the device as another program would.
        // `--no-fork`: flock(1) becomes the command, so killing it lets the device go.
        let Ok(mut holder_process) = std::process::Command::new("flock")
            .args(["--nonblock", "--no-fork"])
            .arg(&path)
            .args(["sleep", "30"])
            .spawn()
        else {
            eprintln!("no flock(1) here: the holder's name is not checked");
            return;
        };
        let pid = holder_process.id();
        let mut named = String::new();
        for _ in 0..200 {
            named = holder(&path);
            if named != "another program" {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let e = open(&path, 115_200).unwrap_err();
        let _ = holder_process.kill();
        let _ = holder_process.wait();
        assert!(named.starts_with(&format!("process {pid} (")), "{named}");
        assert!(
            e.to_string()
                .contains(&format!("in use by process {pid} (")),
            "{e}"
        );
        assert_eq!(holder(Path::new("/nonexistent/tty")), "another program");
        // The holder gone, the device is free.
        open(&path, 115_200).unwrap();
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
