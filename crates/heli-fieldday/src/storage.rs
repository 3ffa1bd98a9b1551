//! The log storage's faults, made as real as this machine allows.
//!
//! - **Full.** As root (where mounting is allowed) the log directory is a 64 MiB tmpfs of its
//!   own, filled to the last byte by a filler file (`ENOSPC` on every write) and freed by
//!   removing it. Otherwise the flight process gets a file-size limit at its log's size
//!   (`prlimit --fsize`: its writes fail with `EFBIG`), lifted to free it.
//! - **Read-only.** Linux refuses to remount a filesystem read-only while a file on it is open
//!   for writing (the flight log is), so as root an empty read-only tmpfs is mounted over the
//!   log directory (new files and renames refused, `EROFS`) and the flight process's writes
//!   to its open log are refused by the file-size limit; without root the directory is made
//!   read-only (`chmod a-w`) instead of the mount. Undone in reverse.
//!
//! Each trial says which way it was done ([`Means`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::FieldDayError;

/// How the storage faults are made on this machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Means {
    /// A tmpfs of the trial's own (root).
    Tmpfs,
    /// The flight process's file-size limit and the directory's permissions.
    Injected,
}

/// The log directory of a storage-fault trial.
pub struct Storage {
    dir: PathBuf,
    /// How the faults are made.
    pub means: Means,
    filler: Option<PathBuf>,
    overlaid: bool,
}

fn run(program: &str, args: &[&str]) -> Result<(), FieldDayError> {
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|e| FieldDayError::Io(format!("running {program}"), e))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(FieldDayError::Setup(format!(
            "{program} {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        )))
    }
}

/// Sets the soft file-size limit of process `pid` (`None`: unlimited). Only the soft limit:
/// raising a hard limit back needs `CAP_SYS_RESOURCE`, which a container's root may lack.
fn file_size_limit(pid: u32, bytes: Option<u64>) -> Result<(), FieldDayError> {
    let limit = bytes.map_or("unlimited:".to_string(), |b| format!("{b}:"));
    run(
        "prlimit",
        &["--pid", &pid.to_string(), &format!("--fsize={limit}")],
    )
}

/// The size of the largest file in `dir` (the flight log being written).
fn largest_file(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok()?.metadata().ok())
        .filter(std::fs::Metadata::is_file)
        .map(|m| m.len())
        .max()
        .unwrap_or(0)
}

impl Storage {
    /// Makes `dir` the log directory: a 64 MiB tmpfs when `mount` allows it and this process
    /// may mount one.
    pub fn prepare(dir: &Path, mount: bool) -> Result<Self, FieldDayError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| FieldDayError::Io(format!("creating {}", dir.display()), e))?;
        let path = dir.display().to_string();
        let mounted =
            mount && run("mount", &["-t", "tmpfs", "-o", "size=64m", "tmpfs", &path]).is_ok();
        let means = if mounted {
            Means::Tmpfs
        } else {
            Means::Injected
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            means,
            filler: None,
            overlaid: false,
        })
    }

    /// The storage fills: nothing more can be written.
    pub fn fill(&mut self, flight_pid: u32) -> Result<(), FieldDayError> {
        match self.means {
            Means::Tmpfs => {
                let filler = self.dir.join("filler");
                let mut file = std::fs::File::create(&filler)
                    .map_err(|e| FieldDayError::Io("creating the filler".into(), e))?;
                let block = vec![0u8; 1 << 20];
                // Whole blocks, then single bytes, until the filesystem refuses.
                while file.write_all(&block).is_ok() {}
                while file.write_all(&[0]).is_ok() {}
                self.filler = Some(filler);
                Ok(())
            }
            Means::Injected => file_size_limit(flight_pid, Some(largest_file(&self.dir))),
        }
    }

    /// The storage is freed.
    pub fn free(&mut self, flight_pid: u32) -> Result<(), FieldDayError> {
        match self.filler.take() {
            Some(filler) => std::fs::remove_file(&filler)
                .map_err(|e| FieldDayError::Io("removing the filler".into(), e)),
            None => file_size_limit(flight_pid, None),
        }
    }

    /// The storage turns read-only.
    pub fn read_only(&mut self, flight_pid: u32) -> Result<(), FieldDayError> {
        let path = self.dir.display().to_string();
        file_size_limit(flight_pid, Some(largest_file(&self.dir)))?;
        match self.means {
            Means::Tmpfs => run(
                "mount",
                &["-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", &path],
            )?,
            Means::Injected => run("chmod", &["a-w", &path])?,
        }
        self.overlaid = true;
        Ok(())
    }

    /// The storage takes writes again.
    pub fn writable(&mut self, flight_pid: u32) -> Result<(), FieldDayError> {
        let path = self.dir.display().to_string();
        if std::mem::take(&mut self.overlaid) {
            match self.means {
                Means::Tmpfs => run("umount", &[&path])?,
                Means::Injected => run("chmod", &["u+w", &path])?,
            }
        }
        file_size_limit(flight_pid, None)
    }

    /// Copies every log out to `to` and gives the directory back (unmounts the tmpfs);
    /// the copies.
    pub fn release(mut self, to: &Path) -> Result<Vec<PathBuf>, FieldDayError> {
        if self.overlaid {
            let path = self.dir.display().to_string();
            let _ = match self.means {
                Means::Tmpfs => run("umount", &[&path]),
                Means::Injected => run("chmod", &["u+w", &path]),
            };
            self.overlaid = false;
        }
        if let Some(filler) = self.filler.take() {
            let _ = std::fs::remove_file(filler);
        }
        let copies = crate::judge::copy_logs(&self.dir, to)?;
        if self.means == Means::Tmpfs {
            run("umount", &[&self.dir.display().to_string()])?;
        }
        Ok(copies)
    }
}
