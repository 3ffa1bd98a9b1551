//! What both ends read to set a link up: the `udp:HOST:PORT` address form and the signing
//! key file (`heli link keygen`). The one part of this crate that touches the system (a
//! file, a name lookup), kept here so that the vehicle and the ground read them the same way.

use std::fmt;
use std::io::{Read, Write};
use std::net::{SocketAddr, ToSocketAddrs};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use crate::signing::{BadKey, Key};

/// Why a link could not be set up.
#[derive(Debug)]
pub enum SetupError {
    /// The address is not `udp:HOST:PORT`, or names no address.
    Address {
        /// The text given.
        text: String,
        /// What is wrong with it.
        why: String,
    },
    /// The key file could not be read or written.
    KeyFile {
        /// The file.
        path: PathBuf,
        /// The system's answer.
        error: std::io::Error,
    },
    /// The key file holds no key.
    BadKey {
        /// The file.
        path: PathBuf,
        /// What is wrong with its text.
        error: BadKey,
    },
    /// keygen would replace a key that exists.
    KeyExists(PathBuf),
    /// The key file is not kept as a key must be (readable or writable by others, a
    /// symbolic link keygen would write through, not a regular file, a key that is not
    /// random): what is wrong, and the fix.
    KeyUnsafe {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the fix.
        why: String,
    },
}

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SetupError::Address { text, why } => write!(f, "link '{text}': {why}"),
            SetupError::KeyFile { path, error } => write!(
                f,
                "signing key {} (make one with heli link keygen): {error}",
                path.display()
            ),
            SetupError::BadKey { path, error } => {
                write!(f, "signing key {}: {error}", path.display())
            }
            SetupError::KeyUnsafe { path, why } => {
                write!(f, "signing key {}: {why}", path.display())
            }
            SetupError::KeyExists(path) => write!(
                f,
                "{} exists: a key already made is kept (--force replaces it, and every side must then get the new one)",
                path.display()
            ),
        }
    }
}

impl std::error::Error for SetupError {}

/// The address of `udp:HOST:PORT` (a host name is looked up).
pub fn parse_address(text: &str) -> Result<SocketAddr, SetupError> {
    let error = |why: String| SetupError::Address {
        text: text.to_string(),
        why,
    };
    let Some(rest) = text.strip_prefix("udp:") else {
        return Err(error(
            "expected udp:HOST:PORT (e.g. udp:127.0.0.1:14550)".into(),
        ));
    };
    rest.to_socket_addrs()
        .map_err(|e| error(format!("expected udp:HOST:PORT: {e}")))?
        .next()
        .ok_or_else(|| error("no address".into()))
}

/// Fewest different byte values a key of 32 random bytes may have: a random key has about
/// 30; fewer than this is a key typed by hand or a placeholder (all zero, a repeated pattern).
pub const MIN_DISTINCT_KEY_BYTES: usize = 12;

/// The key in `path`, or none without a path. Refused, with the fix: a file others may read
/// or write (the key signs every command), and a key that is not random.
pub fn load_key(path: Option<&Path>) -> Result<Option<Key>, SetupError> {
    let Some(path) = path else { return Ok(None) };
    let unsafe_key = |why: String| SetupError::KeyUnsafe {
        path: path.to_path_buf(),
        why,
    };
    let meta = std::fs::metadata(path).map_err(|error| SetupError::KeyFile {
        path: path.to_path_buf(),
        error,
    })?;
    let mode = meta.permissions().mode() & 0o777;
    if mode & 0o077 != 0 {
        return Err(unsafe_key(format!(
            "mode {mode:03o}: others may read or write it, and the key signs every command (chmod 600 {})",
            path.display()
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|error| SetupError::KeyFile {
        path: path.to_path_buf(),
        error,
    })?;
    let key = Key::from_text(&text).map_err(|error| SetupError::BadKey {
        path: path.to_path_buf(),
        error,
    })?;
    let distinct = key.distinct_bytes();
    if distinct < MIN_DISTINCT_KEY_BYTES {
        return Err(unsafe_key(format!(
            "not a random key ({distinct} different byte values of 32; all zero, or a pattern): make one with heli link keygen"
        )));
    }
    Ok(Some(key))
}

/// A random signing link id for a ground process, 1 to 255 (`/dev/urandom`; the vehicle
/// signs on 0): two grounds that sign at once are two streams to the vehicle, so that
/// neither's frames look like the other's replays.
pub fn random_link_id() -> std::io::Result<u8> {
    let mut file = std::fs::File::open("/dev/urandom")?;
    loop {
        let mut byte = [0u8; 1];
        file.read_exact(&mut byte)?;
        if byte[0] != 0 {
            return Ok(byte[0]);
        }
    }
}

/// A new random key (32 bytes of `/dev/urandom`) written to `out`, readable by its owner
/// only; an existing file is replaced only when `force`.
pub fn keygen(out: &Path, force: bool) -> Result<Key, SetupError> {
    let unsafe_key = |why: &str| SetupError::KeyUnsafe {
        path: out.to_path_buf(),
        why: why.to_string(),
    };
    // Only a regular file of its own: a symbolic link (perhaps planted in a shared
    // directory) would have the key written, and its target's mode changed, elsewhere.
    match std::fs::symlink_metadata(out) {
        Ok(m) if m.file_type().is_symlink() => {
            return Err(unsafe_key(
                "is a symbolic link: keygen writes only a regular file (remove the link, or give the path it points to)",
            ));
        }
        Ok(m) if !m.is_file() => return Err(unsafe_key("is not a regular file")),
        Ok(_) if !force => return Err(SetupError::KeyExists(out.to_path_buf())),
        _ => {}
    }
    let io = |error| SetupError::KeyFile {
        path: out.to_path_buf(),
        error,
    };
    let mut bytes = [0u8; 32];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(io)?;
    let key = Key::new(bytes);
    // O_NOFOLLOW: a link put in its place since the check above is refused, not followed;
    // a new file is created exclusively (O_EXCL) unless replacing one was asked.
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(force)
        .create_new(!force)
        .truncate(force)
        .mode(0o600)
        .custom_flags(nix::fcntl::OFlag::O_NOFOLLOW.bits())
        .open(out)
        .map_err(io)?;
    // `mode` applies only to a file created here: an old key file replaced with --force
    // gets the same permissions.
    file.set_permissions(std::fs::Permissions::from_mode(0o600))
        .map_err(io)?;
    file.write_all(key.to_text().as_bytes()).map_err(io)?;
    Ok(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_are_udp_host_port() {
        assert_eq!(
            parse_address("udp:127.0.0.1:14550").unwrap(),
            "127.0.0.1:14550".parse().unwrap()
        );
        let e = parse_address("tcp:127.0.0.1:14550")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "link 'tcp:127.0.0.1:14550': expected udp:HOST:PORT (e.g. udp:127.0.0.1:14550)"
        );
        let e = parse_address("udp:127.0.0.1").unwrap_err().to_string();
        assert!(
            e.starts_with("link 'udp:127.0.0.1': expected udp:HOST:PORT: "),
            "{e}"
        );
    }

    #[test]
    fn a_made_key_is_private_read_back_and_never_replaced_unasked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("k.key");
        let key = keygen(&path, false).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(
            load_key(Some(&path)).unwrap().unwrap().to_text(),
            key.to_text()
        );
        let again = keygen(&path, false).unwrap_err().to_string();
        assert!(
            again.contains("exists: a key already made is kept"),
            "{again}"
        );
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let other = keygen(&path, true).unwrap();
        assert_ne!(other.to_text(), key.to_text());
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert!(load_key(None).unwrap().is_none());
    }

    #[test]
    fn keys_are_kept_as_keys_or_refused_with_the_fix() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("k.key");
        keygen(&path, false).unwrap();
        // Readable by others: refused, naming the mode and the fix.
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = load_key(Some(&path)).unwrap_err().to_string();
        assert!(e.contains("mode 644") && e.contains("chmod 600"), "{e}");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o620)).unwrap();
        assert!(load_key(Some(&path)).is_err(), "writable by the group");
        // All zero, or a short pattern: not random.
        for text in ["0".repeat(64), "01020304".repeat(8)] {
            let weak = dir.path().join("weak.key");
            let _ = std::fs::remove_file(&weak);
            std::fs::write(&weak, &text).unwrap();
            std::fs::set_permissions(&weak, std::fs::Permissions::from_mode(0o600)).unwrap();
            let e = load_key(Some(&weak)).unwrap_err().to_string();
            assert!(
                e.contains("not a random key") && e.contains("keygen"),
                "{e}"
            );
        }
        // keygen never writes through a symbolic link, forced or not, nor changes its target.
        let target = dir.path().join("target");
        std::fs::write(&target, "precious").unwrap();
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o644)).unwrap();
        let link = dir.path().join("link.key");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        for force in [false, true] {
            let e = keygen(&link, force).unwrap_err().to_string();
            assert!(e.contains("is a symbolic link"), "{e}");
        }
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "precious");
        let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o644);
        let e = keygen(dir.path(), true).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
    }

    #[test]
    fn a_missing_or_bad_key_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("none.key");
        let e = load_key(Some(&missing)).unwrap_err().to_string();
        assert!(
            e.contains("none.key (make one with heli link keygen)"),
            "{e}"
        );
        let bad = dir.path().join("bad.key");
        std::fs::write(&bad, "not a key").unwrap();
        let e = load_key(Some(&bad)).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("signing key {}: ", bad.display())),
            "{e}"
        );
    }
}
