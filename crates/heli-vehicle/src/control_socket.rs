//! The bootstrap's control socket as a system service keeps one: in a private directory
//! (`$XDG_RUNTIME_DIR/heli`, `/run/heli` for root, else a `heli-<uid>` directory of the
//! temporary directory made `0700`), `0600` after it is bound, every peer's credentials
//! checked against the vehicle's user, a path another user put there refused rather than
//! replaced, and every request bounded: one line of at most [`MAX_LINE_BYTES`], read within
//! [`REQUEST_DEADLINE`], at most [`MAX_CONNECTIONS`] at once — and every line answered.
//!
//! What it is not: the requests themselves (`crate::ctl`) or what the bootstrap does with them.

use std::fs;
use std::io::{self, Read};
use std::os::unix::fs::{DirBuilderExt, FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The longest request line read (bytes, newline included); a longer one is refused.
pub const MAX_LINE_BYTES: usize = 4096;

/// How long a client has to send its whole request line.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(2);

/// Control connections served at once; more are refused at once, with a reply.
pub const MAX_CONNECTIONS: usize = 16;

/// How long a listener waits after a failed accept before the next: a failure that
/// repeats at once (no file descriptor left, no memory) must not spin a core.
pub const ACCEPT_BACK_OFF: Duration = Duration::from_millis(100);

/// A listener's failed accepts: the first of a spell is said with why, and the first
/// accept after it with how many failed; every failure is counted.
#[derive(Debug, Default)]
pub struct AcceptErrors {
    /// The failures since the last accept that worked.
    spell: heli_types::Spell,
}

impl AcceptErrors {
    /// An accept failed with `e`: what to say, for the first failure of a spell.
    pub fn failed(&mut self, e: &io::Error) -> Option<String> {
        self.spell.failed().then(|| {
            format!(
                "accept failed ({e}): trying again every {} ms",
                ACCEPT_BACK_OFF.as_millis()
            )
        })
    }

    /// An accept worked: what to say, after a spell of failures.
    pub fn accepted(&mut self) -> Option<String> {
        self.spell
            .worked()
            .map(|run| format!("accepts again, after {run} failed"))
    }

    /// The outcome of an accept on `socket` (its name, for what is said on standard
    /// error): the connection, or `None` after saying a spell's first failure and waiting
    /// [`ACCEPT_BACK_OFF`].
    pub fn take<T>(&mut self, socket: &str, outcome: io::Result<T>) -> Option<T> {
        let (said, taken) = match outcome {
            Ok(connection) => (self.accepted(), Some(connection)),
            Err(e) => (self.failed(&e), None),
        };
        if let Some(note) = said {
            eprintln!("{socket}: {note}");
        }
        if taken.is_none() {
            std::thread::sleep(ACCEPT_BACK_OFF);
        }
        taken
    }
}

/// The name of the socket in its directory.
const SOCKET_NAME: &str = "vehicle.sock";

/// The user this process runs as.
pub fn effective_uid() -> u32 {
    nix::unistd::geteuid().as_raw()
}

/// Where the control socket is when none is given: `$XDG_RUNTIME_DIR/heli/vehicle.sock`,
/// `/run/heli/vehicle.sock` for root, else `<temporary directory>/heli-<uid>/vehicle.sock`.
pub fn default_path() -> PathBuf {
    socket_path(
        std::env::var_os("XDG_RUNTIME_DIR"),
        effective_uid(),
        &std::env::temp_dir(),
    )
}

/// [`default_path`] for a runtime directory (`XDG_RUNTIME_DIR`, if set), a user and a
/// temporary directory.
fn socket_path(runtime_dir: Option<std::ffi::OsString>, uid: u32, temp_dir: &Path) -> PathBuf {
    let dir = match runtime_dir.filter(|d| !d.is_empty()) {
        Some(runtime) => PathBuf::from(runtime).join("heli"),
        None if uid == 0 => PathBuf::from("/run/heli"),
        None => temp_dir.join(format!("heli-{uid}")),
    };
    dir.join(SOCKET_NAME)
}

/// Why the socket's place cannot be trusted or used.
#[derive(Debug)]
pub enum Unsafe {
    /// The directory could not be made or read.
    Directory(PathBuf, io::Error),
    /// Another user can replace what is in the directory.
    DirectoryOpen(PathBuf, String),
    /// Something that is not ours, or not a socket, is at the socket's path.
    Squatted(PathBuf, String),
}

impl std::fmt::Display for Unsafe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unsafe::Directory(dir, e) => write!(f, "directory {}: {e}", dir.display()),
            Unsafe::DirectoryOpen(dir, why) => write!(
                f,
                "directory {} {why}: another user could replace the control socket; \
                 use a private directory (--socket, or XDG_RUNTIME_DIR)",
                dir.display()
            ),
            Unsafe::Squatted(path, why) => write!(
                f,
                "{} {why}: not replaced (another user may have put it there); remove it, \
                 or use a private directory",
                path.display()
            ),
        }
    }
}

/// The socket's directory, made `0700` if it is missing, and checked: ours or root's, and
/// writable by no one else unless sticky (as `/tmp`, where others cannot remove our files).
fn private_directory(dir: &Path) -> Result<(), Unsafe> {
    if !dir.exists() {
        fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(dir)
            .map_err(|e| Unsafe::Directory(dir.to_path_buf(), e))?;
    }
    let meta = fs::metadata(dir).map_err(|e| Unsafe::Directory(dir.to_path_buf(), e))?;
    if !trusted(meta.uid(), effective_uid()) {
        return Err(Unsafe::DirectoryOpen(
            dir.to_path_buf(),
            format!("belongs to uid {}", meta.uid()),
        ));
    }
    let mode = meta.mode();
    let sticky = mode & 0o1000 != 0;
    if mode & 0o022 != 0 && !sticky {
        return Err(Unsafe::DirectoryOpen(
            dir.to_path_buf(),
            format!("is writable by others (mode {:o})", mode & 0o7777),
        ));
    }
    Ok(())
}

/// What is at `path` before binding: nothing, our own stale socket (removed), or a reason
/// to refuse. `Ok(true)` when a bootstrap answers on it.
fn clear_stale(path: &Path) -> Result<bool, Unsafe> {
    let Ok(meta) = fs::symlink_metadata(path) else {
        return Ok(false);
    };
    if !meta.file_type().is_socket() {
        return Err(Unsafe::Squatted(
            path.to_path_buf(),
            "is not a socket".into(),
        ));
    }
    if meta.uid() != effective_uid() {
        return Err(Unsafe::Squatted(
            path.to_path_buf(),
            format!("belongs to uid {}", meta.uid()),
        ));
    }
    if UnixStream::connect(path).is_ok() {
        return Ok(true);
    }
    let _ = fs::remove_file(path);
    Ok(false)
}

/// The listening socket at `path`: its directory private, anything another user put there
/// refused, `0600` once bound. `Ok(None)` when another bootstrap already answers there.
pub fn bind(path: &Path) -> Result<Option<UnixListener>, BindError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        private_directory(dir).map_err(BindError::Unsafe)?;
    }
    if clear_stale(path).map_err(BindError::Unsafe)? {
        return Ok(None);
    }
    let listener = UnixListener::bind(path).map_err(BindError::Io)?;
    fs::set_permissions(path, fs::Permissions::from_mode(0o600)).map_err(BindError::Io)?;
    Ok(Some(listener))
}

/// Why the control socket could not be bound.
#[derive(Debug)]
pub enum BindError {
    /// Its place cannot be trusted.
    Unsafe(Unsafe),
    /// The system refused.
    Io(io::Error),
}

/// The peer's user may command the vehicle: the vehicle's own user, or root.
pub fn peer_allowed(stream: &UnixStream) -> Result<(), String> {
    let creds = nix::sys::socket::getsockopt(stream, nix::sys::socket::sockopt::PeerCredentials)
        .map_err(|e| format!("the peer's credentials cannot be read: {e}"))?;
    may_command(creds.uid(), effective_uid())
}

/// Whether a peer of user `peer_uid` may command a vehicle running as `vehicle_uid`.
fn may_command(peer_uid: u32, vehicle_uid: u32) -> Result<(), String> {
    if trusted(peer_uid, vehicle_uid) {
        Ok(())
    } else {
        Err(format!(
            "uid {peer_uid} may not command this vehicle (it runs as uid {vehicle_uid})"
        ))
    }
}

/// The users a vehicle running as `vehicle_uid` trusts with its socket (who may command
/// it, whose directory may hold it): itself and root.
fn trusted(uid: u32, vehicle_uid: u32) -> bool {
    uid == vehicle_uid || uid == 0
}

/// A byte stream whose reads can be given a timeout: the control connection (a fake one in
/// tests).
pub trait TimedRead: Read {
    /// The next read gives up after `timeout`.
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl TimedRead for UnixStream {
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_read_timeout(Some(timeout))
    }
}

/// Reads one request line from `stream` within `deadline` of `started`: at most
/// [`MAX_LINE_BYTES`], UTF-8. The error is the reply's reason.
pub fn read_line(
    stream: &mut impl TimedRead,
    started: Instant,
    deadline: Duration,
) -> Result<String, String> {
    let mut line = Vec::new();
    let mut chunk = [0u8; 512];
    loop {
        let left = deadline.saturating_sub(started.elapsed());
        if left.is_zero() {
            return Err(format!(
                "no whole request line within {} s",
                deadline.as_secs_f64()
            ));
        }
        stream.set_timeout(left).map_err(|e| e.to_string())?;
        let n = match stream.read(&mut chunk) {
            Ok(n) => n,
            // Timed out (the deadline is checked above) or interrupted: read again.
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                continue;
            }
            Err(e) => return Err(e.to_string()),
        };
        let got = chunk.get(..n).unwrap_or_default();
        let end = got.iter().position(|&b| b == b'\n');
        line.extend_from_slice(got.get(..end.unwrap_or(n)).unwrap_or_default());
        if line.len() >= MAX_LINE_BYTES {
            return Err(format!("request line longer than {MAX_LINE_BYTES} bytes"));
        }
        if end.is_some() || n == 0 {
            if n == 0 && line.is_empty() {
                return Err("no request".into());
            }
            return String::from_utf8(line).map_err(|_| "request line is not UTF-8".into());
        }
    }
}

#[cfg(test)]
#[path = "control_socket_tests.rs"]
mod tests;
