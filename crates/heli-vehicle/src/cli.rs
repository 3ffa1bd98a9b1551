//! The onboard program's command line, shared by the `heli-vehicle` binary and the
//! workstation's `heli vehicle` / `heli flight` / `heli driver`: the bootstrap, its control
//! client, the flight process and the stand-alone drivers.

use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use heli_proto::compass::CompassCalibration;

use crate::bootstrap::{Bootstrap, BootstrapConfig, Said};
use crate::ctl::{self, Request};
use crate::devices::Devices;
use crate::standalone::{self, DriverKind, Source};

/// Where the devices are and how the flight software is set up: shared by the bootstrap
/// (which passes them on) and the flight process.
#[derive(clap::Args, Clone, Debug)]
pub struct FlightArgs {
    /// Device paths and ADC channels (TOML; see docs/architecture.md).
    #[arg(long, conflicts_with = "hilsim")]
    pub devices: Option<PathBuf>,
    /// Fly against `heli hilsim --ptys DIR`: its pseudo-terminals, ADC files and compass
    /// calibration.
    #[arg(long)]
    pub hilsim: Option<PathBuf>,
    /// Directory for the flight logs (`flight_<suffix>.mcap`).
    #[arg(long, default_value = ".")]
    pub log_dir: PathBuf,
    /// Where the log and a second warm-start record go when the log directory refuses
    /// them (full, read-only): a RAM-backed directory. Default `/dev/shm` where there is one;
    /// `--fallback-dir none` for no fallback.
    #[arg(long)]
    pub fallback_dir: Option<PathBuf>,
    /// The lab's plan directory: a plan name that is no library plan flies `DIR/NAME.toml`
    /// (docs/scenarios.md). Plans are asked for by name only, never by path.
    #[arg(long)]
    pub plans_dir: Option<PathBuf>,
    /// Compass calibration (TOML: bias_gauss = [x, y, z], scale = [x, y, z]).
    #[arg(long)]
    pub compass_cal: Option<PathBuf>,
    /// Altimeter readings per second (1-10).
    #[arg(long, default_value_t = heli_proto::baro::DEFAULT_RATE_HZ)]
    pub baro_rate: u8,
    /// IMU bias calibration window (s). 80 as in the thesis; shorter only for tests.
    #[arg(long, default_value_t = 80.0)]
    pub calibration_s: f64,
    /// IMU warm-up before the calibration (s). Shorter only for tests.
    #[arg(long, default_value_t = 5.0)]
    pub warm_up_s: f64,
    /// Run the flight clock this many times as fast as the wall clock, to fly against
    /// `heli hilsim --speed` above 1. Never on a vehicle.
    #[arg(long, default_value_t = 1.0)]
    pub clock_speed: f64,
    /// The signing key file (heli link keygen): signs the link's frames and checks the
    /// lab's attestation; without one the link is unauthenticated and nothing is
    /// lab-tested.
    #[arg(long, env = "HELI_LINK_KEY")]
    pub key: Option<PathBuf>,
    /// The lab's attestation of the build and parameters (heli certify) [default:
    /// LOG_DIR/attestation.json].
    #[arg(long)]
    pub attestation: Option<PathBuf>,
    /// A lab bench's standing override: augmented and autonomous flights on a configuration
    /// that is not lab-tested fly without the operator's per-flight override (each is still
    /// said and logged as flown untested). Never on a vehicle in the field.
    #[arg(long)]
    pub fly_untested: bool,
    /// Fly without the real-time settings (memory locking, `SCHED_FIFO`, CPUs kept awake),
    /// as an unprivileged process would: to measure what they buy, or to share a
    /// workstation. A vehicle flies with them.
    #[arg(long)]
    pub no_realtime: bool,
    /// Pin the real-time threads (the control loop and the device drivers) to this CPU, one
    /// the network's interrupts are kept off (a flood of the link then costs the flight
    /// nothing). Default: wherever the scheduler puts them.
    #[arg(long, value_name = "CPU")]
    pub rt_cpu: Option<usize>,
    /// Write each servo command's stage-by-stage latency (CSV, `CLOCK_MONOTONIC` ns) to this
    /// file when the flight process ends: `heli bench --hil` reads it.
    #[arg(long)]
    pub latency_trace: Option<PathBuf>,
}

impl FlightArgs {
    /// The lab check of these settings (`crate::lab`): `--attestation` (default
    /// `<log-dir>/attestation.json`), `--key`, `--fly-untested`.
    pub fn lab(&self) -> Result<crate::lab::Lab> {
        let key = heli_link::setup::load_key(self.key.as_deref())?;
        Ok(crate::lab::Lab {
            check: heli_link::attest::LabCheck {
                attestation: self.attestation_path(),
                key,
            },
            fly_untested: self.fly_untested,
        })
    }

    /// The attestation file of these settings.
    pub fn attestation_path(&self) -> PathBuf {
        self.attestation
            .clone()
            .unwrap_or_else(|| self.log_dir.join(heli_link::attest::FILE_NAME))
    }

    /// Where the devices are.
    pub fn devices(&self) -> Result<Devices> {
        match (&self.devices, &self.hilsim) {
            (Some(file), _) => Ok(Devices::from_file(file)?),
            (None, Some(dir)) => Ok(Devices::hilsim(dir)),
            (None, None) => bail!("say where the devices are: --devices FILE or --hilsim DIR"),
        }
    }

    /// Checks every value is in its range and the log directory is one.
    pub fn validate(&self) -> Result<()> {
        if !(1..=10).contains(&self.baro_rate) {
            bail!(
                "--baro-rate {}: the altimeter does 1 to 10 readings a second",
                self.baro_rate
            );
        }
        for (name, v) in [
            ("--calibration-s", self.calibration_s),
            ("--warm-up-s", self.warm_up_s),
        ] {
            if !(v.is_finite() && (0.0..=600.0).contains(&v)) {
                bail!("{name} {v}: must be between 0 and 600 seconds");
            }
        }
        if !(self.clock_speed.is_finite() && self.clock_speed > 0.0 && self.clock_speed <= 100.0) {
            bail!(
                "--clock-speed {}: must be more than 0 and at most 100",
                self.clock_speed
            );
        }
        if !self.log_dir.is_dir() {
            bail!("--log-dir {}: not a directory", self.log_dir.display());
        }
        Ok(())
    }

    /// The fallback directory: the one given (`none`: none), else `/dev/shm` where it is a
    /// directory.
    /// Under `/dev/shm` each log directory has its own (`heli-<hash of its path>`), so that
    /// vehicles sharing a computer (tests, a bench) never read each other's records.
    pub fn fallback_dir(&self) -> Option<PathBuf> {
        match &self.fallback_dir {
            Some(dir) if dir.as_os_str() == "none" => None,
            Some(dir) => Some(dir.clone()),
            None => {
                let shm = PathBuf::from("/dev/shm");
                let log_dir = std::fs::canonicalize(&self.log_dir).unwrap_or(self.log_dir.clone());
                // FNV-1a: stable across runs and builds, unlike std's hasher.
                let hash = log_dir
                    .as_os_str()
                    .as_encoded_bytes()
                    .iter()
                    .fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
                        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
                    });
                shm.is_dir().then(|| shm.join(format!("heli-{hash:016x}")))
            }
        }
    }

    /// The compass calibration: the file given, the HILSim's, or none (identity).
    pub fn compass(&self) -> Result<CompassCalibration> {
        let hil_file = self
            .hilsim
            .as_ref()
            .map(|dir| dir.join(crate::compass_file::HIL_FILE_NAME));
        let path = match (&self.compass_cal, hil_file) {
            (Some(p), _) => p.clone(),
            (None, Some(p)) if p.exists() => p,
            _ => return Ok(CompassCalibration::default()),
        };
        Ok(crate::compass_file::read(&path)?)
    }

    /// The same settings as arguments, for the flight process's command line.
    pub fn to_args(&self) -> Vec<OsString> {
        let mut args: Vec<OsString> = Vec::new();
        if let Some(d) = &self.devices {
            args.extend(["--devices".into(), d.clone().into_os_string()]);
        }
        if let Some(d) = &self.hilsim {
            args.extend(["--hilsim".into(), d.clone().into_os_string()]);
        }
        if let Some(c) = &self.compass_cal {
            args.extend(["--compass-cal".into(), c.clone().into_os_string()]);
        }
        if let Some(d) = &self.fallback_dir {
            args.extend(["--fallback-dir".into(), d.clone().into_os_string()]);
        }
        if let Some(d) = &self.plans_dir {
            args.extend(["--plans-dir".into(), d.clone().into_os_string()]);
        }
        if let Some(k) = &self.key {
            args.extend(["--key".into(), k.clone().into_os_string()]);
        }
        if let Some(a) = &self.attestation {
            args.extend(["--attestation".into(), a.clone().into_os_string()]);
        }
        if self.fly_untested {
            args.push("--fly-untested".into());
        }
        if self.no_realtime {
            args.push("--no-realtime".into());
        }
        if let Some(cpu) = self.rt_cpu {
            args.extend(["--rt-cpu".into(), cpu.to_string().into()]);
        }
        if let Some(t) = &self.latency_trace {
            args.extend(["--latency-trace".into(), t.clone().into_os_string()]);
        }
        args.extend([
            "--log-dir".into(),
            self.log_dir.clone().into_os_string(),
            "--baro-rate".into(),
            self.baro_rate.to_string().into(),
            "--calibration-s".into(),
            self.calibration_s.to_string().into(),
            "--warm-up-s".into(),
            self.warm_up_s.to_string().into(),
            "--clock-speed".into(),
            self.clock_speed.to_string().into(),
        ]);
        args
    }
}

/// The flight process's own command line: the bootstrap's flight settings and where a
/// bootstrap started again finds it (`crate::adopt`).
#[derive(clap::Args, Clone, Debug)]
pub struct FlightProcessArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub flight: FlightArgs,
    /// The adoption socket to listen on (the bootstrap gives `<control socket>.flight`).
    #[arg(long)]
    pub adopt_socket: Option<PathBuf>,
}

/// The bootstrap's settings: the flight process's, its control socket and its link.
#[derive(clap::Args, Clone, Debug)]
pub struct BootstrapArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub flight: FlightArgs,
    /// The bootstrap's control socket.
    #[arg(long, global = true, env = "HELI_VEHICLE_SOCKET", default_value_os_t = crate::control_socket::default_path())]
    pub socket: PathBuf,
    /// Serve the MAVLink 2 link on this address (udp:HOST:PORT; e.g. udp:0.0.0.0:14550).
    #[arg(long)]
    pub link: Option<String>,
}

/// The bootstrap's own subcommand: one command to a running bootstrap.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum BootstrapCommand {
    /// Send the bootstrap one command: connect, start-logging SUFFIX MODE [PLAN]
    /// [override-untested], stop, kill confirmed, status, quit.
    Ctl {
        /// The command and its arguments.
        #[arg(required = true, num_args = 1..)]
        command: Vec<String>,
    },
}

/// The bootstrap, or with a subcommand one command to a running one.
pub fn vehicle(args: &BootstrapArgs, command: Option<&BootstrapCommand>) -> Result<ExitCode> {
    match command {
        Some(BootstrapCommand::Ctl { command }) => ctl(command, &args.socket),
        None => bootstrap(args),
    }
}

/// Prints a line at once (the bootstrap's output is read line by line).
fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// The bootstrap, serving the MAVLink link too with `--link`. It starts this same program as
/// the flight process (`<program> flight …`).
pub fn bootstrap(args: &BootstrapArgs) -> Result<ExitCode> {
    let flight = &args.flight;
    flight.validate()?;
    // Fail now, not at the first Connect, on a devices file that cannot be used.
    flight.devices()?;
    flight.compass()?;
    let link_addr = args
        .link
        .as_deref()
        .map(heli_link::setup::parse_address)
        .transpose()?;
    let key = heli_link::setup::load_key(flight.key.as_deref())?;
    let exe =
        std::env::current_exe().context("finding this program, to start the flight process")?;
    let adopt_socket = crate::adopt::socket_for(&args.socket);
    let exe_for_lab = exe.clone();
    let mut child = vec![exe.into_os_string(), "flight".into()];
    child.extend(flight.to_args());
    child.extend([
        "--adopt-socket".into(),
        adopt_socket.clone().into_os_string(),
    ]);
    let config = BootstrapConfig {
        socket: args.socket.clone(),
        child,
        warm_files: std::iter::once(crate::warm::path_in(&flight.log_dir))
            .chain(flight.fallback_dir().as_deref().map(crate::warm::path_in))
            .collect(),
        adopt_socket: Some(adopt_socket),
    };
    let shared = Arc::new(crate::link::LinkShared::default());
    let to_link = Arc::clone(&shared);
    let serving = link_addr.is_some();
    let report = Box::new(move |said: &Said| {
        say(&said.to_string());
        if serving {
            to_link.said(said);
        }
    });
    let lab = flight.lab()?;
    let mut bootstrap = Bootstrap::new(config, report).with_lab(
        crate::bootstrap::LabStatement::new(lab, &exe_for_lab, flight.log_dir.clone()),
    );
    let stop = Arc::new(AtomicBool::new(false));
    if let Some(addr) = link_addr {
        bootstrap = bootstrap.with_link(Arc::clone(&shared) as Arc<dyn crate::bootstrap::LinkPort>);
        let say_shared = Arc::clone(&shared);
        let to_ground = Arc::new(move |said: &Said| {
            say(&said.to_string());
            say_shared.said(said);
        });
        crate::link::spawn(
            addr,
            key,
            (flight.log_dir.clone(), flight.fallback_dir()),
            shared,
            bootstrap.requests(),
            to_ground,
            Arc::clone(&stop),
        )
        .with_context(|| format!("serving the link on udp {addr}"))?;
    }
    let result = bootstrap.run().map_err(anyhow::Error::msg);
    stop.store(true, Ordering::Release);
    result?;
    Ok(ExitCode::SUCCESS)
}

/// One command to the bootstrap on `socket`; its reply is printed.
pub fn ctl(words: &[String], socket: &Path) -> Result<ExitCode> {
    let request = Request::parse(&words.join(" "))?;
    match ctl::send(socket, &request) {
        Ok(reply) => {
            println!("{reply}");
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            eprintln!("heli vehicle: {e}");
            Ok(ExitCode::FAILURE)
        }
    }
}

/// Arguments of a stand-alone driver.
#[derive(clap::Args, Clone, Debug)]
pub struct DriverArgs {
    /// The device.
    #[arg(value_enum)]
    pub device: DriverKind,
    /// Serial port of the device (imu, scb, gps, baro).
    #[arg(long)]
    pub port: Option<PathBuf>,
    /// IIO directory of the ADC (compass, battery).
    #[arg(long)]
    pub adc: Option<PathBuf>,
    /// ADC channels: three for the compass (default 0,1,2), one for the battery (default 3).
    #[arg(long, value_delimiter = ',')]
    pub channel: Vec<u8>,
    /// Write a flight log (MCAP) of what the driver read.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Altimeter readings per second (1-10).
    #[arg(long, default_value_t = heli_proto::baro::DEFAULT_RATE_HZ)]
    pub rate: u8,
    /// Stop after this many packets or readings.
    #[arg(long)]
    pub count: Option<u64>,
}

/// Runs one device's stand-alone driver until --count, an error, or SIGINT / SIGTERM.
pub fn driver(args: &DriverArgs) -> Result<ExitCode> {
    if !(1..=10).contains(&args.rate) {
        bail!(
            "--rate {}: the altimeter does 1 to 10 readings a second",
            args.rate
        );
    }
    let kind = args.device;
    let source = match (kind, &args.port, &args.adc) {
        (DriverKind::Compass | DriverKind::Battery, _, Some(dir)) => Source::Adc {
            dir: dir.clone(),
            channels: match (kind, args.channel.is_empty()) {
                (DriverKind::Compass, true) => vec![0, 1, 2],
                (_, true) => vec![3],
                (_, false) => args.channel.clone(),
            },
        },
        (DriverKind::Compass | DriverKind::Battery, Some(port), None) => Source::Port(port.clone()),
        (DriverKind::Compass | DriverKind::Battery, None, None) => {
            bail!("give the ADC's IIO directory: --adc DIR")
        }
        (_, Some(port), _) => Source::Port(port.clone()),
        (_, None, _) => bail!("give the device's serial port: --port PATH"),
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing the signal handler")?;
    }
    let mut print = |line: &str| println!("{line}");
    let report = standalone::run(
        kind,
        &source,
        args.log.as_deref(),
        args.rate,
        args.count,
        &stop,
        &mut print,
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!(
        "heli driver: {} samples, {} watchdog misses, {} bytes discarded, {} servo packets, {} log messages",
        report.samples,
        report.watchdog_misses,
        report.discarded_bytes,
        report.servo_packets,
        report.log_messages
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    #[derive(clap::Parser)]
    struct LabArgs {
        #[command(flatten)]
        flight: super::FlightArgs,
    }

    #[test]
    fn the_attestation_is_in_the_log_directory_unless_named() {
        use clap::Parser;
        use std::path::Path;
        let args = LabArgs::parse_from(["t", "--log-dir", "/logs"]);
        assert_eq!(
            args.flight.attestation_path(),
            Path::new("/logs/attestation.json")
        );
        let args = LabArgs::parse_from(["t", "--log-dir", "/logs", "--attestation", "/lab/a.json"]);
        assert_eq!(args.flight.attestation_path(), Path::new("/lab/a.json"));
        assert!(!args.flight.fly_untested);
        let lab = args.flight.lab().unwrap();
        assert_eq!(lab.check.attestation, Path::new("/lab/a.json"));
        assert!(lab.check.key.is_none());
    }

    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Line {
        #[command(flatten)]
        flight: FlightArgs,
    }

    fn args(words: &[&str]) -> FlightArgs {
        Line::try_parse_from(std::iter::once("heli-vehicle").chain(words.iter().copied()))
            .unwrap()
            .flight
    }

    #[test]
    fn the_compass_calibration_is_the_file_given_else_the_hilsims_else_none() {
        let dir = tempfile::tempdir().unwrap();
        let hil = dir.path().display().to_string();
        // A HILSim directory without a calibration: none (identity).
        assert_eq!(
            args(&["--hilsim", &hil]).compass().unwrap(),
            CompassCalibration::default()
        );
        let theirs = CompassCalibration {
            bias_gauss: [0.1, 0.2, 0.3],
            scale: [1.0, 1.0, 1.0],
        };
        crate::compass_file::write(
            &dir.path().join(crate::compass_file::HIL_FILE_NAME),
            &theirs,
        )
        .unwrap();
        assert_eq!(args(&["--hilsim", &hil]).compass().unwrap(), theirs);
        // A file given wins over the HILSim's.
        let mine = CompassCalibration {
            bias_gauss: [-0.1, 0.0, 0.0],
            scale: [1.2, 1.0, 0.8],
        };
        let path = dir.path().join("mine.toml");
        crate::compass_file::write(&path, &mine).unwrap();
        let given = args(&[
            "--hilsim",
            &hil,
            "--compass-cal",
            &path.display().to_string(),
        ]);
        assert_eq!(given.compass().unwrap(), mine);
    }

    #[test]
    fn the_fallback_directory_is_the_one_given_none_or_one_per_log_directory_in_ram() {
        assert_eq!(
            args(&["--fallback-dir", "/var/heli"]).fallback_dir(),
            Some(PathBuf::from("/var/heli"))
        );
        assert_eq!(args(&["--fallback-dir", "none"]).fallback_dir(), None);
        if Path::new("/dev/shm").is_dir() {
            let a = args(&["--log-dir", "/tmp"]).fallback_dir().unwrap();
            let b = args(&["--log-dir", "/var/tmp"]).fallback_dir().unwrap();
            assert!(a.starts_with("/dev/shm") && b.starts_with("/dev/shm"));
            assert_ne!(a, b, "each log directory its own");
            assert_eq!(
                args(&["--log-dir", "/tmp"]).fallback_dir().unwrap(),
                a,
                "stable"
            );
            // FNV-1a of the path, the same on every machine and build.
            assert_eq!(
                args(&["--log-dir", "/nonexistent/heli-logs"]).fallback_dir(),
                Some(PathBuf::from("/dev/shm/heli-43fe414f99b0fb82"))
            );
        }
    }

    #[test]
    fn the_flight_process_gets_the_bootstraps_settings_back_unchanged() {
        let given = args(&[
            "--devices",
            "/etc/heli/devices.toml",
            "--log-dir",
            "/tmp",
            "--compass-cal",
            "/etc/heli/compass.toml",
            "--fallback-dir",
            "/run/heli",
            "--baro-rate",
            "4",
            "--calibration-s",
            "12.5",
            "--warm-up-s",
            "2",
            "--clock-speed",
            "3",
            "--no-realtime",
            "--rt-cpu",
            "1",
            "--latency-trace",
            "/tmp/trace.csv",
            "--fly-untested",
        ]);
        let mut words = vec!["heli-vehicle".to_string()];
        words.extend(
            given
                .to_args()
                .iter()
                .map(|w| w.to_string_lossy().into_owned()),
        );
        let back = Line::try_parse_from(words).unwrap().flight;
        assert_eq!(format!("{back:?}"), format!("{given:?}"));
        let hil = args(&["--hilsim", "/tmp/dev"]);
        assert!(hil.to_args().contains(&OsString::from("--hilsim")));
    }

    /// The systemd unit shipped for the flight computer (`deploy/heli-vehicle.service`).
    const UNIT: &str = include_str!("../../../deploy/heli-vehicle.service");

    fn unit_value<'a>(key: &str) -> Vec<&'a str> {
        UNIT.lines()
            .filter_map(|l| l.trim().strip_prefix(key)?.strip_prefix('='))
            .collect()
    }

    #[test]
    fn the_systemd_unit_keeps_the_flight_process_through_a_bootstrap_restart() {
        // Only the bootstrap is killed on a restart; it is always restarted, without limit.
        assert_eq!(unit_value("KillMode"), ["process"]);
        assert_eq!(unit_value("Restart"), ["always"]);
        assert_eq!(unit_value("StartLimitIntervalSec"), ["0"]);
        // The sockets' directory outlives a restart.
        assert_eq!(unit_value("RuntimeDirectory"), ["heli"]);
        assert_eq!(unit_value("RuntimeDirectoryPreserve"), ["restart"]);
        // Its command line is one the bootstrap takes, with its socket in that directory.
        let exec = UNIT
            .split("ExecStart=")
            .nth(1)
            .and_then(|rest| rest.split("\n\n").next())
            .unwrap_or_default()
            .replace("\\\n", " ");
        let words: Vec<&str> = exec.split_whitespace().collect();
        assert_eq!(words.first(), Some(&"/usr/local/bin/heli-vehicle"));
        #[derive(Parser)]
        struct Boot {
            #[command(flatten)]
            boot: BootstrapArgs,
        }
        let parsed = Boot::try_parse_from(words.iter().take_while(|w| !w.contains('=')))
            .unwrap_or_else(|e| panic!("{exec}: {e}"));
        assert_eq!(parsed.boot.socket, PathBuf::from("/run/heli/vehicle.sock"));
        assert!(parsed.boot.flight.devices.is_some() && parsed.boot.link.is_some());
        assert_eq!(
            crate::adopt::socket_for(&parsed.boot.socket),
            PathBuf::from("/run/heli/vehicle.sock.flight")
        );
    }
}
