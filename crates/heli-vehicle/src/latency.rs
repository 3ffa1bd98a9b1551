//! The flight computer's reaction time, stage by stage: for each servo command the control
//! loop wrote in answer to an IMU packet, when the IMU driver's read returned, when the loop
//! woke with it, when the control step started, when the servo bytes' write began and when
//! the step ended. All on `CLOCK_MONOTONIC`, which every process on the machine shares, so
//! that a HILSim beside the flight process can put its own stamps (IMU packet written, servo
//! packet read back) on the same line (`heli bench --hil`).
//!
//! Recording is off unless `--latency-trace PATH` asks for it. The records go into a buffer
//! allocated before the flight (no allocation and no file I/O in the loop; once it is full
//! further records are counted, not kept) and are written to `PATH` as CSV when the flight
//! process ends.

use std::cell::Cell;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::threads::Clock;

/// Records kept at most: an hour of 50 Hz servo commands (8.6 MB while tracing).
pub const MAX_RECORDS: usize = 180_000;

/// The CSV file's header line.
pub const HEADER: &str = "imu_read_ns,loop_woken_ns,step_start_ns,servo_written_ns,step_end_ns";

/// Now on `CLOCK_MONOTONIC` (ns): [`crate::rt::mono_ns`].
pub use crate::rt::mono_ns;

/// One servo command's way through the flight process (ns on `CLOCK_MONOTONIC`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepStamps {
    /// The IMU driver thread's read returned with the packet's last byte.
    pub imu_read_ns: u64,
    /// The control loop woke with it.
    pub loop_woken_ns: u64,
    /// The control step (the flight computer's `receive`) started.
    pub step_start_ns: u64,
    /// The servo packet's write to the servo board's port began.
    pub servo_written_ns: u64,
    /// The control step ended (logging and streams included).
    pub step_end_ns: u64,
}

impl StepStamps {
    /// As a CSV line (no newline).
    fn csv(&self) -> String {
        format!(
            "{},{},{},{},{}",
            self.imu_read_ns,
            self.loop_woken_ns,
            self.step_start_ns,
            self.servo_written_ns,
            self.step_end_ns
        )
    }

    /// From a CSV line.
    fn parse(line: &str) -> Option<Self> {
        let mut fields = line.split(',').map(|f| f.trim().parse::<u64>().ok());
        let mut next = || fields.next().flatten();
        let stamps = Self {
            imu_read_ns: next()?,
            loop_woken_ns: next()?,
            step_start_ns: next()?,
            servo_written_ns: next()?,
            step_end_ns: next()?,
        };
        fields.next().is_none().then_some(stamps)
    }
}

/// The records of one flight, in a buffer allocated up front.
#[derive(Debug)]
pub struct Trace {
    records: Vec<StepStamps>,
    /// Records that found the buffer full.
    pub dropped: u64,
}

impl Trace {
    /// A trace with room for `capacity` records (at most [`MAX_RECORDS`]).
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            records: Vec::with_capacity(capacity.min(MAX_RECORDS)),
            dropped: 0,
        }
    }

    /// Keeps a record, never growing the buffer: a full buffer counts it instead.
    pub fn push(&mut self, stamps: StepStamps) {
        if self.records.len() < self.records.capacity() {
            self.records.push(stamps);
        } else {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// The records kept.
    pub fn records(&self) -> &[StepStamps] {
        &self.records
    }

    /// Writes the records to `path` as CSV (header, one line per record).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
        writeln!(out, "{HEADER}")?;
        for r in &self.records {
            writeln!(out, "{}", r.csv())?;
        }
        out.flush()
    }
}

/// The control loop's probe: stamps the stages of each step while a trace is wanted, and
/// nothing (not even the clock) while it is not. Its methods take `&self` so that the loop's
/// port writer and its step can both stamp.
#[derive(Default)]
pub struct Probe {
    trace: Cell<Option<Trace>>,
    path: Option<PathBuf>,
    read_ns: Cell<u64>,
    woken_ns: Cell<u64>,
    start_ns: Cell<u64>,
    servo_ns: Cell<u64>,
}

impl Probe {
    /// A probe writing to `path` at the end, or an idle one.
    pub fn new(path: Option<PathBuf>) -> Self {
        Self {
            trace: Cell::new(path.as_ref().map(|_| Trace::with_capacity(MAX_RECORDS))),
            path,
            ..Self::default()
        }
    }

    fn on(&self) -> bool {
        self.path.is_some()
    }

    /// The loop woke with an input that the driver read at `read_us` on `clock`.
    pub fn woken(&self, clock: &Clock, read_us: u64) {
        if self.on() {
            self.woken_ns.set(mono_ns());
            self.read_ns.set(clock.mono_ns(read_us));
        }
    }

    /// The control step starts.
    pub fn step_start(&self) {
        if self.on() {
            self.start_ns.set(mono_ns());
            self.servo_ns.set(0);
        }
    }

    /// A servo packet's write begins.
    pub fn servo_written(&self) {
        if self.on() {
            self.servo_ns.set(mono_ns());
        }
    }

    /// The step ended; `imu` when its input was the IMU's bytes. A step that wrote a servo
    /// packet in answer to the IMU is kept.
    pub fn step_end(&self, imu: bool) {
        if !self.on() || !imu || self.servo_ns.get() == 0 {
            return;
        }
        let stamps = StepStamps {
            imu_read_ns: self.read_ns.get(),
            loop_woken_ns: self.woken_ns.get(),
            step_start_ns: self.start_ns.get(),
            servo_written_ns: self.servo_ns.get(),
            step_end_ns: mono_ns(),
        };
        let mut trace = self.trace.take();
        if let Some(t) = trace.as_mut() {
            t.push(stamps);
        }
        self.trace.set(trace);
    }

    /// Writes the trace (after the loop): a note saying where, or why not.
    pub fn finish(&self) -> Option<String> {
        let path = self.path.as_ref()?;
        let trace = self.trace.take()?;
        Some(match trace.write(path) {
            Ok(()) => format!(
                "latency trace: {} servo commands written to {}{}",
                trace.records().len(),
                path.display(),
                if trace.dropped > 0 {
                    format!(" ({} more not kept: the buffer was full)", trace.dropped)
                } else {
                    String::new()
                }
            ),
            Err(e) => format!("latency trace {}: {e}", path.display()),
        })
    }
}

/// Reads a trace file written by [`Trace::write`]; the error names the line that is wrong.
pub fn read(path: &Path) -> Result<Vec<StepStamps>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("latency trace {}: {e}", path.display()))?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == HEADER => {}
        _ => {
            return Err(format!(
                "latency trace {}: line 1 is not the header `{HEADER}`",
                path.display()
            ));
        }
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            StepStamps::parse(l).ok_or_else(|| {
                format!(
                    "latency trace {}: line {}: want five integers, found `{l}`",
                    path.display(),
                    i.saturating_add(1)
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_monotonic_clock_goes_forward_and_is_shared_with_instant() {
        let a = mono_ns();
        std::thread::sleep(std::time::Duration::from_millis(2));
        let b = mono_ns();
        assert!(b >= a + 2_000_000, "{a} {b}");
    }

    #[test]
    fn the_probe_keeps_the_steps_that_answered_the_imu_with_a_servo_packet() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trace.csv");
        let probe = Probe::new(Some(path.clone()));
        let clock = Clock::start();
        let began = mono_ns();
        // An IMU step that wrote the servo packet: kept, its stages in order.
        probe.woken(&clock, clock.now_us());
        probe.step_start();
        probe.servo_written();
        probe.step_end(true);
        // One that wrote none, and another input's that did: not kept.
        probe.woken(&clock, 6);
        probe.step_start();
        probe.step_end(true);
        probe.woken(&clock, 7);
        probe.step_start();
        probe.servo_written();
        probe.step_end(false);
        let note = probe.finish().unwrap();
        assert!(note.contains("1 servo commands"), "{note}");
        let records = read(&path).unwrap();
        assert_eq!(records.len(), 1);
        let r = records[0];
        // Every stamp taken during the test, on the machine's clock.
        let ended = mono_ns();
        for t in [
            r.imu_read_ns,
            r.loop_woken_ns,
            r.step_start_ns,
            r.servo_written_ns,
            r.step_end_ns,
        ] {
            assert!((began.saturating_sub(1_000)..=ended).contains(&t), "{r:?}");
        }
        // (The driver's read is stamped to the microsecond on the flight clock.)
        assert!(r.imu_read_ns <= r.loop_woken_ns + 1_000, "{r:?}");
        assert!(r.loop_woken_ns <= r.step_start_ns, "{r:?}");
        assert!(r.step_start_ns <= r.servo_written_ns, "{r:?}");
        assert!(r.servo_written_ns <= r.step_end_ns, "{r:?}");
        // Idle: nothing written, nothing said.
        let idle = Probe::new(None);
        idle.woken(&clock, 5);
        idle.servo_written();
        idle.step_end(true);
        assert!(idle.finish().is_none());
    }

    #[test]
    fn a_full_trace_counts_what_it_cannot_keep_and_never_grows() {
        let mut t = Trace::with_capacity(2);
        let cap = t.records.capacity();
        for i in 0..(cap as u64 + 3) {
            t.push(StepStamps {
                imu_read_ns: i,
                ..StepStamps::default()
            });
        }
        assert_eq!(t.records().len(), cap);
        assert_eq!(t.dropped, 3);
        assert_eq!(t.records.capacity(), cap);
    }

    #[test]
    fn a_trace_reads_back_what_was_written_and_names_a_bad_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let mut t = Trace::with_capacity(4);
        let r = StepStamps {
            imu_read_ns: 1,
            loop_woken_ns: 2,
            step_start_ns: 3,
            servo_written_ns: 4,
            step_end_ns: 5,
        };
        t.push(r);
        t.push(StepStamps {
            imu_read_ns: u64::MAX,
            ..r
        });
        t.write(&path).unwrap();
        assert_eq!(read(&path).unwrap(), t.records());
        std::fs::write(&path, format!("{HEADER}\n1,2,3,4,5\n1,2,x,4,5\n")).unwrap();
        let e = read(&path).unwrap_err();
        assert!(e.contains("line 3") && e.contains("1,2,x,4,5"), "{e}");
        std::fs::write(&path, "1,2,3,4,5\n").unwrap();
        assert!(read(&path).unwrap_err().contains("line 1"));
        std::fs::write(&path, format!("{HEADER}\n1,2,3,4,5,6\n")).unwrap();
        assert!(read(&path).unwrap_err().contains("line 2"));
    }
}
