//! The flight log on storage that fails (`heli_log::writer`): the fuzzer chooses the
//! messages and, write by write, whether the disk takes a write whole, part of it, or none
//! (a full disk, a read-only remount, a failing card). Asserts: no panic; after every call
//! the file reads to its end (or, when even the repair of a failed write failed, to the
//! last complete end before it); every message read back was written, in order; a log whose
//! storage works again is finished whole.
#![no_main]

use std::cell::RefCell;
use std::io::{self, Cursor, Seek, SeekFrom, Write};
use std::rc::Rc;

use heli_log::{FlightLog, LogFile, StopKind};
use libfuzzer_sys::fuzz_target;

/// A file whose writes succeed, stop short or fail as the fuzzer's bytes say.
#[derive(Clone, Default)]
struct Storage(Rc<RefCell<(Cursor<Vec<u8>>, Vec<u8>)>>);

impl Write for Storage {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut inner = self.0.borrow_mut();
        let verdict = inner.1.pop().unwrap_or(0);
        match verdict % 4 {
            // A short write: what fits of a disk that is filling.
            1 => {
                let n = buf.len().min(usize::from(verdict));
                if n == 0 {
                    return Err(io::Error::from(io::ErrorKind::StorageFull));
                }
                inner.0.write(&buf[..n])
            }
            2 => Err(io::Error::from(io::ErrorKind::StorageFull)),
            3 => Err(io::Error::from(io::ErrorKind::ReadOnlyFilesystem)),
            _ => inner.0.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Seek for Storage {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.0.borrow_mut().0.seek(pos)
    }
}

impl LogFile for Storage {
    fn set_len(&mut self, len: u64) -> io::Result<()> {
        self.0.borrow_mut().0.get_mut().resize(len as usize, 0);
        Ok(())
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let split = usize::from(first).min(rest.len());
    let (verdicts, messages) = rest.split_at(split);
    let storage = Storage::default();
    // Verdicts are taken from the end: reverse them so the first byte is the first write's.
    storage.0.borrow_mut().1 = verdicts.iter().rev().copied().collect();
    let Ok(mut log) = FlightLog::new(storage.clone()) else {
        return;
    };
    for (k, chunk) in messages.chunks(3).enumerate() {
        let t_us = k as u64 * 40_000;
        // An error is the storage's (or a message dropped past the backlog): what matters
        // is what the file holds.
        let _ = log.write("imu", t_us, &serde_json::json!({ "k": k, "bytes": chunk }));
        let bytes = storage.0.borrow().0.get_ref().clone();
        let contents = heli_log::read(&bytes);
        // Complete, or — only when the repair of a failed write failed too — cut inside
        // the records after the last complete end, which the next write replaces.
        if let Some(stop) = &contents.stopped {
            assert_eq!(stop.kind, StopKind::Truncated, "after message {k}: {stop}");
        }
        let ks: Vec<u64> = contents
            .messages
            .iter()
            .filter_map(|m| m.value["k"].as_u64())
            .collect();
        assert!(ks.windows(2).all(|w| w[0] < w[1]), "out of order: {ks:?}");
        assert!(
            ks.iter().all(|&n| n as usize <= k),
            "a message never written: {ks:?}"
        );
    }
    let storage_left = storage.0.borrow().1.len();
    let finished = log.finish();
    if storage_left == 0 {
        // Every write from here on succeeds: the log is finished and whole.
        assert!(finished.is_ok(), "{:?}", finished.err());
        let contents = heli_log::read(storage.0.borrow().0.get_ref());
        assert!(
            contents.stopped.is_none() && contents.closed,
            "{:?}",
            contents.stopped
        );
    }
});
