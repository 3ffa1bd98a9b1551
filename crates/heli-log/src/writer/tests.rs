//! Tests of the writer: complete records only, a complete file after every flush.

use super::*;
use crate::read;
use crate::testutil::{SharedFile, write_flight, write_flight_to};
use serde_json::json;

#[test]
fn after_every_flush_the_file_is_a_complete_mcap_file() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    write_flight_to(&mut log, 5);
    let written = log.messages();
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let state = file.0.borrow();
    assert!(
        state.snapshots.len() > 45,
        "{} flushes",
        state.snapshots.len()
    );
    let mut previous = 0;
    for (i, snapshot) in state.snapshots.iter().enumerate() {
        let contents = read(snapshot);
        let last = i + 1 == state.snapshots.len();
        assert_eq!(contents.stopped, None, "flush {i}");
        assert_eq!(contents.closed, last, "flush {i}");
        let n = contents.messages.len();
        assert!(n >= previous, "flush {i} lost messages");
        previous = n;
    }
    assert_eq!(previous as u64, written);
    // One write per flush, at the provisional end of the file before it: everything before
    // that end is written once and never again.
    assert_eq!(state.writes.len(), state.snapshots.len());
    let mut length = 0u64;
    for (i, &(at, n)) in state.writes.iter().enumerate() {
        assert_eq!(at, length.saturating_sub(50), "write {i}");
        length = at + n as u64;
    }
}

#[test]
fn a_crash_loses_at_most_the_last_100_ms_of_log_time() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    for k in 0..300u64 {
        let t_us = k * 10_000;
        log.write("imu", t_us, &json!({ "k": k }))
            .unwrap_or_else(|e| panic!("{e}"));
        // A crash now leaves the file as it is: everything older than 100 ms is in it.
        let contents = read(&file.bytes());
        assert_eq!(contents.stopped, None);
        let kept = contents.messages.last().map_or(0, |m| m.t_us + 10_000);
        assert!(
            t_us + 10_000 - kept <= FLUSH_EVERY_US,
            "at {t_us} us only up to {kept}"
        );
    }
}

#[test]
fn each_channel_numbers_its_own_messages() {
    let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
    let v = json!({});
    for (topic, t) in [
        ("imu", 0),
        ("imu", 10),
        ("state", 10),
        ("imu", 20),
        ("state", 30),
    ] {
        log.write(topic, t, &v).unwrap_or_else(|e| panic!("{e}"));
    }
    log.write_sequenced("gps", 41, 40, &v)
        .unwrap_or_else(|e| panic!("{e}"));
    log.write("gps", 50, &v).unwrap_or_else(|e| panic!("{e}"));
    let bytes = log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner();
    let contents = read(&bytes);
    let sequences = |topic: &str| -> Vec<u32> {
        contents
            .messages
            .iter()
            .filter(|m| m.topic == topic)
            .map(|m| m.sequence)
            .collect()
    };
    assert_eq!(sequences("imu"), [0, 1, 2]);
    assert_eq!(sequences("state"), [0, 1]);
    assert_eq!(sequences("gps"), [41, 42]);
}

#[test]
fn metadata_is_in_the_file_at_once_and_reads_back() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    let entries: BTreeMap<String, String> =
        [("software".to_string(), "heli 0.1.0".to_string())].into();
    log.write_metadata("flight", &entries)
        .unwrap_or_else(|e| panic!("{e}"));
    // Not finished: the record is there already.
    let contents = read(&file.bytes());
    assert_eq!(contents.metadata.len(), 1);
    assert_eq!(contents.metadata[0].name, "flight");
    assert_eq!(contents.metadata[0].entries, entries);
    drop(log);
    assert_eq!(read(&file.bytes()).metadata[0].entries, entries);
}

#[test]
fn wall_clock_time_flushes_when_log_time_stands_still() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    log.write("imu", 0, &json!({}))
        .unwrap_or_else(|e| panic!("{e}"));
    let before = log.stats().flushes;
    assert!(!log.flush_if_due().unwrap_or(true), "nothing due yet");
    std::thread::sleep(FLUSH_EVERY_WALL + Duration::from_millis(5));
    assert!(log.flush_if_due().unwrap_or(false));
    assert_eq!(log.stats().flushes, before + 1);
    assert_eq!(read(&file.bytes()).messages.len(), 1);
    // The same through a write that does not advance the log time.
    std::thread::sleep(FLUSH_EVERY_WALL + Duration::from_millis(5));
    log.write("imu", 0, &json!({}))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(log.stats().flushes, before + 2);
}

#[test]
fn flushes_are_synced_at_most_every_50_ms_and_always_at_the_end() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file.0.borrow().syncs, 1, "the empty file is synced");
    // 10 s of log time written far faster than real time: 100 flushes, few syncs.
    write_flight_to(&mut log, 10);
    let stats = log.stats();
    assert!(stats.flushes >= 100);
    assert!(stats.syncs < stats.flushes / 2, "{stats:?}");
    std::thread::sleep(SYNC_EVERY_WALL + Duration::from_millis(5));
    log.flush().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(log.stats().syncs, stats.syncs + 1);
    let syncs = log.stats().syncs;
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file.0.borrow().syncs, syncs + 1, "finish syncs");
}

#[test]
fn a_failed_sync_is_an_error_and_the_log_fails_until_a_sync_works() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    log.write("imu", 0, &json!({"k": 0}))
        .unwrap_or_else(|e| panic!("{e}"));
    std::thread::sleep(SYNC_EVERY_WALL + Duration::from_millis(5));
    file.0.borrow_mut().fail_syncs = 2;
    let e = log.flush().expect_err("the sync failed");
    assert!(matches!(e, LogError::Sync(_)), "{e}");
    assert!(
        e.to_string().contains("may not survive a power loss"),
        "{e}"
    );
    let failing = log
        .sync_failing_since()
        .expect("failing after a failed sync");
    assert_eq!(log.failing_since(), None, "the write went out");
    assert_eq!(log.stats().failed_syncs, 1);
    // The next write goes out, but the data is still not synced: the log still fails, and
    // the sync is tried again (once its wait is over) without a new write needing it.
    log.write("imu", 10_000, &json!({"k": 1}))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(log.sync_failing_since(), Some(failing));
    std::thread::sleep(SYNC_EVERY_WALL + Duration::from_millis(5));
    assert!(matches!(log.flush_if_due(), Err(LogError::Sync(_))));
    assert_eq!(log.stats().failed_syncs, 2);
    assert_eq!(
        log.sync_failing_since(),
        Some(failing),
        "the spell's start is kept"
    );
    std::thread::sleep(SYNC_EVERY_WALL + Duration::from_millis(5));
    log.flush_if_due().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(log.sync_failing_since(), None, "a sync that works ends it");
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let contents = read(&file.bytes());
    assert_eq!((contents.stopped, contents.closed), (None, true));
    assert_eq!(contents.messages.len(), 2, "nothing written was lost");
}

#[test]
fn a_failed_write_is_retried_and_nothing_is_lost() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    log.write("imu", 0, &json!({"k": 0}))
        .unwrap_or_else(|e| panic!("{e}"));
    file.0.borrow_mut().fail_writes = 1;
    assert!(log.write("imu", 200_000, &json!({"k": 1})).is_err());
    log.write("imu", 400_000, &json!({"k": 2}))
        .unwrap_or_else(|e| panic!("{e}"));
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let contents = read(&file.bytes());
    assert_eq!((contents.stopped, contents.closed), (None, true));
    assert_eq!(contents.messages.len(), 3);
}

#[test]
fn a_log_dropped_without_finish_is_closed() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    write_flight_to(&mut log, 1);
    drop(log);
    let contents = read(&file.bytes());
    assert!(contents.closed);
    assert_eq!(contents.messages.len(), 150);
}

#[test]
fn indexes_are_optional_and_change_nothing_that_is_read() {
    let plain = write_flight(5);
    let mut log = FlightLog::with_options(
        Cursor::new(Vec::new()),
        LogOptions {
            indexed: true,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    write_flight_to(&mut log, 5);
    let indexed = log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner();
    assert_eq!(read(&plain).messages, read(&indexed).messages);
    // With a chunk every 100 ms the indexes are a large part of the file.
    assert!(
        indexed.len() as f64 > plain.len() as f64 * 1.2,
        "{} vs {}",
        indexed.len(),
        plain.len()
    );
}

#[test]
fn writing_after_finish_is_an_error_not_a_panic() {
    let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
    assert!(log.close().is_ok());
    assert!(matches!(
        log.write("imu", 0, &json!({})),
        Err(LogError::Finished)
    ));
    assert!(matches!(log.flush(), Err(LogError::Finished)));
}

/// Writes one message a 10 ms step; returns whether the writer took it.
fn step(log: &mut FlightLog<SharedFile>, k: u64) -> bool {
    log.write(
        "imu",
        k * 10_000,
        &json!({ "k": k, "rate_rps": [0.1, 0.2, k as f64] }),
    )
    .is_ok()
}

#[test]
fn a_disk_that_fills_leaves_a_complete_file_cut_back_to_its_last_flush() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    for k in 0..200 {
        assert!(step(&mut log, k));
    }
    let before = read(&file.bytes()).messages.len();
    assert!(before > 150, "{before}");
    // The disk fills: it holds 300 bytes more than the file now has.
    let full_at = file.bytes().len() as u64 + 300;
    file.0.borrow_mut().capacity = Some(full_at);
    let mut refused = 0;
    for k in 200..400 {
        if !step(&mut log, k) {
            refused += 1;
            // Each failed write was short (the disk took what fitted): the file is cut back
            // to its last complete end, and every reader reads it whole.
            let contents = read(&file.bytes());
            assert_eq!(contents.stopped, None, "after the failure at k = {k}");
            assert!(contents.messages.len() >= before);
        }
    }
    assert!(refused > 0, "the disk never refused a write");
    let stats = log.stats();
    assert!(stats.failed_writes > 0);
    assert!(log.failing_since().is_some());
    assert!(
        file.0.borrow().cuts.iter().all(|&len| len <= full_at),
        "cut to past the end"
    );
    // Space is freed: the next flush writes everything kept, from where the file ended.
    file.0.borrow_mut().capacity = None;
    log.flush().unwrap_or_else(|e| panic!("{e}"));
    assert!(log.failing_since().is_none());
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let contents = read(&file.bytes());
    assert_eq!((contents.stopped, contents.closed), (None, true));
    assert_eq!(contents.messages.len(), 400, "nothing was lost");
    let ks: Vec<u64> = contents
        .messages
        .iter()
        .filter_map(|m| m.value["k"].as_u64())
        .collect();
    assert_eq!(ks, (0..400).collect::<Vec<_>>(), "in order, once each");
}

#[test]
fn while_the_disk_stays_full_the_memory_is_bounded_and_drops_are_counted() {
    let file = SharedFile::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    // The backlog's memory is there from the start.
    let reserved = log.unwritten.capacity();
    assert!(reserved >= BACKLOG_RESERVE_BYTES);
    assert!(step(&mut log, 0));
    log.flush().unwrap_or_else(|e| panic!("{e}"));
    file.0.borrow_mut().capacity = Some(file.bytes().len() as u64);
    let _ = log.flush();
    // Messages that do not compress: the backlog fills with a few thousand of them.
    let mut dropped = 0u64;
    let mut k = 1u64;
    while dropped < 1000 {
        let noise: Vec<u64> = (0..16)
            .map(|i| (k * 0x9e37_79b9_7f4a_7c15).rotate_left(i))
            .collect();
        match log.write("imu", k * 10_000, &json!({ "k": k, "noise": noise })) {
            Ok(()) => {}
            Err(LogError::Dropped { backlog_bytes }) => {
                assert!(backlog_bytes >= MAX_BACKLOG_BYTES);
                dropped += 1;
            }
            // Taken; the flush it was due for failed.
            Err(LogError::Io(_)) => {}
            Err(e) => panic!("{e}"),
        }
        if k.is_multiple_of(64) {
            let _ = log.flush();
        }
        k += 1;
        assert!(k < 1_000_000, "never dropped");
    }
    assert_eq!(log.stats().dropped, dropped);
    // The backlog stops where it was: at most one closed chunk past the bound, in the
    // memory reserved at the start (never reallocated: the process does not grow).
    assert!(log.unwritten.len() < MAX_BACKLOG_BYTES + (MAX_CHUNK_BYTES as usize) * 2);
    assert_eq!(log.unwritten.capacity(), reserved);
    // The disk comes back: what was kept is written, in order, and the log goes on.
    file.0.borrow_mut().capacity = None;
    log.flush().unwrap_or_else(|e| panic!("{e}"));
    assert!(log.write("imu", k * 10_000, &json!({ "k": k })).is_ok());
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let contents = read(&file.bytes());
    assert_eq!((contents.stopped, contents.closed), (None, true));
    assert_eq!(contents.messages.len() as u64, k + 1 - dropped);
}
