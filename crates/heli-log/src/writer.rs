//! The in-flight writer: messages in, a file that is a complete MCAP file after every flush.
//!
//! mcap's own writer writes a chunk's header first, with all-ones placeholders, and patches it
//! when the chunk is closed; a process killed in between leaves a header whose length is
//! 2^64 − 1, and the official Python and TypeScript readers refuse the whole file. Here mcap
//! writes into memory instead ([`mcap::WriteOptions::disable_seeking`] builds each chunk in a
//! buffer) and [`FlightLog`] hands the file only finished records, in one write per flush:
//!
//! ```text
//! file after a flush:  magic header [chunk]… [chunk] | DataEnd Footer magic
//!                      ^ written once, never touched  ^ provisional end (50 bytes), replaced
//!                                                       by the next flush's records
//! ```
//!
//! The official Python reader (`mcap.reader.make_reader(f).iter_messages()`) reads nothing at
//! all from a file that does not end in a Footer, so the provisional end is what makes a file
//! left by a crash readable by it. [`FlightLog::finish`] writes mcap's summary (schemas,
//! channels, statistics, metadata index) in its place.
//!
//! When: at the first message at least [`FLUSH_EVERY_US`] of log time after the last flush,
//! or [`FLUSH_EVERY_WALL`] of wall-clock time (checked on every write and by
//! [`FlightLog::flush_if_due`]). Each flush is followed by `sync_data` unless the last one was
//! less than [`SYNC_EVERY_WALL`] ago: in a real-time flight every flush is synced; a
//! simulation running many times faster than real time is not slowed down to the disk.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Cursor, Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use mcap::write::NoSeek;
use serde_json::Value;

use crate::LogError;

/// Longest stretch of log time between two flushes (µs): a crash loses at most this much.
pub const FLUSH_EVERY_US: u64 = 100_000;

/// Longest stretch of wall-clock time between two flushes while messages keep coming (and,
/// through [`FlightLog::flush_if_due`], while they do not).
pub const FLUSH_EVERY_WALL: Duration = Duration::from_millis(100);

/// While the file refuses writes (a full disk, a read-only remount), how often a flush tries
/// it again.
pub const RETRY_EVERY_WALL: Duration = Duration::from_secs(1);

/// Most bytes of finished records kept in memory while the file refuses them. Past it each
/// new message is dropped and counted ([`WriterStats::dropped`]): the writer's memory stays
/// bounded however long the storage stays full, and what was kept reaches the file, in order,
/// when it takes writes again.
pub const MAX_BACKLOG_BYTES: usize = 4 << 20;

/// The backlog's memory, reserved and touched when the log is created: the bound plus two
/// chunks (a chunk closed past the bound, the one being closed) and the file's end. A full
/// disk then fills memory the process already has: its resident size does not grow.
pub const BACKLOG_RESERVE_BYTES: usize =
    MAX_BACKLOG_BYTES + 2 * (MAX_CHUNK_BYTES as usize) + (64 << 10);

/// Shortest wall-clock time between two `sync_data` calls. A flush less than this after the
/// last sync is synced by the next flush (or by [`FlightLog::finish`]).
pub const SYNC_EVERY_WALL: Duration = Duration::from_millis(50);

/// A chunk is closed early when its uncompressed size passes this (bytes): a bound on the
/// writer's memory whatever the message rate.
const MAX_CHUNK_BYTES: u64 = 1 << 20;

/// The provisional end written after every flush: DataEnd (no CRC), Footer (no summary) and
/// the closing magic, 50 bytes.
const PROVISIONAL_END: [u8; 50] = provisional_end();

const fn provisional_end() -> [u8; 50] {
    let mut end = [0u8; 50];
    // DataEnd: opcode 0x0f, length 4, data section CRC 0 (not computed).
    end[0] = 0x0f;
    end[1] = 4;
    // Footer: opcode 0x02, length 20, summary start 0, summary offset start 0, CRC 0.
    end[13] = 0x02;
    end[14] = 20;
    // Magic.
    let magic = b"\x89MCAP0\r\n";
    let mut i = 0;
    while i < 8 {
        end[42 + i] = magic[i];
        i += 1;
    }
    end
}

/// Where a log is written: a seekable byte sink that can make what it holds durable.
pub trait LogFile: Write + Seek {
    /// Makes everything written so far survive a power loss (`fdatasync` for a file). The
    /// default does nothing, for sinks in memory.
    fn sync_data(&mut self) -> io::Result<()> {
        Ok(())
    }

    /// Cuts the sink (or extends it with zeros) to `len` bytes: how a write that failed
    /// part-way is undone.
    fn set_len(&mut self, len: u64) -> io::Result<()>;
}

impl LogFile for File {
    fn sync_data(&mut self) -> io::Result<()> {
        File::sync_data(self)
    }

    fn set_len(&mut self, len: u64) -> io::Result<()> {
        File::set_len(self, len)
    }
}

impl LogFile for Cursor<Vec<u8>> {
    fn set_len(&mut self, len: u64) -> io::Result<()> {
        let len = usize::try_from(len).map_err(|_| io::Error::other("length past memory"))?;
        self.get_mut().resize(len, 0);
        Ok(())
    }
}

impl<T: LogFile + ?Sized> LogFile for &mut T {
    fn sync_data(&mut self) -> io::Result<()> {
        (**self).sync_data()
    }

    fn set_len(&mut self, len: u64) -> io::Result<()> {
        (**self).set_len(len)
    }
}

/// Choices a log's owner can make.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LogOptions {
    /// Write a message index after every chunk and the chunk indexes in the summary, as mcap
    /// does by default. Off: with a chunk every 100 ms the indexes took 27–32 % of the file
    /// (docs/logging.md has the numbers), and readers do not need them to read a flight.
    pub indexed: bool,
    /// zstd compression level; 0 is zstd's default (3).
    pub compression_level: u32,
}

/// What a writer has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WriterStats {
    /// Messages written.
    pub messages: u64,
    /// Writes to the file (the first one, every flush, the last one).
    pub flushes: u64,
    /// `sync_data` calls.
    pub syncs: u64,
    /// Length of the file after the last write (bytes).
    pub file_bytes: u64,
    /// Writes to the file that failed (each one undone: the file was cut back to its last
    /// complete end).
    pub failed_writes: u64,
    /// Messages dropped because the file refused writes for longer than
    /// [`MAX_BACKLOG_BYTES`] of records lasts.
    pub dropped: u64,
    /// `sync_data` calls that failed: what was written since the last one that worked may
    /// not be on the storage.
    pub failed_syncs: u64,
}

/// The bytes mcap has produced and the file has not yet received.
#[derive(Clone, Debug, Default)]
struct Pending(Arc<Mutex<Vec<u8>>>);

impl Pending {
    fn append_to(&self, out: &mut Vec<u8>) {
        let mut bytes = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        out.append(&mut bytes);
    }
}

impl Write for Pending {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut bytes = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        bytes.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// One channel of the log.
#[derive(Clone, Copy, Debug)]
struct Channel {
    id: u16,
    next_sequence: u32,
}

/// An empty backlog whose memory is reserved and touched (resident from now on, and never
/// reallocated while it stays within [`BACKLOG_RESERVE_BYTES`]).
fn reserved_backlog() -> Vec<u8> {
    // Written, not only allocated: a zeroed allocation (`vec![0; n]`) gets fresh pages from
    // the kernel that become resident only when first written — during the fault. (A process
    // with its memory locked has them at once either way.)
    let mut backlog = Vec::with_capacity(BACKLOG_RESERVE_BYTES);
    backlog.resize(BACKLOG_RESERVE_BYTES, 0xA5);
    backlog.clear();
    backlog
}

/// The writer.
pub struct FlightLog<F: LogFile> {
    /// `None` once finished.
    file: Option<F>,
    /// `None` once finished.
    mcap: Option<mcap::Writer<NoSeek<Pending>>>,
    pending: Pending,
    /// Records taken from `pending` that a failed write did not get into the file.
    unwritten: Vec<u8>,
    /// File offset of the provisional end: where the next records go.
    data_end: u64,
    channels: BTreeMap<String, Channel>,
    /// Log time of the first message after the last flush.
    chunk_start_us: Option<u64>,
    last_flush_wall: Instant,
    /// Set while the file refuses writes: when it was last tried.
    failing_since: Option<Instant>,
    /// Set while the file refuses to sync: since when.
    sync_failing_since: Option<Instant>,
    last_attempt_wall: Instant,
    last_sync_wall: Option<Instant>,
    unsynced: bool,
    stats: WriterStats,
    /// Log time the helicopter's scene was last written (`crate::scene`).
    scene_at_us: Option<u64>,
}

impl FlightLog<File> {
    /// Creates a log file at `path` (replacing one that is there), with the default options.
    pub fn create(path: &Path) -> Result<Self, LogError> {
        Self::new(File::create(path)?)
    }

    /// Creates a log file at `path`, refusing to replace one that is there (a flight's log
    /// is never overwritten by the next flight that reuses its name). Its directory is
    /// synced once the file is started, so that the log's name, not only its bytes, survives
    /// a power loss. A file it made but could not start (a full disk takes the name, not the
    /// bytes), or whose directory cannot be synced, is removed again: the name stays free
    /// and no empty log is left behind.
    pub fn create_new(path: &Path) -> Result<Self, LogError> {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)?;
        Self::new(file)
            .and_then(|log| {
                crate::replace::sync_dir(path).map_err(LogError::Sync)?;
                Ok(log)
            })
            .inspect_err(|_| {
                let _ = std::fs::remove_file(path);
            })
    }
}

impl<F: LogFile> FlightLog<F> {
    /// A log written to `file` from its start, with the default options.
    pub fn new(file: F) -> Result<Self, LogError> {
        Self::with_options(file, LogOptions::default())
    }

    /// A log written to `file` from its start. The file is a valid, empty MCAP file when this
    /// returns.
    pub fn with_options(file: F, options: LogOptions) -> Result<Self, LogError> {
        let pending = Pending::default();
        let mcap = mcap::WriteOptions::new()
            .profile("heli")
            .library(concat!(
                "heli-log ",
                env!("CARGO_PKG_VERSION"),
                " (mcap-rs)"
            ))
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(options.compression_level)
            // One thread: the logger must not take the flight computer's cores.
            .compression_threads(0)
            .chunk_size(Some(MAX_CHUNK_BYTES))
            .disable_seeking(true)
            .emit_message_indexes(options.indexed)
            .emit_chunk_indexes(options.indexed)
            .create(NoSeek::new(pending.clone()))?;
        let mut log = Self {
            file: Some(file),
            mcap: Some(mcap),
            pending,
            unwritten: reserved_backlog(),
            data_end: 0,
            channels: BTreeMap::new(),
            chunk_start_us: None,
            last_flush_wall: Instant::now(),
            failing_since: None,
            sync_failing_since: None,
            last_attempt_wall: Instant::now(),
            last_sync_wall: None,
            unsynced: false,
            stats: WriterStats::default(),
            scene_at_us: None,
        };
        log.write_out(&PROVISIONAL_END)?;
        log.sync_if_due(true)?;
        Ok(log)
    }

    /// The channel of `topic`, announced (with its schema) on first use.
    fn channel(&mut self, topic: &str) -> Result<Channel, LogError> {
        if let Some(channel) = self.channels.get(topic) {
            return Ok(*channel);
        }
        let mcap = self.mcap.as_mut().ok_or(LogError::Finished)?;
        let schema = crate::schema::for_topic(topic);
        let text = serde_json::to_vec(&schema.json).map_err(LogError::Encode)?;
        let schema_id = mcap.add_schema(&schema.name, "jsonschema", &text)?;
        let id = mcap.add_channel(schema_id, topic, "json", &BTreeMap::new())?;
        let channel = Channel {
            id,
            next_sequence: 0,
        };
        self.channels.insert(topic.to_string(), channel);
        Ok(channel)
    }

    /// Appends one message to `topic`, stamped `t_us` (vehicle clock), with the channel's
    /// next sequence number (each channel counts from 0). Flushes when due.
    pub fn write(&mut self, topic: &str, t_us: u64, value: &Value) -> Result<(), LogError> {
        let sequence = self.channel(topic)?.next_sequence;
        self.write_sequenced(topic, sequence, t_us, value)
    }

    /// Appends one message with a sequence number of the owner's: the source stream's own
    /// count, so that records the owner never saw show as a gap in this channel's numbers.
    /// The channel's next automatic number follows it.
    pub fn write_sequenced(
        &mut self,
        topic: &str,
        sequence: u32,
        t_us: u64,
        value: &Value,
    ) -> Result<(), LogError> {
        if self.unwritten.len() >= MAX_BACKLOG_BYTES {
            // The file has refused writes for a while: try it again when that is due (its
            // failure was said when it began), and while the backlog stays full keep what
            // is kept and drop this one.
            if self.flush_due() {
                let _ = self.flush();
            }
            if self.unwritten.len() >= MAX_BACKLOG_BYTES {
                self.stats.dropped += 1;
                return Err(LogError::Dropped {
                    backlog_bytes: self.unwritten.len(),
                });
            }
        }
        let data = serde_json::to_vec(value).map_err(LogError::Encode)?;
        let channel = self.channel(topic)?;
        let mcap = self.mcap.as_mut().ok_or(LogError::Finished)?;
        let time_ns = t_us.saturating_mul(1000);
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        mcap.write_to_known_channel(&header, &data)?;
        if let Some(c) = self.channels.get_mut(topic) {
            c.next_sequence = sequence.wrapping_add(1);
        }
        self.stats.messages += 1;
        let start = *self.chunk_start_us.get_or_insert(t_us);
        let due = if self.failing_since.is_some() {
            self.flush_due()
        } else {
            t_us.saturating_sub(start) >= FLUSH_EVERY_US
                || self.last_flush_wall.elapsed() >= FLUSH_EVERY_WALL
        };
        if due {
            self.flush()?;
        }
        Ok(())
    }

    /// Whether a flush is due by the wall clock: [`FLUSH_EVERY_WALL`] after the last one, or
    /// while the file refuses writes, [`RETRY_EVERY_WALL`] after the last try.
    fn flush_due(&self) -> bool {
        if self.failing_since.is_some() {
            self.last_attempt_wall.elapsed() >= RETRY_EVERY_WALL
        } else {
            self.last_flush_wall.elapsed() >= FLUSH_EVERY_WALL
        }
    }

    /// Since when the file has refused writes (`None` while it takes them).
    pub fn failing_since(&self) -> Option<Instant> {
        self.failing_since
    }

    /// Since when the file has refused to sync (`None` once a sync works): data it did not
    /// sync may be lost, even after a later sync works.
    pub fn sync_failing_since(&self) -> Option<Instant> {
        self.sync_failing_since
    }

    /// Records a named set of key–value pairs (an MCAP Metadata record) and flushes, so that it
    /// is in the file at once. [`crate::metadata::flight`] builds the usual one.
    pub fn write_metadata(
        &mut self,
        name: &str,
        entries: &BTreeMap<String, String>,
    ) -> Result<(), LogError> {
        let mcap = self.mcap.as_mut().ok_or(LogError::Finished)?;
        mcap.write_metadata(&mcap::records::Metadata {
            name: name.to_string(),
            metadata: entries.clone(),
        })?;
        self.flush()
    }

    /// Closes the chunk being filled and appends it to the file, with a new provisional end.
    /// Syncs it unless the last sync was less than [`SYNC_EVERY_WALL`] ago.
    pub fn flush(&mut self) -> Result<(), LogError> {
        let mcap = self.mcap.as_mut().ok_or(LogError::Finished)?;
        mcap.flush()?;
        self.write_out(&PROVISIONAL_END)?;
        self.sync_if_due(false)
    }

    /// Flushes if messages have waited [`FLUSH_EVERY_WALL`] or more, and syncs a flush that
    /// was left unsynced: for owners to call from a timer, so that a pause in the messages does
    /// not hold the last ones back. Returns whether it wrote anything.
    pub fn flush_if_due(&mut self) -> Result<bool, LogError> {
        let waiting = self.chunk_start_us.is_some() || !self.unwritten.is_empty();
        if waiting && self.flush_due() {
            self.flush()?;
            return Ok(true);
        }
        self.sync_if_due(false)?;
        Ok(false)
    }

    /// Writes what mcap produced, then `end`, at the provisional end, in one write.
    ///
    /// A write that fails (part-way, as a full disk does) is undone: the file is cut back to
    /// the end of its last complete record and the provisional end written there again (the
    /// 50 bytes the cut just freed), so that the file stays a complete MCAP file for every
    /// reader. The records are kept for the next try, which starts there.
    fn write_out(&mut self, end: &[u8]) -> Result<(), LogError> {
        self.pending.append_to(&mut self.unwritten);
        let file = self.file.as_mut().ok_or(LogError::Finished)?;
        let records = self.unwritten.len();
        self.unwritten.extend_from_slice(end);
        self.last_attempt_wall = Instant::now();
        let written = file
            .seek(SeekFrom::Start(self.data_end))
            .and_then(|_| file.write_all(&self.unwritten))
            .and_then(|()| file.flush());
        // Kept for the next attempt if the write failed.
        self.unwritten.truncate(records);
        if let Err(e) = written {
            self.stats.failed_writes += 1;
            self.failing_since.get_or_insert(self.last_attempt_wall);
            // Best effort: if the file refuses even this, the next try repairs it.
            // Everything after the last complete record goes first, so that even a repair
            // that fails too leaves the file cut at a record's end or inside the provisional
            // end (a cut every reader recognises), never followed by a failed write's bytes.
            // Before the first write there is nothing to keep.
            let end_of_data = self.data_end;
            let _ = file.set_len(end_of_data).and_then(|()| {
                if end_of_data == 0 {
                    return Ok(());
                }
                file.seek(SeekFrom::Start(end_of_data))
                    .and_then(|_| file.write_all(&PROVISIONAL_END))
                    .and_then(|()| file.flush())
            });
            return Err(e.into());
        }
        self.failing_since = None;
        self.data_end += records as u64;
        self.unwritten.clear();
        self.chunk_start_us = None;
        self.last_flush_wall = self.last_attempt_wall;
        self.unsynced = true;
        self.stats.flushes += 1;
        self.stats.file_bytes = self.data_end + end.len() as u64;
        Ok(())
    }

    fn sync_if_due(&mut self, always: bool) -> Result<(), LogError> {
        let due = self
            .last_sync_wall
            .is_none_or(|t| t.elapsed() >= SYNC_EVERY_WALL);
        if self.unsynced && (always || due) {
            let file = self.file.as_mut().ok_or(LogError::Finished)?;
            let synced = file.sync_data();
            // A failed sync is tried again after the same wait as a sync that worked.
            self.last_sync_wall = Some(Instant::now());
            self.stats.syncs += 1;
            if let Err(e) = synced {
                self.stats.failed_syncs += 1;
                self.sync_failing_since.get_or_insert(Instant::now());
                return Err(LogError::Sync(e));
            }
            self.unsynced = false;
            self.sync_failing_since = None;
        }
        Ok(())
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.stats.messages
    }

    /// True when the helicopter's scene is to be written with a message at `t_us` (the
    /// first time, and [`crate::scene::SCENE_EVERY_US`] after the last), and notes it so.
    pub(crate) fn scene_due(&mut self, t_us: u64) -> bool {
        let due = self
            .scene_at_us
            .is_none_or(|at| t_us < at || t_us.saturating_sub(at) >= crate::scene::SCENE_EVERY_US);
        if due {
            self.scene_at_us = Some(t_us);
        }
        due
    }

    /// Counts of what the writer has done.
    pub fn stats(&self) -> WriterStats {
        self.stats
    }

    /// Closes the log: the last chunk and mcap's summary (schemas, channels, statistics,
    /// metadata index) and footer replace the provisional end; synced. Returns the file.
    pub fn finish(mut self) -> Result<F, LogError> {
        self.close()?;
        self.file.take().ok_or(LogError::Finished)
    }

    fn close(&mut self) -> Result<(), LogError> {
        let mut mcap = self.mcap.take().ok_or(LogError::Finished)?;
        mcap.finish()?;
        // The summary is at least as long as the provisional end it replaces, which it
        // starts with (DataEnd), so nothing of the old end is left behind.
        self.write_out(&[])?;
        self.sync_if_due(true)
    }
}

impl<F: LogFile> Drop for FlightLog<F> {
    /// A log dropped without [`FlightLog::finish`] (an error path, a panic unwinding) is
    /// closed as `finish` would, as far as the file lets it; errors are ignored.
    fn drop(&mut self) {
        if self.mcap.is_some() {
            let _ = self.close();
        }
    }
}

#[cfg(test)]
mod tests;
