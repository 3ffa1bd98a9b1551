//! Files replaced whole: a crash or a power loss leaves the old file or the new one, never a
//! part of either and never an empty one. For the small files kept beside the flight logs —
//! the vehicle's warm-start record and parameters, the ground's pack totals — which a restart
//! after a brown-out reads back.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

/// How a file was replaced.
#[derive(Debug)]
#[must_use]
pub enum Replaced {
    /// Replaced and synced, its directory too: the new file survives a power loss.
    Durably,
    /// Replaced, but its directory could not be synced (why): until the system writes the
    /// directory back on its own, a power loss may bring back the old file.
    DirectoryNotSynced(io::Error),
}

impl Replaced {
    /// What to say of the replacement, if anything: a directory that could not be synced.
    pub fn warning(&self) -> Option<String> {
        match self {
            Replaced::Durably => None,
            Replaced::DirectoryNotSynced(e) => Some(format!(
                "replaced, but its directory could not be synced ({e}): a power loss may \
                 bring back the old file"
            )),
        }
    }
}

/// Writes `bytes` to `path` whole: into `tmp` (a name beside it) first, synced to the
/// storage, renamed over `path`, and the directory synced so that the rename survives a
/// power loss too. Without the syncs a journalling file system may keep the rename and lose
/// the data, leaving an empty file where the old one was. An error leaves `path` as it was
/// and removes `tmp` (the error is the first step's that failed); once the rename is done,
/// the file is replaced, and a directory that cannot be synced is [`Replaced`]'s to say.
pub fn replace_file(path: &Path, tmp: &Path, bytes: &[u8]) -> io::Result<Replaced> {
    let written = File::create(tmp)
        .and_then(|mut file| file.write_all(bytes).and_then(|()| file.sync_all()))
        .and_then(|()| std::fs::rename(tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(tmp);
        return Err(e);
    }
    Ok(match sync_dir(path) {
        Ok(()) => Replaced::Durably,
        Err(e) => Replaced::DirectoryNotSynced(e),
    })
}

/// Syncs the directory `path` is in, so that a file made, renamed or removed there survives a
/// power loss (where a file system cannot sync a directory, as some refuse with "invalid
/// argument", there is nothing more to do).
pub fn sync_dir(path: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        match File::open(dir).and_then(|d| d.sync_all()) {
            Err(e) if e.kind() == io::ErrorKind::InvalidInput => Ok(()),
            other => other,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_file_is_replaced_whole_and_no_temporary_file_is_left() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.txt");
        let tmp = dir.path().join(".params.tmp");
        assert!(matches!(
            replace_file(&path, &tmp, b"first").unwrap(),
            Replaced::Durably
        ));
        assert!(
            replace_file(&path, &tmp, b"second")
                .unwrap()
                .warning()
                .is_none()
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert!(!tmp.exists());
        // A bare name is in the working directory's.
        assert!(sync_dir(Path::new("bare-name")).is_ok());
    }

    #[test]
    fn a_failure_leaves_the_old_file_and_no_temporary_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("warm.toml");
        let tmp = dir.path().join("warm.tmp");
        let _ = replace_file(&path, &tmp, b"old").unwrap();
        // The rename cannot replace a directory: the step after the write fails.
        let blocked = dir.path().join("blocked");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("inside"), b"x").unwrap();
        let e = replace_file(&blocked, &tmp, b"new").unwrap_err();
        assert_ne!(e.kind(), io::ErrorKind::NotFound, "{e}");
        assert!(!tmp.exists(), "the temporary file is removed");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        // A directory that is not there: the error is the creation's.
        let missing = dir.path().join("no-such-dir");
        let e = replace_file(&missing.join("f"), &missing.join("f.tmp"), b"x").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
    }

    #[test]
    fn a_directory_that_could_not_be_synced_is_said() {
        let said = Replaced::DirectoryNotSynced(io::Error::other("I/O error")).warning();
        assert_eq!(
            said.as_deref(),
            Some(
                "replaced, but its directory could not be synced (I/O error): a power loss may \
                 bring back the old file"
            )
        );
    }
}
