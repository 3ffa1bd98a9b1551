//! `heli vehicle` (the bootstrap), `heli vehicle ctl …` (its control client) and the flight
//! process the bootstrap starts (`heli flight`, not for people to run by hand).

use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use heli_fsw::core::mission::Plan;
use heli_fsw::core::{CoreConfig, FlightParams};
use heli_proto::compass::CompassCalibration;
use heli_vehicle::bootstrap::{Bootstrap, BootstrapConfig};
use heli_vehicle::ctl::{self, Request};
use heli_vehicle::devices::Devices;
use heli_vehicle::flight::{self, FlightSetup, Report};

/// The control socket when none is given.
pub const DEFAULT_SOCKET: &str = "/tmp/heli-vehicle.sock";
/// The compass calibration the HILSim leaves in its directory (the vehicle keeps its own in
/// flash; this is the simulated compass's).
pub const HIL_COMPASS_CAL: &str = "compass-cal.toml";

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
}

impl FlightArgs {
    fn devices(&self) -> Result<Devices> {
        match (&self.devices, &self.hilsim) {
            (Some(file), _) => Ok(Devices::from_file(file)?),
            (None, Some(dir)) => Ok(Devices::hilsim(dir)),
            (None, None) => bail!("say where the devices are: --devices FILE or --hilsim DIR"),
        }
    }

    fn validate(&self) -> Result<()> {
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

    fn compass(&self) -> Result<CompassCalibration> {
        let path = match (&self.compass_cal, &self.hilsim) {
            (Some(p), _) => p.clone(),
            (None, Some(dir)) if dir.join(HIL_COMPASS_CAL).exists() => dir.join(HIL_COMPASS_CAL),
            _ => return Ok(CompassCalibration::default()),
        };
        read_compass_cal(&path)
    }

    /// The same settings as arguments, for the flight process's command line.
    fn to_args(&self) -> Vec<OsString> {
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

/// Reads a compass calibration file.
pub fn read_compass_cal(path: &Path) -> Result<CompassCalibration> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Cal {
        bias_gauss: [f64; 3],
        scale: [f64; 3],
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("compass calibration {}", path.display()))?;
    let cal: Cal =
        toml::from_str(&text).with_context(|| format!("compass calibration {}", path.display()))?;
    if !cal
        .bias_gauss
        .iter()
        .chain(&cal.scale)
        .all(|v| v.is_finite())
    {
        bail!(
            "compass calibration {}: values must be finite",
            path.display()
        );
    }
    Ok(CompassCalibration {
        bias_gauss: cal.bias_gauss,
        scale: cal.scale,
    })
}

/// Writes a compass calibration file.
pub fn write_compass_cal(path: &Path, cal: &CompassCalibration) -> Result<()> {
    let text = format!(
        "# Compass calibration (hard-iron bias and scale), as stored in the vehicle's flash.\nbias_gauss = {:?}\nscale = {:?}\n",
        cal.bias_gauss, cal.scale
    );
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// `heli vehicle`: the bootstrap, serving the MAVLink link too with `link`.
pub fn vehicle(
    args: &FlightArgs,
    socket: &Path,
    link: Option<&str>,
    key: Option<&Path>,
) -> Result<ExitCode> {
    args.validate()?;
    // Fail now, not at the first Connect, on a devices file that cannot be used.
    args.devices()?;
    args.compass()?;
    let link_addr = link.map(crate::link_cmd::parse_link).transpose()?;
    let key = crate::link_cmd::load_key(key)?;
    let exe = std::env::current_exe().context("finding the heli program")?;
    let mut child = vec![exe.into_os_string(), "flight".into()];
    child.extend(args.to_args());
    let config = BootstrapConfig {
        socket: socket.to_path_buf(),
        child,
        warm_file: Some(heli_vehicle::warm::path_in(&args.log_dir)),
    };
    let shared = Arc::new(heli_vehicle::link::LinkShared::default());
    let print = |line: &str| {
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{line}");
        let _ = out.flush();
    };
    let to_link = Arc::clone(&shared);
    let serving = link_addr.is_some();
    let report = Box::new(move |line: &str| {
        print(line);
        if serving {
            to_link.line(line);
        }
    });
    let mut bootstrap = Bootstrap::new(config, report);
    let stop = Arc::new(AtomicBool::new(false));
    if let Some(addr) = link_addr {
        bootstrap = bootstrap.with_link(Arc::clone(&shared));
        let say_shared = Arc::clone(&shared);
        let say = Arc::new(move |line: &str| {
            print(line);
            say_shared.line(line);
        });
        heli_vehicle::link::spawn(
            addr,
            key,
            args.log_dir.clone(),
            shared,
            bootstrap.requests(),
            say,
            Arc::clone(&stop),
        )
        .with_context(|| format!("serving the link on udp {addr}"))?;
    }
    let result = bootstrap.run().map_err(anyhow::Error::msg);
    stop.store(true, Ordering::Release);
    result?;
    Ok(ExitCode::SUCCESS)
}

/// `heli vehicle ctl …`: one command to the bootstrap.
pub fn ctl(words: &[String], socket: &Path) -> Result<ExitCode> {
    let request = Request::parse(&words.join(" ")).map_err(anyhow::Error::msg)?;
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

/// One line of standard input (the stdin buffer is shared, so threads may take turns);
/// `None` at its end.
fn read_line() -> Option<String> {
    let mut line = String::new();
    match std::io::stdin().read_line(&mut line) {
        Ok(0) | Err(_) => None,
        Ok(_) => Some(line.trim_end().to_string()),
    }
}

fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// The flight plan named at Start Logging: a built-in scenario's plan, or a scenario file's.
/// Returns its name, its legs as JSON (recorded in the log, so a replay needs no file) and
/// the plan.
fn plan_named(name: Option<&str>) -> Result<(String, String, Plan)> {
    let name = name.unwrap_or("hover");
    let scenario = heli_sim::scenario::load(name).with_context(|| {
        format!("flight plan '{name}' (a built-in scenario or a scenario file)")
    })?;
    let legs_json = serde_json::to_string(&scenario.plan)?;
    let plan = plan_of(&scenario.plan).with_context(|| format!("flight plan '{name}'"))?;
    Ok((name.to_string(), legs_json, plan))
}

/// The flight software's plan of a scenario's legs.
pub fn plan_of(legs: &[heli_sim::scenario::LegSpec]) -> Result<Plan> {
    let legs: Vec<_> = legs.iter().map(|l| l.to_leg()).collect();
    Plan::new(&legs).map_err(|e| anyhow::anyhow!("{e}"))
}

/// Where the flight process's lines go: a printer thread, so that no flight thread (the
/// control loop least of all) ever waits on the pipe to the bootstrap. Lines that do not
/// fit are counted and the count said when there is room.
fn reporter() -> impl Fn(String) + Send + Sync + Clone {
    let (tx, rx) = std::sync::mpsc::sync_channel::<String>(4096);
    let dropped = Arc::new(std::sync::atomic::AtomicU64::new(0));
    {
        let dropped = Arc::clone(&dropped);
        std::thread::spawn(move || {
            for line in rx {
                let lost = dropped.swap(0, Ordering::AcqRel);
                if lost > 0 {
                    say(&format!(
                        "note {lost} report lines dropped (the bootstrap was not reading)"
                    ));
                }
                say(&line);
            }
        });
    }
    move |line: String| {
        if tx.try_send(line).is_err() {
            dropped.fetch_add(1, Ordering::AcqRel);
        }
    }
}

/// `heli flight`: the flight process. It says `ready`, waits for `start SUFFIX MODE [PLAN]`
/// on its standard input, flies until `stop` (or the end of its input), and says `stopped`.
pub fn flight_process(args: &FlightArgs) -> Result<ExitCode> {
    args.validate()?;
    let devices = args.devices()?;
    let compass = args.compass()?;
    say("ready");
    // What the bootstrap says of its link: 0 nothing (no link), 1 a ground heard, 2 none.
    let ground_link = Arc::new(std::sync::atomic::AtomicU8::new(0));
    let link_word = |words: &[&str]| match words {
        ["link", "fresh"] => Some(1),
        ["link", "lost"] => Some(2),
        _ => None,
    };
    let (restart, suffix, mode, plan_name) = loop {
        let Some(line) = read_line() else {
            say("stopped {}");
            return Ok(ExitCode::SUCCESS);
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [word @ ("start" | "restart"), suffix, mode, rest @ ..] if rest.len() <= 1 => {
                break (
                    *word == "restart",
                    suffix.to_string(),
                    mode.to_string(),
                    rest.first().map(|p| p.to_string()),
                );
            }
            ["stop"] => {
                say("stopped {}");
                return Ok(ExitCode::SUCCESS);
            }
            w if link_word(w).is_some() => {
                ground_link.store(link_word(w).unwrap_or(0), Ordering::Release);
            }
            _ => say(&format!("error not understood: '{line}'")),
        }
    };
    let start_words = match &plan_name {
        Some(plan) => format!("{suffix} {mode} {plan}"),
        None => format!("{suffix} {mode}"),
    };
    let started = heli_link::StartParameters::new(&suffix, &mode);
    let (mode, plan_name, plan_legs, plan) = match started
        .map_err(anyhow::Error::from)
        .and_then(|p| Ok((p.controller, plan_named(plan_name.as_deref())?)))
    {
        Ok((mode, (name, legs, plan))) => (mode, name, legs, plan),
        Err(e) => {
            say(&format!("error {e:#}"));
            bail!("{e:#}");
        }
    };
    // The plan's legs, for the bootstrap to serve over the link's mission protocol.
    say(&format!("plan {plan_legs}"));
    let warm_path = heli_vehicle::warm::path_in(&args.log_dir);
    // Started again by the bootstrap after a crash or a brown-out: resume from the record
    // the process before left, if it can be read (otherwise start cold, and say so).
    let restart_from = if restart {
        match heli_vehicle::warm::WarmFile::read(&warm_path) {
            Ok(Some(file)) => Some(file),
            Ok(None) => {
                say("note restarted without a warm-start record: calibrating from scratch");
                None
            }
            Err(e) => {
                say(&format!(
                    "note warm-start record unreadable ({e}): calibrating from scratch"
                ));
                None
            }
        }
    } else {
        None
    };
    let log_path = next_free_log(&args.log_dir, &suffix, restart);
    let mut config = CoreConfig {
        calibration_s: args.calibration_s,
        imu_warm_up_s: args.warm_up_s,
        compass,
        ..CoreConfig::default()
    };
    // The parameters set over the link: a file that cannot be used stops the start, with
    // its reason, rather than flying on values nobody chose.
    // With no file the flight software's own defaults are flown, exactly.
    let params = if heli_vehicle::params::path_in(&args.log_dir).exists() {
        let table = heli_vehicle::params::load(&args.log_dir).map_err(anyhow::Error::msg)?;
        heli_vehicle::params::apply(&table, &mut config);
        Some(table)
    } else {
        None
    };
    let baro_rate = params
        .as_ref()
        .and_then(heli_vehicle::params::baro_rate_hz)
        .unwrap_or(args.baro_rate);
    let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
    let parameters = [
        ("suffix".to_string(), suffix.clone()),
        ("mode".to_string(), mode.name().to_string()),
        ("plan".to_string(), plan_name),
        ("plan_legs_json".to_string(), plan_legs),
        ("calibration_s".to_string(), args.calibration_s.to_string()),
        ("warm_up_s".to_string(), args.warm_up_s.to_string()),
        ("baro_rate_hz".to_string(), baro_rate.to_string()),
        (
            "params".to_string(),
            params.as_ref().map(|t| t.to_text()).unwrap_or_default(),
        ),
        ("clock_speed".to_string(), args.clock_speed.to_string()),
        (
            "compass_bias_gauss".to_string(),
            format!("{:?}", compass.bias_gauss),
        ),
        ("compass_scale".to_string(), format!("{:?}", compass.scale)),
        ("devices".to_string(), format!("{devices:?}")),
        (
            "warm_start".to_string(),
            restart_from
                .as_ref()
                .map(|w| w.to_text())
                .unwrap_or_default(),
        ),
    ];
    let metadata = heli_log::metadata::flight(software, std::time::SystemTime::now(), parameters);
    let setup = FlightSetup {
        devices,
        config,
        params: FlightParams { mode, plan },
        baro_rate_hz: baro_rate,
        log_path: Some(log_path.clone()),
        metadata,
        clock_speed: args.clock_speed,
        restart_from: restart_from.map(|w| w.warm),
        warm_file: Some((warm_path, start_words)),
        ground_link: Arc::clone(&ground_link),
    };
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        let ground_link = Arc::clone(&ground_link);
        std::thread::spawn(move || {
            while let Some(line) = read_line() {
                let words: Vec<&str> = line.split_whitespace().collect();
                if words == ["stop"] {
                    break;
                }
                if let Some(state) = link_word(&words) {
                    ground_link.store(state, Ordering::Release);
                }
            }
            // `stop`, or the bootstrap is gone: clean up either way.
            stop.store(true, Ordering::Release);
        });
    }
    let line = reporter();
    let report = Arc::new(move |r: Report| match r {
        Report::Started { log } => line(format!(
            "started {}",
            log.map_or("(no log)".to_string(), |p| p.display().to_string())
        )),
        Report::Note(text) => line(format!("note {text}")),
        Report::Event { severity, text, .. } => line(format!("event {} {text}", severity.name())),
        Report::Telemetry(v) => line(format!("telemetry {v}")),
    });
    let summary = match flight::run(setup, stop, report) {
        Ok(s) => s,
        Err(e) => {
            // The bootstrap answers the pending Start Logging with this.
            say(&format!("error {e}"));
            bail!("{e}");
        }
    };
    let s = summary.stats;
    let json = serde_json::json!({
        "imu_samples": s.imu_samples,
        "watchdog_fires": s.watchdog_fires,
        "control_steps": s.control_steps,
        "uplinks": s.uplinks,
        "gps_fixes": s.gps_fixes,
        "baro_readings": s.baro_readings,
        "compass_readings": s.compass_readings,
        "inputs": summary.inputs,
        "log_messages": summary.log.as_ref().map(|l| l.messages),
        "log_error": summary.log.as_ref().and_then(|l| l.error.clone()),
        "log_dropped": summary.log_dropped,
    });
    say(&format!("stopped {json}"));
    Ok(ExitCode::SUCCESS)
}

/// The flight log's path: `flight_<suffix>.mcap`, or for a process started again after a
/// crash `flight_<suffix>_r<N>.mcap` with the first N not taken (the crashed process's log
/// is never overwritten).
fn next_free_log(dir: &std::path::Path, suffix: &str, restart: bool) -> std::path::PathBuf {
    let first = dir.join(heli_log::file_name("flight", suffix, "mcap"));
    if !restart {
        return first;
    }
    (1..1000)
        .map(|n| {
            dir.join(heli_log::file_name(
                "flight",
                &format!("{suffix}_r{n}"),
                "mcap",
            ))
        })
        .find(|p| !p.exists())
        .unwrap_or(first)
}
