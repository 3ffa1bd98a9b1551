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

/// The key in `path`, or none without a path.
pub fn load_key(path: Option<&Path>) -> Result<Option<Key>, SetupError> {
    let Some(path) = path else { return Ok(None) };
    let text = std::fs::read_to_string(path).map_err(|error| SetupError::KeyFile {
        path: path.to_path_buf(),
        error,
    })?;
    Key::from_text(&text)
        .map(Some)
        .map_err(|error| SetupError::BadKey {
            path: path.to_path_buf(),
            error,
        })
}

/// A new random key (32 bytes of `/dev/urandom`) written to `out`, readable by its owner
/// only; an existing file is replaced only when `force`.
pub fn keygen(out: &Path, force: bool) -> Result<Key, SetupError> {
    if out.exists() && !force {
        return Err(SetupError::KeyExists(out.to_path_buf()));
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
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
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
