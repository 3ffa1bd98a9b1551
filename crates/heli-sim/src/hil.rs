//! `heli hilsim --ptys DIR`: the simulator alone, in real time, as the thesis's HILSim
//! computer — the helicopter's devices on the flight computer's own interfaces.
//!
//! Each serial device is a pseudo-terminal: `DIR/imu`, `DIR/scb`, `DIR/gps`, `DIR/baro` are
//! symlinks to the terminal ends a flight computer opens like any serial port. The simulator
//! writes each device's bytes when the last byte would have arrived at the device's baud
//! rate, and reads back what the computer writes (servo commands on `scb`, the handshake on
//! `baro`). The analog channels are an IIO-style directory, `DIR/adc/in_voltageN_raw`
//! (compass x, y, z on 0, 1, 2; battery on 3), each file replaced atomically at the
//! channel's rate, so the same driver reads a real `/sys/bus/iio/devices/iio:deviceN`.
//!
//! The run is paced to the wall clock times `speed`. Bytes that no one reads are dropped once
//! a terminal's buffer is full, as a serial line with no listener loses them.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use heli_types::Port;
use serialport::{SerialPort, TTYPort};

use crate::lockstep::{HilOut, Simulation};
use crate::summary::{HilStamps, HilSummary, Percentiles, Starved, Summary};
use heli_scenario::Scenario;

/// Why the HILSim could not run, or stopped early.
#[derive(Debug)]
pub enum HilError {
    /// A speed out of its range.
    Speed(f64),
    /// The scenario cannot be flown.
    Scenario(heli_scenario::ScenarioError),
    /// A device could not be made, read or written: what, and the system's answer.
    Device {
        /// What was being done.
        what: String,
        /// The system's answer.
        error: std::io::Error,
    },
    /// The recording cannot be replayed.
    Recording(crate::replay::log::ReplayError),
    /// Stopped before a flight computer started.
    Stopped,
    /// No flight computer wrote to the devices within this time (s).
    NoComputer(f64),
}

impl std::fmt::Display for HilError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HilError::Speed(v) => write!(f, "--speed {v}: must be more than 0 and at most 100"),
            HilError::Scenario(e) => write!(f, "{e}"),
            HilError::Device { what, error } => write!(f, "{what}: {error}"),
            HilError::Recording(e) => write!(f, "{e}"),
            HilError::Stopped => write!(f, "stopped before a flight computer started"),
            HilError::NoComputer(s) => {
                write!(f, "no flight computer wrote to the devices in {s} s")
            }
        }
    }
}

impl std::error::Error for HilError {}

/// A device error saying what was being done.
pub(crate) fn device(what: impl std::fmt::Display) -> impl FnOnce(std::io::Error) -> HilError {
    move |error| HilError::Device {
        what: what.to_string(),
        error,
    }
}

/// `SCHED_FIFO` priority of the HILSim's own loop where the machine allows: above the
/// flight computer's (`heli_vehicle::rt::LOOP_PRIORITY`), as the world it stands for runs on
/// its own time and the thesis's HILSim on its own computer. A HILSim starved by other work
/// on a shared machine would write its devices late, and the flight computer would be
/// blamed for the world's delay.
pub const HILSIM_PRIORITY: u8 = 85;

/// A device write this late is said on standard error (`hilsim: behind: ...`), at most once
/// every [`BEHIND_EVERY`]: the world, not the flight computer, was late.
pub const BEHIND: Duration = Duration::from_millis(5);

/// A device write this late is a starved stretch of the run ([`Starved`]): the IMU's
/// silence limit on the flight computer (`heli_fsw::health::timing_us`), past which the
/// vehicle sees its IMU stop.
pub const STARVED: Duration = Duration::from_millis(100);

/// Most starved stretches a summary keeps (a machine starved more often than this is said
/// by the first ones).
pub const STARVED_KEPT: usize = 50;

/// Writes starved within this much simulated time of the last are one stretch.
const STARVED_JOIN_S: f64 = 1.0;

/// Adds a write that left `late` after its due time `t_s` to the starved stretches.
fn note_starved(starved: &mut Vec<Starved>, t_s: f64, late: Duration) {
    if late <= STARVED {
        return;
    }
    let late_ms = late.as_secs_f64() * 1e3;
    if let Some(last) = starved.last_mut()
        && t_s - last.to_s <= STARVED_JOIN_S
    {
        last.to_s = t_s;
        last.late_ms = last.late_ms.max(late_ms);
    } else if starved.len() < STARVED_KEPT {
        starved.push(Starved {
            from_s: t_s,
            to_s: t_s,
            late_ms,
        });
    }
}

/// Least time between two `hilsim: behind` lines.
pub const BEHIND_EVERY: Duration = Duration::from_secs(1);

/// Fastest run whose loop takes `SCHED_FIFO`: at these speeds it sleeps most of the time;
/// faster, it computes without pause, and under `SCHED_FIFO` would take a whole core from
/// everything else.
pub const REALTIME_UP_TO_SPEED: f64 = 10.0;

/// The flight computer's reaction time as the HILSim sees it: from the write of an IMU
/// packet to the first whole servo packet read back after it.
struct Latency {
    /// When IMU packets were written (the write call began), newest last (a few kept).
    imu_writes: std::collections::VecDeque<Instant>,
    framer: heli_proto::scb::ServoFramer,
    samples_us: Vec<f64>,
    servo_packets: u64,
    /// Every write and read on `CLOCK_MONOTONIC`, if asked for.
    stamps: Option<HilStamps>,
}

impl Latency {
    fn new(stamps: bool) -> Self {
        Self {
            imu_writes: std::collections::VecDeque::new(),
            framer: heli_proto::scb::ServoFramer::default(),
            samples_us: Vec::new(),
            servo_packets: 0,
            stamps: stamps.then(HilStamps::default),
        }
    }

    fn imu_written(&mut self, at: Instant) {
        if self.imu_writes.len() >= 16 {
            self.imu_writes.pop_front();
        }
        self.imu_writes.push_back(at);
        if let Some(s) = self.stamps.as_mut() {
            s.imu_written_ns.push(heli_vehicle::rt::mono_ns_at(at));
        }
    }

    fn servo_bytes(&mut self, bytes: &[u8], read_at: Instant) {
        for &b in bytes {
            if self.framer.push(b).is_some() {
                self.servo_packets += 1;
                if let Some(s) = self.stamps.as_mut() {
                    s.servo_read_ns.push(heli_vehicle::rt::mono_ns_at(read_at));
                }
                // The newest IMU packet written before the read is what the command answers.
                if let Some(imu) = self.imu_writes.iter().rev().find(|t| **t <= read_at) {
                    self.samples_us
                        .push(read_at.duration_since(*imu).as_secs_f64() * 1e6);
                }
            }
        }
    }
}

/// What the HILSim exposes.
#[derive(Clone, Debug)]
pub struct HilDevices {
    /// The directory.
    pub dir: PathBuf,
    /// Each serial port's symlink and the terminal it points to.
    pub ports: Vec<(Port, PathBuf, PathBuf)>,
    /// The IIO-style ADC directory.
    pub adc: PathBuf,
    /// The hot-swap's digital input, as a GPIO line's value file (`1` on the flight
    /// batteries, `0` on the ground battery): `heli vehicle --hotswap PATH` reads it.
    pub hotswap: PathBuf,
}

/// How to run.
#[derive(Clone, Copy, Debug)]
pub struct HilOptions {
    /// Simulated seconds per wall-clock second.
    pub speed: f64,
    /// Stop after this many simulated seconds (default: the scenario's duration).
    pub duration_s: Option<f64>,
    /// Keep every IMU write's and servo read's time ([`HilSummary::stamps`]) for a
    /// stage-by-stage latency (`heli bench --hil`); 12 bytes per control period.
    pub stamps: bool,
    /// Pin the HILSim's loop and readers to this CPU (one the network's interrupts are kept
    /// off), if any.
    pub cpu: Option<usize>,
}

pub(crate) struct PtyPort {
    pub(crate) port: Port,
    pub(crate) master: TTYPort,
    /// Held open so the terminal exists (and reads on the master never fail) while no
    /// flight computer has it open.
    _slave: TTYPort,
    /// The directory's lock ([`hold_directory`]), held while any terminal is.
    _lock: Arc<std::fs::File>,
}

/// The lock file of a `--ptys` directory: one HILSim per directory.
pub const LOCK_FILE: &str = ".hilsim.lock";

/// Locks `dir` for this HILSim ([`LOCK_FILE`], with its process id): a second HILSim on the
/// same directory would point the device links at its own terminals under the first one's
/// flight computer, and leave them dangling when it ends. It is refused, naming the holder.
fn hold_directory(dir: &Path) -> Result<std::fs::File, HilError> {
    use std::io::Write;
    let path = dir.join(LOCK_FILE);
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .read(true)
        .write(true)
        .open(&path)
        .map_err(device(path.display()))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let pid = std::fs::read_to_string(&path).unwrap_or_default();
            return Err(device(format!("--ptys {}", dir.display()))(
                std::io::Error::other(format!(
                    "in use by another heli hilsim (process {}): stop it, or give another directory",
                    pid.trim()
                )),
            ));
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(device(path.display())(e)),
    }
    file.set_len(0)
        .and_then(|()| writeln!(file, "{}", std::process::id()))
        .map_err(device(path.display()))?;
    Ok(file)
}

/// Creates the pseudo-terminals and the ADC directory under `dir`.
pub(crate) fn expose(dir: &Path) -> Result<(Vec<PtyPort>, HilDevices), HilError> {
    if dir.exists() && !dir.is_dir() {
        return Err(device(format!("--ptys {}", dir.display()))(
            std::io::Error::other("not a directory: give a directory for the devices' links"),
        ));
    }
    std::fs::create_dir_all(dir).map_err(device(format!("--ptys {}", dir.display())))?;
    let lock = Arc::new(hold_directory(dir)?);
    let adc = dir.join("adc");
    std::fs::create_dir_all(&adc).map_err(device(adc.display()))?;
    let mut ptys = Vec::new();
    let mut listed = Vec::new();
    for port in Port::ALL {
        let (mut master, slave) = TTYPort::pair()
            .map_err(std::io::Error::from)
            .map_err(device("creating a pseudo-terminal"))?;
        master
            .set_timeout(Duration::from_millis(1))
            .map_err(std::io::Error::from)
            .map_err(device("setting a pseudo-terminal's timeout"))?;
        let target = slave.name().map(PathBuf::from).ok_or_else(|| {
            device("naming a pseudo-terminal")(std::io::Error::other("it has no name"))
        })?;
        let link = dir.join(port.name());
        if link.symlink_metadata().is_ok() {
            std::fs::remove_file(&link).map_err(device(link.display()))?;
        }
        std::os::unix::fs::symlink(&target, &link).map_err(device(link.display()))?;
        listed.push((port, link, target));
        ptys.push(PtyPort {
            port,
            master,
            _slave: slave,
            _lock: Arc::clone(&lock),
        });
    }
    Ok((
        ptys,
        HilDevices {
            dir: dir.to_path_buf(),
            ports: listed,
            adc,
            hotswap: dir.join("hotswap"),
        },
    ))
}

/// Writes the hot-swap line's value file atomically.
pub(crate) fn write_line(path: &Path, high: bool) -> std::io::Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, if high { "1\n" } else { "0\n" })?;
    std::fs::rename(&tmp, path)
}

/// Writes an ADC channel file atomically (a temporary file renamed over the old one).
pub(crate) fn write_adc(dir: &Path, channel: u8, counts: u16) -> std::io::Result<()> {
    let path = dir.join(format!("in_voltage{channel}_raw"));
    let tmp = dir.join(format!(".in_voltage{channel}_raw.tmp"));
    std::fs::write(&tmp, format!("{counts}\n"))?;
    std::fs::rename(&tmp, &path)
}

/// Reads what the flight computer writes on the ports that take commands.
pub(crate) fn spawn_readers(
    ptys: &[PtyPort],
    stop: &Arc<AtomicBool>,
    cpu: Option<usize>,
) -> Result<Receiver<(Port, Vec<u8>, Instant)>, HilError> {
    let (tx, rx) = channel();
    for pty in ptys
        .iter()
        .filter(|p| matches!(p.port, Port::Scb | Port::Baro))
    {
        let mut master = pty
            .master
            .try_clone_native()
            .map_err(std::io::Error::from)
            .map_err(device("opening a pseudo-terminal again"))?;
        master
            .set_timeout(Duration::from_millis(20))
            .map_err(std::io::Error::from)
            .map_err(device("setting a pseudo-terminal's timeout"))?;
        let tx = tx.clone();
        let stop = Arc::clone(stop);
        let port = pty.port;
        std::thread::Builder::new()
            .name(format!("hil-{}", port.name()))
            .spawn(move || {
                // The reader answers at once, as the board's UART would: under SCHED_FIFO
                // where the machine allows (a HILSim's own wake-up is not the flight
                // computer's latency); the normal scheduler otherwise.
                let _ = heli_vehicle::rt::realtime_thread(heli_vehicle::rt::DRIVER_PRIORITY);
                if let Some(cpu) = cpu {
                    let _ = heli_vehicle::rt::pin_to_cpu(cpu);
                }
                let mut buf = [0u8; 256];
                while !stop.load(Ordering::Acquire) {
                    match master.read(&mut buf) {
                        Ok(n) if n > 0 => {
                            let read_at = Instant::now();
                            if tx.send((port, buf[..n].to_vec(), read_at)).is_err() {
                                return;
                            }
                        }
                        Ok(_) => {}
                        // Nothing came within the timeout: read again at once (a sleep
                        // here would hold a packet arriving during it: it held 1 % of
                        // the servo packets 5 ms).
                        Err(e)
                            if matches!(
                                e.kind(),
                                std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                            ) => {}
                        // The terminal failed (EIO while no one has it open): wait.
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            })
            .map_err(device("starting a reader thread"))?;
    }
    Ok(rx)
}

/// Runs the scenario's helicopter against a flight computer on the devices under `dir`,
/// until the duration is reached, it crashes, or `stop` is set. `ready` is called once the
/// devices exist, `watch` after every step of the simulation (a view of the truth, and the
/// place a live pilot's sticks and a trainer's failures come in).
pub fn run(
    scenario: Scenario,
    dir: &Path,
    options: HilOptions,
    stop: &Arc<AtomicBool>,
    ready: impl FnOnce(&HilDevices),
    mut watch: impl FnMut(&mut Simulation),
) -> Result<Summary, HilError> {
    if !(options.speed.is_finite() && options.speed > 0.0 && options.speed <= 100.0) {
        return Err(HilError::Speed(options.speed));
    }
    let duration_s = options.duration_s.unwrap_or(scenario.duration_s);
    let mut sim = Simulation::hil(scenario).map_err(HilError::Scenario)?;
    if options.speed <= REALTIME_UP_TO_SPEED {
        // The world does not wait: refused without privileges (the normal scheduler then).
        let _ = heli_vehicle::rt::realtime_thread(HILSIM_PRIORITY);
    }
    if let Some(cpu) = options.cpu {
        // Asked for: said, pinned or refused (a CPU the machine has not), as the vehicle's
        // note on its own pinning.
        eprintln!(
            "hilsim: loop and device readers {}",
            heli_vehicle::rt::pin_to_cpu(cpu)
        );
    }
    let (mut ptys, devices) = expose(dir)?;
    let from_computer = spawn_readers(&ptys, stop, options.cpu)?;
    // The ADC files exist before anyone looks.
    for channel in 0..=crate::lockstep::HIL_BATTERY_CHANNEL {
        write_adc(&devices.adc, channel, 0).map_err(device("writing an ADC file"))?;
    }
    ready(&devices);
    let end_us = (duration_s * 1e6) as u64;
    let wall_start = Instant::now();
    let mut dropped = 0u64;
    let mut latency = Latency::new(options.stamps);
    let (mut write_late_max, mut writes_late) = (Duration::ZERO, 0u64);
    let mut said_behind: Option<Instant> = None;
    let mut starved = Vec::new();
    loop {
        if stop.load(Ordering::Acquire) {
            break;
        }
        while let Ok((port, bytes, read_at)) = from_computer.try_recv() {
            if port == Port::Scb {
                latency.servo_bytes(&bytes, read_at);
            }
            sim.inject(port, &bytes);
        }
        if !sim.advance(end_us) {
            let truth = sim.truth_frame();
            if sim.crash().is_none() && truth.contact_points == 0 {
                // The world ends under a flying helicopter: its computer loses every device.
                eprintln!(
                    "hilsim: the run's {duration_s} s are up with the helicopter in the air ({:.1} m up): its flight computer loses its devices now (--duration for a longer run)",
                    -truth.pos_ned_m[2]
                );
            }
            break;
        }
        watch(&mut sim);
        let wall_of =
            |t_us: u64| wall_start + Duration::from_secs_f64(t_us as f64 * 1e-6 / options.speed);
        // Each transmission leaves when its last byte would have reached the computer.
        for (t_us, out) in sim.take_outbox() {
            if let Some(wait) = wall_of(t_us).checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            let late = Instant::now().saturating_duration_since(wall_of(t_us));
            write_late_max = write_late_max.max(late);
            if late > Duration::from_millis(1) {
                writes_late += 1;
            }
            note_starved(&mut starved, t_us as f64 * 1e-6, late);
            // Said at most once a second, but a starved write (past [`STARVED`]) always
            // (the first of a catching-up burst: the latest).
            let starved_again =
                late > STARVED && said_behind.is_none_or(|at: Instant| at.elapsed() >= STARVED);
            if late > BEHIND
                && (starved_again
                    || said_behind.is_none_or(|at: Instant| at.elapsed() >= BEHIND_EVERY))
            {
                said_behind = Some(Instant::now());
                eprintln!(
                    "hilsim: behind: a device write left {:.1} ms late at t={:.2} s (the simulator was starved: the flight computer saw the world late)",
                    late.as_secs_f64() * 1e3,
                    t_us as f64 * 1e-6
                );
            }
            match out {
                HilOut::Bytes(port, bytes) => {
                    if let Some(pty) = ptys.iter_mut().find(|p| p.port == port) {
                        // Stamped as the write begins: the flight computer's driver may
                        // read the bytes before the write call has returned here.
                        let begun = Instant::now();
                        if pty.master.write_all(bytes.as_slice()).is_err() {
                            dropped += 1;
                        } else if port == Port::Imu {
                            latency.imu_written(begun);
                        }
                    }
                }
                HilOut::Adc { channel, counts } => {
                    let _ = write_adc(&devices.adc, channel, counts);
                }
                HilOut::PowerLine(high) => {
                    let _ = write_line(&devices.hotswap, high);
                }
            }
        }
        if let Some(wait) = wall_of(sim.now_us()).checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
    }
    let mut summary = sim.finish(wall_start.elapsed().as_secs_f64());
    summary.hil = Some(HilSummary {
        servo_packets: latency.servo_packets,
        latency_us: Percentiles::of(&mut latency.samples_us),
        dropped_writes: dropped,
        write_late_max_us: write_late_max.as_secs_f64() * 1e6,
        writes_late_over_1ms: writes_late,
        starved,
        stamps: latency.stamps.take(),
    });
    if dropped > 0 {
        summary.events.push(format!(
            "{dropped} device writes found no reader and were dropped"
        ));
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_hilsim_per_directory_and_a_file_is_no_directory() {
        let dir = tempfile::tempdir().unwrap();
        let ptys = dir.path().join("dev");
        let first = expose(&ptys).unwrap();
        let why = expose(&ptys).map(|_| ()).unwrap_err().to_string();
        assert!(
            why.contains("in use by another heli hilsim")
                && why.contains(&std::process::id().to_string()),
            "{why}"
        );
        // The first one's links are left as they were.
        let imu = std::fs::read_link(ptys.join("imu")).unwrap();
        assert_eq!(imu, first.1.ports[0].2);
        drop(first);
        expose(&ptys).unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, b"x").unwrap();
        let why = expose(&file).map(|_| ()).unwrap_err().to_string();
        assert!(why.contains("not a directory"), "{why}");
    }

    #[test]
    fn writes_starved_past_the_imu_silence_limit_make_stretches() {
        let mut starved = Vec::new();
        note_starved(&mut starved, 1.0, Duration::from_millis(100));
        assert!(starved.is_empty(), "at the limit is not starved");
        note_starved(&mut starved, 2.0, Duration::from_millis(250));
        note_starved(&mut starved, 2.5, Duration::from_millis(500));
        note_starved(&mut starved, 2.6, Duration::from_millis(101));
        note_starved(&mut starved, 4.0, Duration::from_millis(125));
        assert_eq!(
            starved,
            [
                Starved {
                    from_s: 2.0,
                    to_s: 2.6,
                    late_ms: 500.0
                },
                Starved {
                    from_s: 4.0,
                    to_s: 4.0,
                    late_ms: 125.0
                }
            ]
        );
        for k in 0..2 * STARVED_KEPT {
            note_starved(&mut starved, 10.0 + 2.0 * k as f64, STARVED * 2);
        }
        assert_eq!(starved.len(), STARVED_KEPT, "kept to a bound");
    }
}
