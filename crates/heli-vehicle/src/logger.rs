//! The in-flight logger: a thread that writes what the loop hands it to the flight log
//! (thesis ch. 4: write sensor data to non-volatile memory in flight, so that a crash no
//! longer loses it). The loop never waits for it: items go through a bounded channel with
//! `try_send`, and an item that does not fit is counted as dropped, never blocks.
//!
//! What it writes: the seven streams (with Foxglove views), the events with their level, the
//! battery, notes, and on channel `device` every device input in the order the flight
//! computer took it, which is what `heli log replay` feeds to a fresh flight computer. The
//! log is flushed (a complete chunk written and synced) at heli-log's interval, so a kill or a
//! power cut loses at most the last interval.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::thread::JoinHandle;
use std::time::Duration;

use heli_fsw::RecordedInput;
use heli_fsw::core::{Action, CoreEvent};
use heli_log::FlightLog;
use serde_json::json;

use heli_log::inputs;

use crate::error::VehicleError;

/// Items the logger's channel holds before the loop's items are dropped: about 18 s of a
/// flight's traffic (some 455 items a second: the seven streams, the device inputs, the
/// battery), against a flush every 100 ms. The channel's slots are allocated at once and,
/// with the memory locked, resident: 8192 of them are 3 MiB.
pub const LOG_QUEUE: usize = 8192;

/// Something to log.
// By value through the channel: no allocation per record in the loop.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum LogItem {
    /// The flight computer was started at `t_us`.
    Start(u64),
    /// A device input the flight computer took at `t_us`, numbered in the order taken (the
    /// `device` channel's sequence, so a dropped input shows as a gap).
    Input(u64, u64, RecordedInput),
    /// What the flight computer did.
    Action(Action),
    /// A battery reading (V) at `t_us`.
    Battery(u64, f64),
    /// A note from the runtime (a port error, a restarted thread) at `t_us`.
    Note(u64, String),
}

impl LogItem {
    /// When it happened, on the vehicle's clock, where the item says.
    fn t_us(&self) -> Option<u64> {
        match self {
            LogItem::Start(t_us)
            | LogItem::Input(t_us, ..)
            | LogItem::Battery(t_us, _)
            | LogItem::Note(t_us, _) => Some(*t_us),
            LogItem::Action(Action::Event(e)) => Some(e.t_us),
            LogItem::Action(_) => None,
        }
    }
}

/// The loop's end of the logger's channel.
#[derive(Clone)]
pub struct LogSender {
    tx: SyncSender<LogItem>,
    dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// The logger thread is gone (it panicked): nothing sent reaches the log any more.
    gone: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl LogSender {
    /// Hands an item to the logger without waiting; counts it dropped if the queue is full.
    /// Returns false when it was dropped.
    pub fn send(&self, item: LogItem) -> bool {
        match self.tx.try_send(item) {
            Ok(()) => true,
            Err(e) => {
                if matches!(e, TrySendError::Disconnected(_)) {
                    self.gone.store(true, std::sync::atomic::Ordering::Relaxed);
                }
                self.dropped
                    .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                false
            }
        }
    }

    /// Whether the logger thread is gone (an item found no one to take it).
    pub fn gone(&self) -> bool {
        self.gone.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Items dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// What is said when the first item is dropped: from there the log has a gap.
pub const GAP_NOTE: &str =
    "the logger fell behind and dropped items: the log has a gap and cannot be replayed past it";

/// What is said when the first item is dropped because the logger thread is gone.
pub const LOGGER_GONE_NOTE: &str =
    "the logger thread has stopped (it panicked): the log ends here; the flight goes on";

/// The control loop's side of the log: each input handed to the logger, and the first one
/// dropped said once (the sender counts them all).
pub struct InputLog<'a> {
    sender: Option<&'a LogSender>,
    gap_said: bool,
}

impl<'a> InputLog<'a> {
    /// A log through `sender`, or none.
    pub fn new(sender: Option<&'a LogSender>) -> Self {
        Self {
            sender,
            gap_said: false,
        }
    }

    /// Hands the item `make` builds to the logger (nothing is built without a logger).
    /// Returns [`GAP_NOTE`] when this is the first item dropped ([`LOGGER_GONE_NOTE`] when
    /// it was dropped because the logger is gone).
    pub fn record(&mut self, make: impl FnOnce() -> LogItem) -> Option<&'static str> {
        let sender = self.sender?;
        if sender.send(make()) || self.gap_said {
            return None;
        }
        self.gap_said = true;
        Some(if sender.gone() {
            LOGGER_GONE_NOTE
        } else {
            GAP_NOTE
        })
    }
}

/// What the logger did.
#[derive(Clone, Debug, Default)]
pub struct LogReport {
    /// The file.
    pub path: PathBuf,
    /// Messages written (where `error` says the log could not be closed, those held in
    /// memory for a refusing storage among them may not be in the file).
    pub messages: u64,
    /// Messages dropped because the storage refused writes for longer than the memory
    /// held for it lasts.
    pub dropped: u64,
    /// Writes to the file that failed (each undone, and tried again).
    pub failed_writes: u64,
    /// Syncs of the file to the storage that failed (each tried again; what they left
    /// unsynced may not have survived a power loss).
    pub failed_syncs: u64,
    /// What went wrong, if anything did: the first storage failure, and a failure to close.
    pub error: Option<String>,
}

impl LogReport {
    /// The account of a logger thread that panicked: its file, and why the log ends early.
    pub fn panicked(path: PathBuf) -> Self {
        Self {
            path,
            error: Some(
                "the logger thread panicked: the log ends where it stopped, unclosed".into(),
            ),
            ..Self::default()
        }
    }
}

/// Closes `log` and completes `report` with the writer's account.
fn close<F: heli_log::LogFile>(log: FlightLog<F>, report: &mut LogReport) {
    let stats = log.stats();
    report.messages = log.messages();
    report.dropped = stats.dropped;
    report.failed_writes = stats.failed_writes;
    report.failed_syncs = stats.failed_syncs;
    if let Err(e) = log.finish() {
        let closing = match e {
            // Closed, but its last sync failed (counted here: the writer is gone).
            heli_log::LogError::Sync(_) => {
                report.failed_syncs = report.failed_syncs.saturating_add(1);
                format!("the log was closed but its last sync failed ({e})")
            }
            _ => format!(
                "the log could not be closed ({e}): what was held in memory for it is not in \
                 the file"
            ),
        };
        report.error = Some(match report.error.take() {
            Some(first) => format!("{first}; then {closing}"),
            None => closing,
        });
    }
}

/// Creates the log at `path`, writes `metadata` (MCAP metadata named `flight`) and starts the
/// logger thread. The thread ends, closing the log, when every sender is gone.
/// Runtime trouble (a write error) is said at once through `note`. An existing file is
/// never replaced.
pub fn spawn(
    path: &Path,
    metadata: &BTreeMap<String, String>,
    note: Arc<dyn Fn(String) + Send + Sync>,
) -> Result<(LogSender, JoinHandle<LogReport>), VehicleError> {
    let named = |source, hint| VehicleError::Log {
        path: Some(path.to_path_buf()),
        source,
        hint,
    };
    let mut log = FlightLog::create_new(path).map_err(|e| {
        let exists = match &e {
            heli_log::LogError::Io(io) if io.kind() == std::io::ErrorKind::AlreadyExists => {
                " (a log of that name exists: choose another suffix)"
            }
            _ => "",
        };
        named(e, exists)
    })?;
    log.write_metadata("flight", metadata)
        .map_err(|e| named(e, ""))?;
    let (tx, rx) = std::sync::mpsc::sync_channel(LOG_QUEUE);
    let path = path.to_path_buf();
    let handle = crate::rt::thread("logger", crate::rt::LOGGER_STACK_BYTES)
        .spawn(move || run(log, &rx, path, &*note))
        .map_err(|source| VehicleError::Thread {
            name: "logger".into(),
            source,
        })?;
    Ok((
        LogSender {
            tx,
            dropped: Default::default(),
            gone: Default::default(),
        },
        handle,
    ))
}

fn run(
    mut log: FlightLog<std::fs::File>,
    rx: &Receiver<LogItem>,
    path: PathBuf,
    note: &(dyn Fn(String) + Send + Sync),
) -> LogReport {
    let mut report = LogReport {
        path,
        ..LogReport::default()
    };
    let mut storage = StorageWatch::default();
    loop {
        let result = match rx.recv_timeout(Duration::from_millis(20)) {
            Ok(item) => {
                storage.t_us = item.t_us().unwrap_or(storage.t_us);
                write(&mut log, &item)
            }
            Err(RecvTimeoutError::Timeout) => log.flush_if_due().map(|_| ()),
            Err(RecvTimeoutError::Disconnected) => break,
        };
        // Said at once, and the logger keeps going: the storage may come back, and one bad
        // write must not end the flight's record.
        storage.after(&mut log, result, &mut report, note);
    }
    close(log, &mut report);
    report
}

/// Whether the storage takes the log's writes, and what the operator was told of it: a
/// failure is said once when it begins (with its cause), and again when the storage takes
/// writes again (how long it refused them and how many messages were dropped), which the log
/// itself records too.
#[derive(Default)]
struct StorageWatch {
    /// The write failure said, and the writer's drop count when it began.
    failing: Option<u64>,
    /// The sync failure said, and the writer's failed syncs when it began.
    sync_failing: Option<u64>,
    /// The vehicle's time of the latest item that had one (µs).
    t_us: u64,
}

impl StorageWatch {
    /// Says a spell of failures of the storage when it begins, and again when it ends: one
    /// for writes the storage refuses, one for syncs it refuses (a sync can fail while
    /// writes go on, and the other way round).
    fn after<F: heli_log::LogFile>(
        &mut self,
        log: &mut FlightLog<F>,
        result: Result<(), heli_log::LogError>,
        report: &mut LogReport,
        note: &(dyn Fn(String) + Send + Sync),
    ) {
        let path = report.path.display().to_string();
        match &result {
            Err(e @ heli_log::LogError::Sync(_)) => {
                if self.sync_failing.is_none() {
                    note(format!(
                        "flight log {path}: {e}; the sync is tried again with the next flush \
                         (at most every {} ms)",
                        heli_log::SYNC_EVERY_WALL.as_millis()
                    ));
                    self.sync_failing = Some(log.stats().failed_syncs.saturating_sub(1));
                }
            }
            Err(heli_log::LogError::Dropped { .. }) => {}
            Err(e) => {
                if self.failing.is_none() {
                    note(format!(
                        "flight log {path}: {e}; up to {} MiB kept in memory for it, \
                         messages past that dropped and counted, retried every {} s",
                        heli_log::writer::MAX_BACKLOG_BYTES >> 20,
                        heli_log::writer::RETRY_EVERY_WALL.as_secs()
                    ));
                    self.failing = Some(log.stats().dropped);
                }
            }
            Ok(()) => {}
        }
        if let Err(e) = result {
            report.error.get_or_insert(e.to_string());
        }
        if let Some(dropped_before) = self.failing
            && log.failing_since().is_none()
        {
            self.failing = None;
            let dropped = log.stats().dropped.saturating_sub(dropped_before);
            self.say_and_log(
                log,
                format!(
                    "flight log {path}: the storage takes writes again; {dropped} messages \
                     were dropped while it refused them"
                ),
                note,
            );
        }
        if let Some(syncs_before) = self.sync_failing
            && log.sync_failing_since().is_none()
        {
            self.sync_failing = None;
            let failed = log.stats().failed_syncs.saturating_sub(syncs_before);
            self.say_and_log(
                log,
                format!(
                    "flight log {path}: the storage syncs again, after {failed} failed syncs; \
                     what they left unsynced may not have survived a power loss"
                ),
                note,
            );
        }
    }

    /// Says `text`, and writes it in the log's notes.
    fn say_and_log<F: heli_log::LogFile>(
        &self,
        log: &mut FlightLog<F>,
        text: String,
        note: &(dyn Fn(String) + Send + Sync),
    ) {
        let _ = log.write(
            "notes",
            self.t_us,
            &json!({ "text": text.clone(), "level": "warning" }),
        );
        note(text);
    }
}

fn write(log: &mut FlightLog<std::fs::File>, item: &LogItem) -> Result<(), heli_log::LogError> {
    match item {
        LogItem::Start(t_us) => {
            log.write_sequenced(inputs::CHANNEL, 0, *t_us, &inputs::start_json())
        }
        LogItem::Input(t_us, seq, input) => log.write_sequenced(
            inputs::CHANNEL,
            // The start marker is 0; inputs count from 1 (32 bits: 11 years of inputs).
            u32::try_from(seq.saturating_add(1)).unwrap_or(u32::MAX),
            *t_us,
            &inputs::input_json(input),
        ),
        LogItem::Action(Action::Publish(record)) => log.write_record(record),
        LogItem::Action(Action::Event(e)) => log.write_event(e.t_us, &e.value),
        // The servo stream carries the command; the action adds nothing.
        LogItem::Action(Action::Servo(_)) => Ok(()),
        LogItem::Battery(t_us, volts) => log.write("battery", *t_us, &json!({ "volts": volts })),
        LogItem::Note(t_us, text) => {
            log.write("notes", *t_us, &json!({ "text": text, "level": "warning" }))
        }
    }
}

/// Whether an event is worth a line on the flight process's output (everything but routine
/// activity and single watchdog fires, which the counters show).
pub fn worth_reporting(event: &CoreEvent) -> bool {
    !matches!(event, CoreEvent::WatchdogFired)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sender of a logger that has stopped reading: its queue holds one item.
    fn stalled() -> (LogSender, std::sync::mpsc::Receiver<LogItem>) {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let sender = LogSender {
            tx,
            dropped: Default::default(),
            gone: Default::default(),
        };
        (sender, rx)
    }

    /// A log file in memory whose writes fail while `full` is set, and whose syncs fail
    /// while `unsyncable` is.
    #[derive(Clone, Default)]
    struct Disk {
        bytes: std::rc::Rc<std::cell::RefCell<std::io::Cursor<Vec<u8>>>>,
        full: std::rc::Rc<std::cell::Cell<bool>>,
        unsyncable: std::rc::Rc<std::cell::Cell<bool>>,
    }

    impl std::io::Write for Disk {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.full.get() {
                return Err(std::io::Error::from(std::io::ErrorKind::StorageFull));
            }
            self.bytes.borrow_mut().write(buf)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl std::io::Seek for Disk {
        fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
            self.bytes.borrow_mut().seek(pos)
        }
    }

    impl heli_log::LogFile for Disk {
        fn sync_data(&mut self) -> std::io::Result<()> {
            if self.unsyncable.get() {
                return Err(std::io::Error::other("I/O error (test)"));
            }
            Ok(())
        }
        fn set_len(&mut self, len: u64) -> std::io::Result<()> {
            self.bytes.borrow_mut().get_mut().truncate(len as usize);
            Ok(())
        }
    }

    /// A log on a [`Disk`], and the report of a flight's logger writing it.
    fn on_disk() -> (Disk, FlightLog<Disk>, LogReport) {
        let disk = Disk::default();
        let log = FlightLog::new(disk.clone()).unwrap();
        let report = LogReport {
            path: PathBuf::from("/var/heli/flight_t1.mcap"),
            ..LogReport::default()
        };
        (disk, log, report)
    }

    #[test]
    fn a_storage_failure_is_said_once_when_it_begins_and_again_with_the_drops_when_it_ends() {
        let (disk, mut log, mut report) = on_disk();
        let said = std::sync::Mutex::new(Vec::<String>::new());
        let note = |text: String| said.lock().unwrap().push(text);
        let mut storage = StorageWatch {
            t_us: 7_000_000,
            ..StorageWatch::default()
        };
        // Going well: nothing said.
        let result = log.write("imu", 0, &json!({"k": 0}));
        storage.after(&mut log, result, &mut report, &note);
        assert!(said.lock().unwrap().is_empty());
        disk.full.set(true);
        for _ in 0..3 {
            let result = log.flush();
            storage.after(&mut log, result, &mut report, &note);
        }
        {
            let said = said.lock().unwrap();
            assert_eq!(said.len(), 1, "{said:?}");
            assert!(
                said[0].starts_with("flight log /var/heli/flight_t1.mcap: ")
                    && said[0].contains("retried every 1 s"),
                "{said:?}"
            );
        }
        assert!(report.error.is_some());
        disk.full.set(false);
        let result = log.flush();
        storage.after(&mut log, result, &mut report, &note);
        let said = said.lock().unwrap().clone();
        assert_eq!(said.len(), 2, "{said:?}");
        assert!(
            said[1].contains("takes writes again; 0 messages"),
            "{said:?}"
        );
        let written = log.finish().unwrap();
        let contents = heli_log::read(written.bytes.borrow().get_ref());
        let notes: Vec<_> = contents
            .messages
            .iter()
            .filter(|m| m.topic == "notes")
            .collect();
        assert_eq!(notes.len(), 1);
        assert_eq!(notes[0].t_us, 7_000_000, "at the time of the last item");
    }

    #[test]
    fn a_storage_that_will_not_sync_is_said_once_and_again_when_it_syncs() {
        let (disk, mut log, mut report) = on_disk();
        let said = std::sync::Mutex::new(Vec::<String>::new());
        let note = |text: String| said.lock().unwrap().push(text);
        let mut storage = StorageWatch::default();
        let result = log.write("imu", 0, &json!({"k": 0}));
        storage.after(&mut log, result, &mut report, &note);
        disk.unsyncable.set(true);
        for k in 1..4u64 {
            std::thread::sleep(heli_log::SYNC_EVERY_WALL + Duration::from_millis(5));
            let result = log
                .write("imu", k * 10_000, &json!({"k": k}))
                .and_then(|()| log.flush());
            storage.after(&mut log, result, &mut report, &note);
        }
        {
            let said = said.lock().unwrap();
            assert_eq!(said.len(), 1, "once: {said:?}");
            assert!(
                said[0].contains("sync to the storage failed")
                    && said[0].contains("may not survive a power loss")
                    && said[0].contains("tried again with the next flush (at most every 50 ms)"),
                "{said:?}"
            );
        }
        // While syncs fail, writes fail too: said as well (one spell does not hide the other).
        disk.full.set(true);
        let result = log.flush();
        storage.after(&mut log, result, &mut report, &note);
        assert_eq!(said.lock().unwrap().len(), 2, "{:?}", said.lock().unwrap());
        assert!(said.lock().unwrap()[1].contains("kept in memory"));
        disk.full.set(false);
        disk.unsyncable.set(false);
        std::thread::sleep(heli_log::SYNC_EVERY_WALL + Duration::from_millis(5));
        let result = log.flush();
        storage.after(&mut log, result, &mut report, &note);
        let said = said.lock().unwrap().clone();
        assert_eq!(said.len(), 4, "{said:?}");
        assert!(said[2].contains("takes writes again"), "{said:?}");
        assert!(
            said[3].ends_with(
                "the storage syncs again, after 3 failed syncs; what they left unsynced may \
                 not have survived a power loss"
            ),
            "{said:?}"
        );
        // The last sync, at the close, fails: counted, and said as what it is.
        disk.unsyncable.set(true);
        close(log, &mut report);
        assert_eq!(report.failed_syncs, 4, "{report:?}");
        assert_eq!(report.failed_writes, 1, "{report:?}");
        let error = report.error.unwrap_or_default();
        assert!(
            error.contains("then the log was closed but its last sync failed"),
            "{error}"
        );
    }

    #[test]
    fn the_closing_account_has_the_drops_the_failed_writes_and_a_failure_to_close() {
        let disk = Disk::default();
        let mut log = FlightLog::new(disk.clone()).unwrap();
        log.write("imu", 0, &json!({"k": 0})).unwrap();
        disk.full.set(true);
        assert!(log.flush().is_err());
        let mut report = LogReport {
            error: Some("the storage is full".into()),
            ..LogReport::default()
        };
        // The storage never comes back: the close fails, after the first failure.
        close(log, &mut report);
        assert_eq!(report.messages, 1);
        assert_eq!(report.failed_writes, 1, "the flush refused: {report:?}");
        let error = report.error.unwrap_or_default();
        assert!(
            error.starts_with("the storage is full; then the log could not be closed (")
                && error.ends_with("what was held in memory for it is not in the file"),
            "{error}"
        );
        // A storage that came back: the account has no error, and the file all.
        let disk = Disk::default();
        let mut log = FlightLog::new(disk.clone()).unwrap();
        log.write("imu", 0, &json!({"k": 0})).unwrap();
        let mut report = LogReport::default();
        close(log, &mut report);
        assert_eq!(
            (report.messages, report.dropped, report.failed_writes),
            (1, 0, 0)
        );
        assert_eq!(report.error, None);
    }

    #[test]
    fn a_logger_that_panicked_has_an_account_naming_its_file_and_why() {
        let report = LogReport::panicked(PathBuf::from("/var/heli/flight_t1.mcap"));
        assert_eq!(report.path, PathBuf::from("/var/heli/flight_t1.mcap"));
        assert!(
            report
                .error
                .is_some_and(|e| e.starts_with("the logger thread panicked")),
            "read as no log otherwise"
        );
    }

    #[test]
    fn each_item_says_its_time_where_it_has_one() {
        assert_eq!(LogItem::Start(5).t_us(), Some(5));
        assert_eq!(LogItem::Battery(6, 12.0).t_us(), Some(6));
        assert_eq!(LogItem::Note(7, "x".into()).t_us(), Some(7));
        assert_eq!(
            LogItem::Input(8, 0, heli_fsw::RecordedInput::Tick).t_us(),
            Some(8)
        );
        let event = heli_fsw::Stamped::new(9, CoreEvent::WatchdogFired);
        assert_eq!(LogItem::Action(Action::Event(event)).t_us(), Some(9));
        let servo = heli_fsw::Stamped::new(10, heli_proto::scb::Controls::default());
        assert_eq!(LogItem::Action(Action::Servo(servo)).t_us(), None);
    }

    #[test]
    fn a_log_that_cannot_be_created_names_the_real_cause() {
        let dir = tempfile::tempdir().unwrap();
        let note: Arc<dyn Fn(String) + Send + Sync> = Arc::new(|_| {});
        let meta = BTreeMap::new();
        let missing = dir.path().join("no-such-dir").join("flight.mcap");
        let e = spawn(&missing, &meta, Arc::clone(&note))
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("flight.mcap") && !e.contains("a log of that name exists"),
            "{e}"
        );
        let taken = dir.path().join("taken.mcap");
        std::fs::write(&taken, b"").unwrap();
        let e = spawn(&taken, &meta, note).err().unwrap().to_string();
        assert!(e.contains("a log of that name exists"), "{e}");
    }

    #[test]
    fn a_full_queue_drops_and_counts_and_never_waits() {
        let (sender, _rx) = stalled();
        assert!(sender.send(LogItem::Battery(0, 12.0)));
        // Would block with `send`; `try_send` drops it and counts.
        assert!(!sender.send(LogItem::Battery(1, 12.0)));
        assert!(!sender.send(LogItem::Battery(2, 12.0)));
        assert_eq!(sender.dropped(), 2);
    }

    #[test]
    fn the_first_item_dropped_is_said_once_and_none_without_a_logger() {
        let (sender, _rx) = stalled();
        let mut log = InputLog::new(Some(&sender));
        assert_eq!(log.record(|| LogItem::Battery(0, 12.0)), None, "it fits");
        assert_eq!(log.record(|| LogItem::Battery(1, 12.0)), Some(GAP_NOTE));
        assert_eq!(log.record(|| LogItem::Battery(2, 12.0)), None, "said once");
        assert_eq!(sender.dropped(), 2, "but every one counted");
        let built = std::cell::Cell::new(false);
        let mut none = InputLog::new(None);
        let item = || {
            built.set(true);
            LogItem::Battery(3, 12.0)
        };
        assert_eq!(none.record(item), None);
        assert!(!built.get(), "nothing built without a logger");
        // A logger that is gone is said as gone, not as behind.
        let (sender, rx) = stalled();
        drop(rx);
        let mut log = InputLog::new(Some(&sender));
        assert!(!sender.gone());
        assert_eq!(
            log.record(|| LogItem::Battery(0, 12.0)),
            Some(LOGGER_GONE_NOTE)
        );
        assert!(sender.gone());
        assert_eq!(sender.dropped(), 1);
    }
}
