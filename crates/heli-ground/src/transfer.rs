//! A log's transfer from the vehicle, sans-I/O: the log list is asked for until it is whole,
//! then the log is downloaded over the link's log protocol and handed to the runtime to save,
//! with progress for the message area; nothing new for the timeout gives it up.
//!
//! The thesis's cleanup routine (§4.1.7) is one: after Stop, with the final parameters the
//! operator gave (base directory, file suffix), the flight's log — the newest on the vehicle
//! — goes to `BASE/flight_SUFFIX.mcap`. `heli ground download ID` is another.
//!
//! A transfer trusts nothing it did not ask for: it always asks the vehicle for its log list
//! afresh (a list kept from an earlier transfer would name an earlier flight), and a log it
//! received is handed over to be saved only once it is checked: its size, the MCAP's own
//! CRCs (read whole, not cut or damaged), and — when the flight's suffix is known — the
//! suffix the flight was started with, from the log's `flight` metadata.

use std::path::{Path, PathBuf};

use heli_link::ground::GroundLink;

use crate::refusal::SaveError;

/// A transfer with nothing new for this long (µs) is given up.
pub const TRANSFER_TIMEOUT_US: u64 = 30_000_000;
/// A transfer whose log the vehicle has said it cannot serve (a read that fails, no such
/// log, a file cut since it was listed) is given up, with the vehicle's words, after this
/// long (µs) without progress: the vehicle asks the storage again at every request, so a
/// failure that passes lets the transfer go on.
pub const UNSERVABLE_GRACE_US: u64 = 3_000_000;
/// The log list is asked for again this often (µs) until it is whole.
const LIST_RETRY_US: u64 = 1_000_000;

/// Which log a transfer fetches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    /// The newest on the vehicle (the flight just stopped).
    Newest,
    /// The log of this id in the vehicle's list.
    Id(u16),
}

/// Where a transfer is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Asking for the vehicle's log list.
    Listing,
    /// Downloading log `id` of `size` bytes.
    Downloading { id: u16, size: u32 },
}

/// What a transfer step produced.
#[derive(Debug, Default)]
pub struct Step {
    /// Frames to send.
    pub frames: Vec<Vec<u8>>,
    /// Lines for the message area.
    pub notes: Vec<String>,
    /// The finished log: where to save it and its bytes.
    pub save: Option<(PathBuf, Vec<u8>)>,
    /// The transfer is over (saved or given up).
    pub done: bool,
    /// It failed (the notes say why).
    pub failed: bool,
}

/// One log transfer.
#[derive(Clone, Debug)]
pub struct Transfer {
    dest: PathBuf,
    which: Which,
    /// The suffix the flight was started with, when known: the log must be that flight's.
    expect_suffix: Option<String>,
    /// Saved under the suffix its own metadata names ([`Transfer::of_unnamed_flight`]).
    name_from_log: bool,
    /// The log list has been asked for by this transfer.
    asked: bool,
    timeout_us: u64,
    stage: Stage,
    asked_us: u64,
    progress_us: u64,
    last_bytes: u64,
    reported_tenths: u64,
}

impl Transfer {
    /// A transfer of the newest log to `dest`, started at `now_us`.
    pub fn new(dest: PathBuf, now_us: u64) -> Self {
        Self::of(Which::Newest, dest, TRANSFER_TIMEOUT_US, now_us)
    }

    /// The same, of the flight started with `suffix`: a newest log of another flight is an
    /// error, not a save.
    pub fn of_flight(dest: PathBuf, suffix: Option<String>, now_us: u64) -> Self {
        Self {
            expect_suffix: suffix,
            ..Self::new(dest, now_us)
        }
    }

    /// The newest log, of a flight this station did not start (it knows no suffix): saved
    /// in `dest`'s directory as `flight_SUFFIX.mcap` by the suffix its `flight` metadata
    /// names (when that is a valid suffix), else at `dest`.
    pub fn of_unnamed_flight(dest: PathBuf, now_us: u64) -> Self {
        Self {
            name_from_log: true,
            ..Self::new(dest, now_us)
        }
    }

    /// A transfer of log `which` to `dest`, given up after `timeout_us` without progress.
    pub fn of(which: Which, dest: PathBuf, timeout_us: u64, now_us: u64) -> Self {
        Self {
            dest,
            which,
            expect_suffix: None,
            name_from_log: false,
            asked: false,
            timeout_us,
            stage: Stage::Listing,
            asked_us: 0,
            progress_us: now_us,
            last_bytes: 0,
            reported_tenths: 0,
        }
    }

    /// Where it will be saved.
    pub fn dest(&self) -> &PathBuf {
        &self.dest
    }

    /// Bytes received and the log's size, once known.
    pub fn progress(&self, link: &GroundLink) -> Option<(u64, u32)> {
        match self.stage {
            Stage::Listing => None,
            Stage::Downloading { size, .. } => {
                Some((link.download.as_ref().map_or(0, |d| d.received()), size))
            }
        }
    }

    /// One step at `now_us`.
    pub fn tick(&mut self, link: &mut GroundLink, now_us: u64) -> Step {
        let mut step = Step::default();
        if now_us.saturating_sub(self.progress_us) > self.timeout_us {
            step.notes.push(format!(
                "log transfer to {} given up: nothing new for {} s",
                self.dest.display(),
                self.timeout_us / 1_000_000
            ));
            step.done = true;
            step.failed = true;
            link.download = None;
            return step;
        }
        match self.stage {
            Stage::Listing => self.list(link, now_us, &mut step),
            Stage::Downloading { id, size } => self.download(link, id, size, now_us, &mut step),
        }
        step
    }

    fn list(&mut self, link: &mut GroundLink, now_us: u64, step: &mut Step) {
        if !self.asked {
            // Whatever list the link holds is an earlier transfer's: ask afresh.
            self.asked = true;
            self.asked_us = now_us;
            link.log_entries.clear();
            step.frames.push(link.log_list_frame(now_us));
            return;
        }
        let want = link
            .log_entries
            .values()
            .next()
            .map(|e| usize::from(e.num_logs));
        let have = link.log_entries.values().filter(|e| e.id > 0).count();
        if want.is_some_and(|n| have >= n) {
            let mut logs = link.log_entries.values().filter(|e| e.id > 0);
            let chosen = match self.which {
                Which::Newest => logs.max_by_key(|e| (e.time_utc, e.id)).cloned(),
                Which::Id(id) => logs.find(|e| e.id == id).cloned(),
            };
            let Some(newest) = chosen else {
                step.notes.push(match self.which {
                    Which::Newest => "log transfer: the vehicle has no log".into(),
                    Which::Id(id) => format!("log transfer: the vehicle has no log {id}"),
                });
                step.done = true;
                step.failed = true;
                return;
            };
            step.notes.push(format!(
                "log transfer: log {} ({} bytes) to {}",
                newest.id,
                newest.size,
                self.dest.display()
            ));
            step.frames
                .push(link.start_download(newest.id, newest.size, now_us));
            self.stage = Stage::Downloading {
                id: newest.id,
                size: newest.size,
            };
            self.progress_us = now_us;
            return;
        }
        if now_us.saturating_sub(self.asked_us) >= LIST_RETRY_US {
            link.log_entries.clear();
            step.frames.push(link.log_list_frame(now_us));
            self.asked_us = now_us;
        }
    }

    fn download(
        &mut self,
        link: &mut GroundLink,
        id: u16,
        size: u32,
        now_us: u64,
        step: &mut Step,
    ) {
        if let Some(frame) = link.download_tick(now_us) {
            step.frames.push(frame);
        }
        let Some(dl) = link.download.as_ref().filter(|d| d.id == id) else {
            step.notes
                .push("log transfer: the download was lost".into());
            step.done = true;
            step.failed = true;
            return;
        };
        let received = dl.received();
        if received != self.last_bytes {
            self.last_bytes = received;
            self.progress_us = now_us;
        }
        if let Some((said_us, said)) = dl.vehicle_said()
            && now_us.saturating_sub((*said_us).max(self.progress_us)) >= UNSERVABLE_GRACE_US
        {
            step.notes.push(format!(
                "log transfer to {} given up: the vehicle says {said}",
                self.dest.display()
            ));
            step.done = true;
            step.failed = true;
            link.download = None;
            return;
        }
        let tenths = received
            .saturating_mul(10)
            .checked_div(u64::from(size))
            .unwrap_or(10);
        if tenths > self.reported_tenths && !dl.complete() {
            self.reported_tenths = tenths;
            step.notes.push(format!(
                "log transfer: {} % ({received} of {size} bytes)",
                tenths.saturating_mul(10)
            ));
        }
        if dl.complete() {
            let bytes = link.download.take().map(|d| d.bytes).unwrap_or_default();
            step.frames.push(link.log_end_frame(now_us));
            step.done = true;
            match check(&bytes, size, self.expect_suffix.as_deref()) {
                Ok(what) => {
                    step.notes.push(format!(
                        "log transfer: 100 % ({size} bytes) received, {what}; saving"
                    ));
                    let dest = if self.name_from_log {
                        named_by_log(&self.dest, &bytes)
                    } else {
                        self.dest.clone()
                    };
                    step.save = Some((dest, bytes));
                }
                // A log asked for by its id is the operator's to keep, damaged or not (what
                // reads of it can be exported with `heli log export --partial`).
                Err(why) if matches!(self.which, Which::Id(_)) => {
                    step.notes.push(format!(
                        "log transfer: 100 % ({size} bytes) received; saving it although {why}"
                    ));
                    step.save = Some((self.dest.clone(), bytes));
                }
                Err(why) => {
                    step.notes.push(format!(
                        "log transfer: log {id} not saved to {}: {why}; it stays on the vehicle (download it again with `heli ground download {id}`)",
                        self.dest.display()
                    ));
                    step.failed = true;
                }
            }
        }
    }
}

/// `dest` renamed `flight_SUFFIX.mcap` by the suffix the log's `flight` metadata names, when
/// that is a valid file suffix (the log is data from the vehicle: its words never make a
/// path by themselves).
fn named_by_log(dest: &std::path::Path, bytes: &[u8]) -> PathBuf {
    let contents = heli_log::reader::read(bytes);
    contents
        .metadata
        .iter()
        .find(|m| m.name == "flight")
        .and_then(|m| m.entries.get("suffix"))
        .filter(|s| heli_link::StartParameters::new(s, "manual").is_ok())
        .map_or_else(
            || dest.to_path_buf(),
            |s| dest.with_file_name(format!("flight_{s}.mcap")),
        )
}

/// Checks a received log: its size, that it reads whole (every chunk's CRC), and that it is
/// the flight started with `suffix` when that is known. What was checked, or why it fails.
pub fn check(bytes: &[u8], size: u32, suffix: Option<&str>) -> Result<String, String> {
    if u64::try_from(bytes.len()).ok() != Some(u64::from(size)) {
        return Err(format!(
            "{} bytes received of the {size} the vehicle listed",
            bytes.len()
        ));
    }
    let contents = heli_log::reader::read(bytes);
    if let Some(stop) = &contents.stopped {
        return Err(format!("the log is damaged or cut off: {}", stop.detail));
    }
    let flight_suffix = contents
        .metadata
        .iter()
        .find(|m| m.name == "flight")
        .and_then(|m| m.entries.get("suffix"));
    match (suffix, flight_suffix) {
        (Some(want), Some(got)) if want != got => Err(format!(
            "it is the log of flight '{got}', not of the flight just stopped ('{want}')"
        )),
        (Some(want), None) => Err(format!(
            "it names no flight, and the flight just stopped is '{want}'"
        )),
        (Some(want), Some(_)) => Ok(format!("checked: flight '{want}', every chunk's CRC")),
        (None, _) => Ok("checked: every chunk's CRC".into()),
    }
}

/// Saves a transferred log at `path`, or next to it as `NAME-2.mcap`, `NAME-3.mcap`… (the
/// path's own extension kept) when a file of that name exists: an earlier flight's log is
/// never overwritten. Returns where it went.
pub fn save_new(path: &Path, bytes: &[u8]) -> Result<PathBuf, SaveError> {
    use std::io::Write;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| SaveError::Directory {
            dir: dir.to_path_buf(),
            source,
        })?;
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    for n in 1..100u32 {
        let candidate = if n == 1 {
            path.to_path_buf()
        } else {
            path.with_file_name(format!("{stem}-{n}{ext}"))
        };
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&candidate)
        {
            Ok(mut file) => {
                // Synced with its directory entry: a saved log survives the ground
                // computer's power loss. A log that could not be written whole is removed
                // (the vehicle still has it), never left as a part that looks saved.
                let written = file
                    .write_all(bytes)
                    .and_then(|()| file.sync_all())
                    .and_then(|()| heli_log::replace::sync_dir(&candidate));
                if let Err(e) = written {
                    let _ = std::fs::remove_file(&candidate);
                    return Err(SaveError::Write(e));
                }
                return Ok(candidate);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(SaveError::Write(e)),
        }
    }
    Err(SaveError::NamesTaken)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A flight's log as the vehicle writes it: the `flight` metadata with its suffix, and a
    /// few messages that differ from flight to flight (the station's tests use it too).
    pub(crate) fn flight_log(suffix: &str) -> Vec<u8> {
        let mut log = heli_log::FlightLog::new(std::io::Cursor::new(Vec::new())).unwrap();
        let entries = heli_log::metadata::flight(
            "heli test",
            std::time::UNIX_EPOCH,
            [("suffix".to_string(), suffix.to_string())],
        );
        log.write_metadata("flight", &entries).unwrap();
        for k in 0..200u64 {
            log.write(
                "notes",
                k * 10_000,
                &serde_json::json!({ "text": format!("{suffix} {k}") }),
            )
            .unwrap();
        }
        log.finish().unwrap().into_inner()
    }

    #[test]
    fn a_saved_log_never_overwrites_a_file_it_goes_next_to_it() {
        let dir = std::env::temp_dir().join(format!("heli-save-new-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let path = dir.join("base").join("flight_a.mcap");
        assert_eq!(save_new(&path, b"one").unwrap(), path);
        let second = save_new(&path, b"two").unwrap();
        assert_eq!(second, dir.join("base").join("flight_a-2.mcap"));
        assert_eq!(std::fs::read(&path).unwrap(), b"one", "the first kept");
        assert_eq!(std::fs::read(&second).unwrap(), b"two");
        assert_eq!(
            save_new(&path, b"three").unwrap(),
            dir.join("base").join("flight_a-3.mcap")
        );
        let bin = dir.join("x.bin");
        save_new(&bin, b"1").unwrap();
        assert_eq!(save_new(&bin, b"2").unwrap(), dir.join("x-2.bin"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_received_log_is_checked_for_its_size_its_crcs_and_its_flight() {
        let bytes = flight_log("f1");
        let size = u32::try_from(bytes.len()).unwrap();
        assert!(
            check(&bytes, size, Some("f1"))
                .unwrap()
                .contains("flight 'f1'")
        );
        assert!(check(&bytes, size, None).is_ok());
        let e = check(&bytes, size, Some("f2")).unwrap_err();
        assert!(
            e.contains("flight 'f1', not of the flight just stopped ('f2')"),
            "{e}"
        );
        let e = check(&bytes, size + 1, Some("f1")).unwrap_err();
        assert!(e.contains("received of the"), "{e}");
        // One flipped byte inside the data: a chunk's CRC.
        let mut damaged = bytes.clone();
        let middle = damaged.len() / 2;
        damaged[middle] ^= 0x40;
        let e = check(&damaged, size, None).unwrap_err();
        assert!(e.contains("damaged or cut off"), "{e}");
    }

    #[test]
    fn a_log_the_vehicle_cannot_serve_is_given_up_with_its_words_not_after_the_timeout() {
        use heli_link::logs::MemoryStore;
        use heli_link::vehicle::{VehicleLink, VehicleStatus};
        let mut vehicle = VehicleLink::new(None, 0);
        let mut ground = GroundLink::new(None);
        let mut store = MemoryStore {
            logs: vec![("flight_a.mcap".into(), vec![7; 5000])],
        };
        let mut t = Transfer::new(PathBuf::from("/x.mcap"), 0);
        let mut notes = Vec::new();
        let mut now_us = 0u64;
        let mut outcome = None;
        while now_us < 20_000_000 && outcome.is_none() {
            now_us += 20_000;
            if t.progress(&ground).is_some() {
                // Listed and asked for: the log is gone from the storage since.
                store.logs.clear();
            }
            let step = t.tick(&mut ground, now_us);
            for frame in &step.frames {
                vehicle.receive(frame, now_us, &store);
            }
            vehicle.tick(now_us, VehicleStatus::default(), None, &store);
            for d in vehicle.take_outgoing() {
                ground.receive(&d, now_us);
            }
            notes.extend(step.notes);
            if step.done {
                outcome = Some((now_us, step.failed));
            }
        }
        let (at_us, failed) = outcome.expect("the transfer ended");
        assert!(failed);
        assert!(
            at_us < 5_000_000,
            "given up after {at_us} µs, not the 30 s timeout"
        );
        let last = notes.last().unwrap();
        assert!(
            last.starts_with(
                "log transfer to /x.mcap given up: the vehicle says log 1 (flight_a.mcap) \
                 cannot be read at byte "
            ) && last.ends_with(": no log named flight_a.mcap"),
            "{notes:?}"
        );
    }

    #[test]
    fn a_transfer_asks_for_the_list_afresh_and_never_takes_an_earlier_one() {
        let mut link = GroundLink::new(None);
        // A complete list kept from an earlier transfer.
        link.log_entries.insert(
            1,
            mavlink::dialects::common::LOG_ENTRY_DATA {
                id: 1,
                num_logs: 1,
                last_log_num: 1,
                size: 100,
                time_utc: 0,
            },
        );
        let mut t = Transfer::new(PathBuf::from("/x.mcap"), 0);
        let step = t.tick(&mut link, 10);
        assert_eq!(step.frames.len(), 1, "the list is asked for");
        assert!(link.log_entries.is_empty(), "the old list is dropped");
        assert!(
            t.progress(&link).is_none(),
            "no download of the old list's log"
        );
    }
}
