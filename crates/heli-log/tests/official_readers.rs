//! The official Python MCAP reader opens what a crash leaves of a heli log.
//!
//! Runs when `HELI_MCAP_PYTHON` names a Python with the `mcap` package installed (`.ci/run`
//! makes one: `python3 -m venv DIR && DIR/bin/pip install mcap`); otherwise it prints a note
//! and passes. A flight is written through a file that keeps a copy of itself after every
//! write — the file a crash at that moment would leave — and for the last flush before
//! `finish` and for several arbitrary moments of the flight, Python's
//! `mcap.reader.make_reader(f).iter_messages()` must read exactly the messages written up to
//! that flush, and `iter_metadata()` the flight's metadata; then the finished file.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::io::{self, Cursor, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::process::Command;
use std::rc::Rc;

use heli_log::{FlightLog, LogFile};
use serde_json::{Value, json};

/// The file's bytes, and a copy of them after every write.
type FileAndCopies = (Cursor<Vec<u8>>, Vec<Vec<u8>>);

/// A log file in memory that keeps a copy of itself after every write.
#[derive(Clone, Default)]
struct Snapshots(Rc<RefCell<FileAndCopies>>);

impl Write for Snapshots {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut inner = self.0.borrow_mut();
        let n = inner.0.write(buf)?;
        let copy = inner.0.get_ref().clone();
        inner.1.push(copy);
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Seek for Snapshots {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.0.borrow_mut().0.seek(pos)
    }
}

impl LogFile for Snapshots {
    fn set_len(&mut self, len: u64) -> io::Result<()> {
        self.0.borrow_mut().0.get_mut().resize(len as usize, 0);
        Ok(())
    }
}

/// A log file on a disk that fills: it cannot grow past `capacity` (a write that would is
/// short, the next one fails), and a copy of it is kept at every `flush` — after each
/// complete write and after each repair of a failed one.
#[derive(Clone, Default)]
struct FullDisk(Rc<RefCell<DiskState>>);

/// The file's bytes, a copy at every flush, and the disk's capacity.
type DiskState = (Cursor<Vec<u8>>, Vec<Vec<u8>>, Option<u64>);

impl Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut inner = self.0.borrow_mut();
        let at = inner.0.position();
        let room = inner.2.map_or(buf.len() as u64, |c| c.saturating_sub(at));
        let n = buf.len().min(room as usize);
        if n == 0 {
            return Err(io::Error::from(io::ErrorKind::StorageFull));
        }
        inner.0.write(&buf[..n])
    }

    fn flush(&mut self) -> io::Result<()> {
        let mut inner = self.0.borrow_mut();
        let copy = inner.0.get_ref().clone();
        inner.1.push(copy);
        Ok(())
    }
}

impl Seek for FullDisk {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.0.borrow_mut().0.seek(pos)
    }
}

impl LogFile for FullDisk {
    fn set_len(&mut self, len: u64) -> io::Result<()> {
        self.0.borrow_mut().0.get_mut().resize(len as usize, 0);
        Ok(())
    }
}

/// Runs the official reader on each file; one JSON line per file.
fn python_reads(python: &std::ffi::OsStr, paths: &[PathBuf]) -> Vec<Value> {
    let out = Command::new(python)
        .arg("-c")
        .arg(READER)
        .args(paths)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {python:?}: {e}"));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_default())
        .collect()
}

/// Reads each file with Python's `mcap` and prints one JSON line per file.
const READER: &str = r#"
import json, sys
from mcap.reader import make_reader
for path in sys.argv[1:]:
    try:
        with open(path, "rb") as f:
            messages = [[c.topic, m.log_time, m.sequence]
                        for _, c, m in make_reader(f).iter_messages()]
        with open(path, "rb") as f:
            metadata = [[m.name, m.metadata] for m in make_reader(f).iter_metadata()]
        print(json.dumps({"messages": messages, "metadata": metadata}))
    except Exception as e:
        print(json.dumps({"error": f"{type(e).__name__}: {e}"}))
"#;

#[test]
fn pythons_mcap_reader_reads_every_message_up_to_the_last_flush() {
    let Some(python) = std::env::var_os("HELI_MCAP_PYTHON") else {
        println!("HELI_MCAP_PYTHON is not set: the official Python reader was not tried");
        return;
    };
    let file = Snapshots::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    let metadata: BTreeMap<String, String> = [("scenario".to_string(), "test".to_string())].into();
    log.write_metadata("flight", &metadata)
        .unwrap_or_else(|e| panic!("{e}"));
    // Every message written, and how many had been written when each snapshot was taken.
    let mut written: Vec<(String, u64, u32)> = Vec::new();
    let mut upto: Vec<usize> = Vec::new();
    let mut sequences: BTreeMap<&str, u32> = BTreeMap::new();
    upto.resize(file.0.borrow().1.len(), 0);
    for k in 0..1500u64 {
        let t_us = k * 10_000;
        let mut messages: Vec<(&str, Value)> =
            vec![("imu", json!({ "k": k, "rate_rps": [0.0, 0.1, k as f64] }))];
        if k % 2 == 0 {
            messages.push((
                "state",
                json!({ "phase": "hold", "pos_ned_m": [k as f64, 0.0, -10.0] }),
            ));
        }
        if k % 100 == 0 {
            messages.push(("gps", json!({ "lat_deg": 42.36, "lon_deg": -71.09 })));
        }
        for (topic, value) in messages {
            log.write(topic, t_us, &value)
                .unwrap_or_else(|e| panic!("{e}"));
            let sequence = sequences.entry(topic).or_insert(0);
            written.push((topic.to_string(), t_us * 1000, *sequence));
            *sequence += 1;
            let snapshots = file.0.borrow().1.len();
            upto.resize(snapshots, written.len());
        }
    }
    let before_finish = file.0.borrow().1.len();
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let state = file.0.borrow();
    let (finished, snapshots) = (state.0.get_ref().clone(), &state.1);
    assert!(before_finish > 100, "{before_finish} flushes");

    // The moments of the crashes: the last flush before finish, and arbitrary ones.
    let mut cases: Vec<(Vec<u8>, usize)> = vec![(
        snapshots[before_finish - 1].clone(),
        upto[before_finish - 1],
    )];
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    for _ in 0..6 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let i = 1 + (x % (before_finish as u64 - 1)) as usize;
        cases.push((
            snapshots[i].clone(),
            upto.get(i).copied().unwrap_or(written.len()),
        ));
    }
    cases.push((finished, written.len()));

    let dir = std::env::temp_dir().join(format!("heli-official-readers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let paths: Vec<PathBuf> = cases
        .iter()
        .enumerate()
        .map(|(i, (bytes, _))| {
            let path = dir.join(format!("cut{i}.mcap"));
            std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
            path
        })
        .collect();
    let out = Command::new(&python)
        .arg("-c")
        .arg(READER)
        .args(&paths)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {python:?}: {e}"));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_default())
        .collect();
    assert_eq!(lines.len(), cases.len());
    for ((line, (_, n)), path) in lines.iter().zip(&cases).zip(&paths) {
        assert!(line.get("error").is_none(), "{}: {line}", path.display());
        let mut read: Vec<(String, u64, u32)> = line["messages"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|m| {
                let topic = m[0].as_str().unwrap_or_default().to_string();
                (
                    topic,
                    m[1].as_u64().unwrap_or(0),
                    m[2].as_u64().unwrap_or(0) as u32,
                )
            })
            .collect();
        read.sort();
        let mut expected = written[..*n].to_vec();
        expected.sort();
        assert_eq!(read.len(), expected.len(), "{}", path.display());
        assert!(
            read == expected,
            "{}: not the messages written",
            path.display()
        );
        assert_eq!(
            line["metadata"],
            json!([["flight", {"scenario": "test"}]]),
            "{}",
            path.display()
        );
        println!(
            "{}: Python read all {n} messages written before it was cut",
            path.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn pythons_mcap_reader_opens_the_log_at_every_moment_of_a_disk_that_fills() {
    let Some(python) = std::env::var_os("HELI_MCAP_PYTHON") else {
        println!("HELI_MCAP_PYTHON is not set: the official Python reader was not tried");
        return;
    };
    let file = FullDisk::default();
    let mut log = FlightLog::new(file.clone()).unwrap_or_else(|e| panic!("{e}"));
    let mut failures = 0;
    for k in 0..1200u64 {
        if k == 300 {
            // The disk fills: 3 kB more fit, part of a flush.
            let mut inner = file.0.borrow_mut();
            let len = inner.0.get_ref().len() as u64;
            inner.2 = Some(len + 3000);
        }
        if k == 900 {
            file.0.borrow_mut().2 = None;
        }
        let value = json!({ "k": k, "rate_rps": [0.0, 0.1, k as f64] });
        if log.write("imu", k * 10_000, &value).is_err() {
            failures += 1;
        }
    }
    assert!(failures > 0, "the disk never refused a write");
    log.finish().unwrap_or_else(|e| panic!("{e}"));
    let copies = file.0.borrow().1.clone();
    let dir = std::env::temp_dir().join(format!("heli-full-disk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let paths: Vec<PathBuf> = copies
        .iter()
        .enumerate()
        .map(|(i, bytes)| {
            let path = dir.join(format!("moment{i}.mcap"));
            std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
            path
        })
        .collect();
    let lines = python_reads(&python, &paths);
    assert_eq!(lines.len(), paths.len());
    let mut previous = 0;
    for (line, path) in lines.iter().zip(&paths) {
        assert!(line.get("error").is_none(), "{}: {line}", path.display());
        let n = line["messages"].as_array().map_or(0, Vec::len);
        assert!(
            n >= previous,
            "{}: {n} messages after {previous}",
            path.display()
        );
        previous = n;
    }
    assert_eq!(previous, 1200, "the finished log has every message");
    println!(
        "Python opened the log at all {} moments of a disk that filled ({failures} refused writes)",
        paths.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
