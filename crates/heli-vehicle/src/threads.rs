//! The driver threads: one per serial port and one for the compass's ADC channels. Each
//! reads its device, stamps what it read with the flight clock and hands it to the control
//! loop; the protocol half (framing, parsing, watchdogs) runs in the loop's
//! [`heli_fsw::FlightComputer`], the same code the simulator and the replay run.
//!
//! A port's thread runs under a supervisor: if it dies (a read error, a panic) the death is
//! reported and a fresh thread reopens the port after [`RESTART_DELAY`]. A port that cannot be
//! opened is reported once to the flight computer (its device is failed) and retried every
//! [`REOPEN_DELAY`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use heli_fsw::RecordedInput;
use heli_proto::compass::CompassAdc;
use heli_types::Port;
use serialport::TTYPort;

use crate::adc;
use crate::device_writes::WriteError;
use crate::devices::{Devices, baud};
use crate::error::VehicleError;
use crate::port;

/// Wait before a dead driver thread is replaced.
pub const RESTART_DELAY: Duration = Duration::from_millis(200);
/// Wait between tries to open a port that could not be opened.
pub const REOPEN_DELAY: Duration = Duration::from_secs(1);
/// Compass read period (20 Hz, as the thesis's analog monitor).
pub const COMPASS_PERIOD: Duration = Duration::from_millis(50);

/// The flight process's monotonic clock: microseconds since the flight process started,
/// running `speed` times as fast as the wall clock (1 on a vehicle; more only to fly against a
/// HILSim run faster than real time).
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    start: Instant,
    speed: f64,
    /// The wall-clock time of the start (µs since 1970), for records a successor reads.
    unix_start_us: i64,
}

impl Clock {
    /// A clock starting now, at wall-clock speed.
    pub fn start() -> Self {
        Self::with_speed(1.0)
    }

    /// A clock starting now, running `speed` times as fast as the wall clock (values that
    /// are not finite and positive count as 1).
    pub fn with_speed(speed: f64) -> Self {
        let unix_start_us = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(i64::MAX));
        Self {
            start: Instant::now(),
            unix_start_us,
            speed: if speed.is_finite() && speed > 0.0 {
                speed
            } else {
                1.0
            },
        }
    }

    /// Microseconds since the start.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn now_us(&self) -> u64 {
        (self.start.elapsed().as_secs_f64() * 1e6 * self.speed) as u64
    }

    /// The wall-clock time (µs since 1970) of the time `flight_us` on this clock.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn unix_us(&self, flight_us: i64) -> i64 {
        self.unix_start_us
            .saturating_add((flight_us as f64 / self.speed) as i64)
    }

    /// The time on this clock of the wall-clock time `unix_us` (µs since 1970): negative
    /// before the clock started.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn flight_us_of_unix(&self, unix_us: i64) -> i64 {
        (unix_us.saturating_sub(self.unix_start_us) as f64 * self.speed) as i64
    }

    /// The time `flight_us` on this clock as `CLOCK_MONOTONIC` (ns), to the microsecond, for
    /// stamps another process compares ([`crate::latency`]).
    pub fn mono_ns(&self, flight_us: u64) -> u64 {
        self.start
            .checked_add(self.wall(flight_us))
            .map_or(u64::MAX, crate::rt::mono_ns_at)
    }

    /// The wall-clock time `flight_us` of this clock take.
    pub fn wall(&self, flight_us: u64) -> Duration {
        Duration::try_from_secs_f64(flight_us as f64 * 1e-6 / self.speed).unwrap_or(Duration::MAX)
    }
}

/// What driver threads tell the loop.
#[derive(Debug)]
pub enum LoopMsg {
    /// An input for the flight computer, stamped when it was read (µs).
    Input(u64, RecordedInput),
    /// Something to report (a port error, a thread that died and was restarted).
    Note(String),
}

/// The write half of each serial port, shared between its driver thread (which opens it)
/// and the loop (which writes servo and altimeter commands).
#[derive(Default)]
pub struct Writers {
    scb: Mutex<Option<TTYPort>>,
    baro: Mutex<Option<TTYPort>>,
    /// Ports whose driver has made its first attempt to open them.
    attempted: std::sync::atomic::AtomicUsize,
}

impl Writers {
    fn slot(&self, port: Port) -> Option<&Mutex<Option<TTYPort>>> {
        match port {
            Port::Scb => Some(&self.scb),
            Port::Baro => Some(&self.baro),
            Port::Imu | Port::Gps => None,
        }
    }

    /// Writes `bytes` to `port`; an error if the port is not open (or takes no writes) or
    /// the write failed.
    pub fn write(&self, port: Port, bytes: &[u8]) -> Result<(), WriteError> {
        let slot = self.slot(port).ok_or(WriteError::NotOpen)?;
        let mut guard = slot.lock().unwrap_or_else(|e| e.into_inner());
        let open = guard.as_mut().ok_or(WriteError::NotOpen)?;
        port::write_all(open, bytes).map_err(WriteError::Io)
    }

    /// How many ports have had their first try at opening (successful or not).
    pub fn first_attempts(&self) -> usize {
        self.attempted.load(Ordering::Acquire)
    }

    /// Waits until every port has had its first try at opening, at most `limit`.
    pub fn wait_for_first_attempts(&self, limit: Duration) {
        let start = Instant::now();
        while self.first_attempts() < Port::ALL.len() && start.elapsed() < limit {
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn attempted(&self) {
        self.attempted.fetch_add(1, Ordering::AcqRel);
    }

    fn set(&self, port: Port, handle: Option<TTYPort>) {
        if let Some(slot) = self.slot(port) {
            *slot.lock().unwrap_or_else(|e| e.into_inner()) = handle;
        }
    }
}

/// Starts the supervised driver thread of `port`.
pub fn spawn_port(
    port: Port,
    devices: &Devices,
    clock: Clock,
    tx: Sender<LoopMsg>,
    writers: Arc<Writers>,
    stop: Arc<AtomicBool>,
    rt: crate::rt::RtThreads,
) -> std::io::Result<JoinHandle<()>> {
    let path = devices.port(port).to_path_buf();
    crate::rt::thread(
        format!("sup-{}", port.name()),
        crate::rt::HELPER_STACK_BYTES,
    )
    .spawn(move || {
        let mut reported_failed = false;
        let mut generation = 0u32;
        let mut first = true;
        while !stop.load(Ordering::Acquire) {
            // A port whose write half cannot be made is a port not opened: said, and
            // opened again (not read with every write to it lost as "port not open").
            let attempt = port::open(&path, baud(port))
                .and_then(|p| port::clone(&p, &path).map(|w| (p, w)))
                .map(|(p, w)| {
                    writers.set(port, Some(w));
                    p
                });
            if std::mem::take(&mut first) {
                writers.attempted();
            }
            let opened = match attempt {
                Ok(p) => p,
                Err(e) => {
                    if !reported_failed {
                        reported_failed = true;
                        let _ = tx.send(LoopMsg::Note(format!("{e}")));
                        let _ = tx.send(LoopMsg::Input(
                            clock.now_us(),
                            RecordedInput::PortFailed(port),
                        ));
                    }
                    sleep_unless_stopped(REOPEN_DELAY, &stop);
                    continue;
                }
            };
            if reported_failed {
                let _ = tx.send(LoopMsg::Note(format!(
                    "serial port {}: open again",
                    path.display()
                )));
                reported_failed = false;
            }
            generation = generation.saturating_add(1);
            let worker = {
                let tx = tx.clone();
                let stop = Arc::clone(&stop);
                crate::rt::thread(
                    format!("drv-{}-{generation}", port.name()),
                    crate::rt::HELPER_STACK_BYTES,
                )
                .spawn(move || {
                    // Refused without privileges: the loop's note says so already.
                    rt.driver();
                    read_port(port, opened, clock, &tx, &stop)
                })
            };
            let outcome = match worker {
                Ok(handle) => handle.join(),
                Err(source) => Ok(Err(VehicleError::Thread {
                    name: format!("{} driver", port.name()),
                    source,
                })),
            };
            if stop.load(Ordering::Acquire) {
                // The flight is ending: the loop may still write its last commands, so the
                // write half stays until the flight is over (it closes with the `Writers`).
                // Taken away here, the servo board's last command was lost and counted as a
                // failed write (seen on a loaded machine).
                break;
            }
            writers.set(port, None);
            let why = match outcome {
                Ok(Ok(())) => "stopped".to_string(),
                Ok(Err(e)) => e.to_string(),
                Err(_) => "panicked".to_string(),
            };
            let _ = tx.send(LoopMsg::Note(format!(
                "driver thread of {} died ({why}); restarting",
                port.name()
            )));
            sleep_unless_stopped(RESTART_DELAY, &stop);
        }
    })
}

/// The driver thread proper: read, stamp, hand over, until stopped or the port fails.
fn read_port(
    port: Port,
    mut serial: TTYPort,
    clock: Clock,
    tx: &Sender<LoopMsg>,
    stop: &AtomicBool,
) -> Result<(), VehicleError> {
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Acquire) {
        let n =
            port::read_some(&mut serial, &mut buf).map_err(|source| VehicleError::DeviceIo {
                doing: "read",
                source,
            })?;
        if n == 0 {
            continue;
        }
        let t_us = clock.now_us();
        let bytes = buf.get(..n).unwrap_or_default().to_vec();
        if tx
            .send(LoopMsg::Input(t_us, RecordedInput::Bytes(port, bytes)))
            .is_err()
        {
            return Ok(());
        }
    }
    Ok(())
}

/// Starts the compass's analog monitor: reads the three channels every [`COMPASS_PERIOD`].
pub fn spawn_compass(
    devices: &Devices,
    clock: Clock,
    tx: Sender<LoopMsg>,
    stop: Arc<AtomicBool>,
    rt: crate::rt::RtThreads,
) -> std::io::Result<JoinHandle<()>> {
    let dir = devices.adc.dir.clone();
    let channels = devices.adc.compass;
    crate::rt::thread("drv-compass", crate::rt::HELPER_STACK_BYTES).spawn(move || {
        // A driver like the serial ones: its reads are due on time under any other load.
        rt.driver();
        let mut next = Instant::now();
        let mut failing = false;
        while !stop.load(Ordering::Acquire) {
            let read: Result<Vec<u16>, _> = channels
                .iter()
                .map(|n| adc::read_channel(&dir, *n))
                .collect();
            match read.as_deref() {
                Ok([x, y, z]) => {
                    failing = false;
                    let adc = CompassAdc {
                        counts: [*x, *y, *z],
                    };
                    let input = LoopMsg::Input(clock.now_us(), RecordedInput::Compass(adc));
                    if tx.send(input).is_err() {
                        return;
                    }
                }
                Ok(_) => {}
                Err(e) => {
                    // Reported once per failing spell; the core's compass watchdog
                    // raises the silence.
                    if !failing {
                        failing = true;
                        let _ = tx.send(LoopMsg::Note(format!("compass: {e}")));
                    }
                }
            }
            // The period is in flight time (faster than the wall when the clock is sped up).
            let period_us = u64::try_from(COMPASS_PERIOD.as_micros()).unwrap_or(50_000);
            next = next.checked_add(clock.wall(period_us)).unwrap_or(next);
            if let Some(wait) = next.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            } else {
                next = Instant::now();
            }
        }
    })
}

/// Sleeps `d`, waking early when `stop` is set.
pub fn sleep_unless_stopped(d: Duration, stop: &AtomicBool) {
    let end = Instant::now().checked_add(d);
    while let Some(end) = end {
        if stop.load(Ordering::Acquire) {
            return;
        }
        let Some(left) = end.checked_duration_since(Instant::now()) else {
            return;
        };
        std::thread::sleep(left.min(Duration::from_millis(20)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serialport::SerialPort;
    use std::path::PathBuf;
    use std::time::Duration;

    #[test]
    fn the_loop_waits_for_every_port_s_first_try_but_no_longer_than_its_limit() {
        let writers = Writers::default();
        // No port has tried: the whole limit.
        let start = Instant::now();
        writers.wait_for_first_attempts(Duration::from_millis(40));
        assert!(start.elapsed() >= Duration::from_millis(40));
        // All but one: still the whole limit.
        for _ in 1..Port::ALL.len() {
            writers.attempted();
        }
        let start = Instant::now();
        writers.wait_for_first_attempts(Duration::from_millis(40));
        assert!(start.elapsed() >= Duration::from_millis(40));
        // Every port has tried: at once, however long the limit.
        writers.attempted();
        let start = Instant::now();
        writers.wait_for_first_attempts(Duration::from_secs(30));
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "{:?}",
            start.elapsed()
        );
    }

    fn devices_with_imu(path: PathBuf) -> Devices {
        let mut d = Devices::hilsim(std::path::Path::new("/nonexistent"));
        d.ports.imu = path;
        d
    }

    #[test]
    fn the_clock_says_its_times_on_the_machines_monotonic_clock() {
        let near = |a: u64, b: u64| a.abs_diff(b) < 20_000;
        let before = crate::rt::mono_ns();
        let clock = Clock::start();
        let after = crate::rt::mono_ns();
        // Its start, and a time on it: to the microsecond, on the clock other processes read.
        let start = clock.mono_ns(0);
        assert!(
            start + 20_000 > before && start < after + 20_000,
            "{before} {start} {after}"
        );
        std::thread::sleep(Duration::from_millis(3));
        let now_us = clock.now_us();
        let now_ns = crate::rt::mono_ns();
        assert!(
            near(clock.mono_ns(now_us), now_ns),
            "{} {now_ns}",
            clock.mono_ns(now_us)
        );
        assert!(near(clock.mono_ns(now_us) - start, now_us * 1_000));
        // At twice the wall clock's speed, two flight seconds are one on the wall.
        let fast = Clock::with_speed(2.0);
        let fast_start = fast.mono_ns(0);
        assert!(near(fast.mono_ns(2_000_000) - fast_start, 1_000_000_000));
        assert!(near(fast.mono_ns(60_000) - fast_start, 30_000_000));
    }

    #[test]
    fn a_driver_thread_that_dies_is_reported_and_replaced() {
        let (master, slave) = TTYPort::pair().unwrap();
        let path = PathBuf::from(slave.name().unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let handle = spawn_port(
            Port::Imu,
            &devices_with_imu(path),
            Clock::start(),
            tx,
            Arc::new(Writers::default()),
            Arc::clone(&stop),
            crate::rt::RtThreads::default(),
        )
        .unwrap();
        std::thread::sleep(Duration::from_millis(200));
        // The other end goes away: the driver's reads fail and its thread ends.
        drop(master);
        drop(slave);
        let mut notes = Vec::new();
        let end = Instant::now() + Duration::from_secs(5);
        while Instant::now() < end && !notes.iter().any(|n: &String| n.contains("restarting")) {
            if let Ok(LoopMsg::Note(n)) = rx.recv_timeout(Duration::from_millis(100)) {
                notes.push(n);
            }
        }
        assert!(
            notes
                .iter()
                .any(|n| n.contains("driver thread of imu died")),
            "{notes:?}"
        );
        // Its replacement cannot open the port (it is gone): the device is failed, once.
        let mut failed = 0;
        let end = Instant::now() + Duration::from_secs(3);
        while Instant::now() < end {
            if let Ok(LoopMsg::Input(_, RecordedInput::PortFailed(Port::Imu))) =
                rx.recv_timeout(Duration::from_millis(100))
            {
                failed += 1;
            }
        }
        assert_eq!(failed, 1);
        stop.store(true, Ordering::Release);
        handle.join().unwrap();
    }

    #[test]
    fn a_driver_stopping_with_the_flight_leaves_the_loop_its_port_to_write_the_last_commands() {
        let (mut board, slave) = TTYPort::pair().unwrap();
        let mut devices = Devices::hilsim(std::path::Path::new("/nonexistent"));
        devices.ports.scb = PathBuf::from(slave.name().unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, _rx) = std::sync::mpsc::channel();
        let writers = Arc::new(Writers::default());
        let handle = spawn_port(
            Port::Scb,
            &devices,
            Clock::start(),
            tx,
            Arc::clone(&writers),
            Arc::clone(&stop),
            crate::rt::RtThreads::default(),
        )
        .unwrap();
        let end = Instant::now() + Duration::from_secs(5);
        while writers.write(Port::Scb, b"a").is_err() && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        // The flight ends: its driver thread is gone, and the loop's last command still goes.
        stop.store(true, Ordering::Release);
        handle.join().unwrap();
        assert!(
            writers.write(Port::Scb, b"z").is_ok(),
            "the last command found no port"
        );
        let mut got = Vec::new();
        let mut buf = [0u8; 16];
        let end = Instant::now() + Duration::from_secs(5);
        while !got.ends_with(b"z") && Instant::now() < end {
            if let Ok(n) = std::io::Read::read(&mut board, &mut buf) {
                got.extend_from_slice(&buf[..n]);
            }
        }
        assert!(got.ends_with(b"z"), "{got:?}");
    }

    #[test]
    fn a_port_that_never_opens_fails_its_device_once_and_is_retried_quietly() {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let handle = spawn_port(
            Port::Imu,
            &devices_with_imu(PathBuf::from("/nonexistent/ttyIMU")),
            Clock::start(),
            tx,
            Arc::new(Writers::default()),
            Arc::clone(&stop),
            crate::rt::RtThreads::default(),
        )
        .unwrap();
        std::thread::sleep(Duration::from_millis(2_300));
        stop.store(true, Ordering::Release);
        handle.join().unwrap();
        let msgs: Vec<LoopMsg> = rx.try_iter().collect();
        let notes = msgs
            .iter()
            .filter(|m| matches!(m, LoopMsg::Note(n) if n.contains("no such device")))
            .count();
        let failed = msgs
            .iter()
            .filter(|m| matches!(m, LoopMsg::Input(_, RecordedInput::PortFailed(Port::Imu))))
            .count();
        assert_eq!((notes, failed), (1, 1), "{msgs:?}");
    }

    #[test]
    fn the_clock_runs_at_its_speed_from_its_start() {
        for nonsense in [0.0, -2.0, f64::NAN, f64::INFINITY] {
            let c = Clock::with_speed(nonsense);
            assert_eq!(c.wall(1_000_000), Duration::from_secs(1), "{nonsense}");
        }
        let c = Clock::with_speed(4.0);
        assert_eq!(c.wall(1_000_000), Duration::from_millis(250));
        assert_eq!(c.wall(3), Duration::from_nanos(750));
        let before = std::time::Instant::now();
        std::thread::sleep(Duration::from_millis(30));
        let now = c.now_us();
        let wall_us = before.elapsed().as_micros() as u64;
        // Four flight microseconds per wall microsecond since the start (created before
        // `before`, read after the sleep).
        assert!(now >= 4 * 30_000, "{now}");
        assert!(now <= 4 * (wall_us + 5_000), "{now} for {wall_us} us");
        let fresh = Clock::start();
        assert!(fresh.now_us() < 5_000);
        assert_eq!(fresh.wall(2_000), Duration::from_millis(2));
    }

    #[test]
    fn a_sleep_lasts_its_time_unless_stopped() {
        let stop = AtomicBool::new(false);
        let started = Instant::now();
        sleep_unless_stopped(Duration::from_millis(60), &stop);
        assert!(started.elapsed() >= Duration::from_millis(60));
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let stopper = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(30));
            flag.store(true, Ordering::Release);
        });
        let started = Instant::now();
        sleep_unless_stopped(Duration::from_secs(10), &stop);
        assert!(
            started.elapsed() < Duration::from_secs(2),
            "{:?}",
            started.elapsed()
        );
        stopper.join().unwrap();
    }
}
