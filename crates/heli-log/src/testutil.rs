//! Test helpers: a log file the test can look into while the writer holds it, and a flight.

use std::cell::RefCell;
use std::io::{self, Cursor, Seek, SeekFrom, Write};
use std::rc::Rc;

use serde_json::json;

use crate::{FlightLog, LogFile};

/// What happened to a [`SharedFile`].
#[derive(Debug, Default)]
pub struct FileState {
    /// The file's bytes.
    pub bytes: Cursor<Vec<u8>>,
    /// Offset and length of every `write` call.
    pub writes: Vec<(u64, usize)>,
    /// The file as it was after every `flush` call (the writer flushes after each write).
    pub snapshots: Vec<Vec<u8>>,
    /// `sync_data` calls.
    pub syncs: u64,
    /// Fail this many coming writes.
    pub fail_writes: u32,
    /// Fail this many coming `sync_data` calls.
    pub fail_syncs: u32,
    /// A full disk: the file cannot grow past this many bytes; a write that would is short,
    /// and the next one fails.
    pub capacity: Option<u64>,
    /// `set_len` calls.
    pub cuts: Vec<u64>,
}

/// A log file in memory, shared with the test.
#[derive(Clone, Debug, Default)]
pub struct SharedFile(pub Rc<RefCell<FileState>>);

impl SharedFile {
    /// The file's bytes now.
    pub fn bytes(&self) -> Vec<u8> {
        self.0.borrow().bytes.get_ref().clone()
    }
}

impl Write for SharedFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut state = self.0.borrow_mut();
        if state.fail_writes > 0 {
            state.fail_writes -= 1;
            return Err(io::Error::other("disk full (test)"));
        }
        let at = state.bytes.position();
        let room = state
            .capacity
            .map_or(buf.len() as u64, |c| c.saturating_sub(at));
        let n = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
        if n == 0 {
            return Err(io::Error::from(io::ErrorKind::StorageFull));
        }
        state.writes.push((at, n));
        state.bytes.write(&buf[..n])
    }

    fn flush(&mut self) -> io::Result<()> {
        let mut state = self.0.borrow_mut();
        let snapshot = state.bytes.get_ref().clone();
        state.snapshots.push(snapshot);
        Ok(())
    }
}

impl Seek for SharedFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.0.borrow_mut().bytes.seek(pos)
    }
}

impl LogFile for SharedFile {
    fn sync_data(&mut self) -> io::Result<()> {
        let mut state = self.0.borrow_mut();
        state.syncs += 1;
        if state.fail_syncs > 0 {
            state.fail_syncs -= 1;
            return Err(io::Error::other("I/O error (test)"));
        }
        Ok(())
    }

    fn set_len(&mut self, len: u64) -> io::Result<()> {
        let mut state = self.0.borrow_mut();
        state.cuts.push(len);
        state.bytes.set_len(len)
    }
}

/// Writes `seconds` of a flight: `imu` at 100 Hz, `state` at 50 Hz.
pub fn write_flight_to<F: LogFile>(log: &mut FlightLog<F>, seconds: u64) {
    for k in 0..seconds * 100 {
        let t = k * 10_000;
        log.write(
            "imu",
            t,
            &json!({"rate_rps": [0.01, 0.0, k as f64], "temp_c": 25.0}),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        if k % 2 == 0 {
            log.write(
                "state",
                t,
                &json!({"phase": "hold", "pos_ned_m": [1.0, 2.0, -10.0]}),
            )
            .unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

/// A finished log of `seconds` of flight, in memory.
pub fn write_flight(seconds: u64) -> Vec<u8> {
    let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
    write_flight_to(&mut log, seconds);
    log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner()
}
