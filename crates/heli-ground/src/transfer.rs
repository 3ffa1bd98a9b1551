//! A log's transfer from the vehicle, sans-I/O: the log list is asked for until it is whole,
//! then the log is downloaded over the link's log protocol and handed to the runtime to save,
//! with progress for the message area; nothing new for the timeout gives it up.
//!
//! The thesis's cleanup routine (§4.1.7) is one: after Stop, with the final parameters the
//! operator gave (base directory, file suffix), the flight's log — the newest on the vehicle
//! — goes to `BASE/flight_SUFFIX.mcap`. `heli ground download ID` is another.

use std::path::PathBuf;

use heli_link::ground::GroundLink;

/// A transfer with nothing new for this long (µs) is given up.
pub const TRANSFER_TIMEOUT_US: u64 = 30_000_000;
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

    /// A transfer of log `which` to `dest`, given up after `timeout_us` without progress.
    pub fn of(which: Which, dest: PathBuf, timeout_us: u64, now_us: u64) -> Self {
        Self {
            dest,
            which,
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
            step.notes.push(format!(
                "log transfer: 100 % ({size} bytes) received, saving"
            ));
            step.save = Some((self.dest.clone(), bytes));
            step.done = true;
        }
    }
}
