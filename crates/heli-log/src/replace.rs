//! Files replaced whole: a crash or a power loss leaves the old file or the new one, never a
//! part of either and never an empty one. For the small files kept beside the flight logs —
//! the vehicle's warm-start record and parameters, the ground's pack totals — which a restart
//! after a brown-out reads back.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

/// Writes `bytes` to `path` whole: into `tmp` (a name beside it) first, synced to the
/// storage, renamed over `path`, and the directory synced so that the rename survives a
/// power loss too. Without the syncs a journalling file system may keep the rename and lose
/// the data, leaving an empty file where the old one was. A failure leaves `path` as it was
/// and removes `tmp`; the error is the first step's that failed.
pub fn replace_file(path: &Path, tmp: &Path, bytes: &[u8]) -> io::Result<()> {
    let written = File::create(tmp)
        .and_then(|mut file| file.write_all(bytes).and_then(|()| file.sync_all()))
        .and_then(|()| std::fs::rename(tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(tmp);
        return Err(e);
    }
    sync_dir(path)
}

/// Syncs the directory `path` is in (where a file system cannot sync a directory, as some
/// refuse with "invalid argument", there is nothing more to do).
fn sync_dir(path: &Path) -> io::Result<()> {
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
        replace_file(&path, &tmp, b"first").unwrap();
        replace_file(&path, &tmp, b"second").unwrap();
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
        replace_file(&path, &tmp, b"old").unwrap();
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
}
