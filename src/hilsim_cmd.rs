//! `heli hilsim --ptys DIR`: the simulator alone, in real time, with its devices on
//! pseudo-terminals and IIO-style ADC files for a flight computer outside; with `--replay
//! FLIGHT.mcap`, a recorded flight's device inputs instead of the simulator's, and the
//! computer's servo commands compared with the recorded ones.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, anyhow, bail};
use heli_scenario as scenario;
use heli_sim::hil::{self, HilOptions};
use heli_sim::lockstep::Simulation;
use heli_sim::replay::compare::{CHANNELS, Tolerance};
use heli_sim::replay::hil::{self as hil_replay, Recording, ReplayOptions};
use heli_sim::summary::Outcome;

/// Arguments of `heli hilsim`.
#[derive(clap::Args)]
pub struct HilsimArgs {
    /// Directory for the devices: symlinks imu, scb, gps, baro to pseudo-terminals, and
    /// adc/in_voltageN_raw (compass x, y, z on 0-2, battery on 3).
    #[arg(long)]
    pub ptys: PathBuf,
    /// Built-in scenario name or scenario file: the helicopter, wind, pilot and faults.
    #[arg(long, default_value = "hover")]
    pub scenario: String,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Stop after this many simulated seconds (default: the scenario's duration).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Seed for every noise source (overrides the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Print the truth summary (with --replay: the comparison) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Play this recorded flight's device inputs (a vehicle's or `heli sim --log`'s) instead
    /// of simulating, and compare the flight computer's servo commands with the recorded
    /// ones. Exit 0 when they match, 1 when they differ.
    #[arg(long, value_name = "FLIGHT.mcap", conflicts_with_all = ["scenario", "duration", "seed"])]
    pub replay: Option<PathBuf>,
    /// With --replay: the largest pulse-width difference that still matches (µs).
    #[arg(long, default_value_t = 50)]
    pub tolerance_us: u16,
    /// Serve a 3D view of the simulator's truth on this address (`127.0.0.1:0` picks a free
    /// port; the URL is printed): the helicopter, its rotor disk, the field, the plan, the
    /// trail, the wind, from the pilot's stand, a chase camera or above (a flat field camera
    /// where the browser has no WebGL).
    #[arg(long, value_name = "ADDR")]
    pub view: Option<std::net::SocketAddr>,
    /// With --view: a person flies from the view's page — a gamepad or RC transmitter
    /// through the browser's Gamepad API, or the keyboard — through the simulated receiver
    /// and servo controller board, and the page's trainer panel triggers failures.
    #[arg(long, requires = "view")]
    pub pilot: bool,
    /// With --replay: the share of commands that may be out of tolerance (0-1).
    #[arg(long, default_value_t = 0.01)]
    pub tolerance_share: f64,
    /// With --replay: how long to wait for the flight computer to start (s).
    #[arg(long, default_value_t = 300.0)]
    pub wait_s: f64,
    /// Take failures on standard input, one a line, applied at once — the trainer panel's
    /// requests as JSON (`{"kind":"servo-board-silent","seconds":3}`; docs/pilot.md lists
    /// every kind), for a script or a fault campaign to inject faults while a flight runs.
    /// Each is answered on standard error (`hilsim: failure at T s: …` or `hilsim: failure refused: …`).
    #[arg(long, conflicts_with = "replay")]
    pub failures_stdin: bool,
    /// Pin the HILSim's loop and device readers to this CPU (as `heli vehicle --rt-cpu`):
    /// load on the other CPUs, a flood of the network's interrupts above all, then costs
    /// the simulated world no time.
    #[arg(long, value_name = "CPU", conflicts_with = "replay")]
    pub cpu: Option<usize>,
}

/// Reads failure requests from standard input on a thread of their own.
fn failures_from_stdin() -> Result<std::sync::mpsc::Receiver<String>> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("failures".into())
        .spawn(move || {
            use std::io::BufRead;
            for line in std::io::stdin().lock().lines().map_while(Result::ok) {
                if !line.trim().is_empty() && tx.send(line).is_err() {
                    return;
                }
            }
        })
        .context("starting the failures reader")?;
    Ok(rx)
}

/// Where `--json` output goes: the original standard output, kept apart from every other
/// line the run prints.
struct JsonOut(std::fs::File);

impl JsonOut {
    /// With `--json`, standard output becomes standard error for the rest of the run (every
    /// progress line, the library's included, goes there), and the JSON document alone goes
    /// to the original standard output.
    fn divert() -> Result<Self> {
        use std::os::fd::AsFd;
        let out = std::io::stdout();
        let _ = std::io::Write::flush(&mut out.lock());
        let original = out
            .as_fd()
            .try_clone_to_owned()
            .context("keeping standard output")?;
        nix::unistd::dup2_stdout(std::io::stderr())
            .context("sending progress lines to standard error")?;
        Ok(Self(std::fs::File::from(original)))
    }

    fn print(mut self, value: &impl serde::Serialize) -> Result<()> {
        let text = serde_json::to_string_pretty(value)?;
        std::io::Write::write_all(&mut self.0, format!("{text}\n").as_bytes())?;
        Ok(())
    }
}

/// Runs the HILSim until its duration, a crash, or SIGINT / SIGTERM.
pub fn hilsim(args: &HilsimArgs) -> Result<ExitCode> {
    let json = if args.json {
        Some(JsonOut::divert()?)
    } else {
        None
    };
    if let Some(flight) = &args.replay {
        return replay(args, flight, json);
    }
    let mut scenario = scenario::load(&args.scenario)
        .with_context(|| format!("loading scenario '{}'", args.scenario))?;
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration must be a positive number of seconds, not {d}");
    }
    // The lab's compass calibration of this simulated compass, where the vehicle finds it.
    let compass = Simulation::new(scenario.clone())?
        .flight_software_setup()
        .0
        .compass;
    let stop = stop_on_signals()?;
    let options = HilOptions {
        speed: args.speed,
        duration_s: args.duration,
        stamps: false,
        cpu: args.cpu,
    };
    let dir = args.ptys.clone();
    let name = scenario.name.clone();
    let (feed, mut cockpit) = match args.view {
        Some(addr) => {
            let (feed, cockpit) = heli_sim::view::cockpit::serve(addr, &scenario, args.pilot)?;
            (Some(feed), cockpit)
        }
        None => (None, None),
    };
    let mut last_frame: Option<std::time::Instant> = None;
    let failures = args.failures_stdin.then(failures_from_stdin).transpose()?;
    let watch = |sim: &mut Simulation| {
        if let Some(c) = &mut cockpit {
            c.apply(sim);
        }
        while let Some(line) = failures.as_ref().and_then(|rx| rx.try_recv().ok()) {
            let t_s = sim.now_us() as f64 * 1e-6;
            match scenario::trainer::TrainerFault::parse(&line).and_then(|f| sim.trigger_fault(&f))
            {
                Ok(what) => eprintln!("hilsim: failure at {t_s:.2} s: {what}"),
                Err(why) => eprintln!("hilsim: failure refused: {why}"),
            }
        }
        if let Some(feed) = &feed
            && last_frame.is_none_or(|t| t.elapsed() >= heli_sim::view::cockpit::FRAME_EVERY)
        {
            last_frame = Some(std::time::Instant::now());
            heli_sim::view::cockpit::publish(feed, sim, cockpit.as_ref());
        }
    };
    let summary = hil::run(
        scenario,
        &dir,
        options,
        &stop,
        |devices| {
            let cal = devices.dir.join(heli_vehicle::compass_file::HIL_FILE_NAME);
            if let Err(e) = heli_vehicle::compass_file::write(&cal, &compass) {
                eprintln!("heli hilsim: {e:#}");
            }
            println!("hilsim: scenario {name}, {}x real time", args.speed);
            print_devices(devices, &cal);
        },
        watch,
    )
    .map_err(anyhow::Error::msg)?;
    if let Some(json) = json {
        json.print(&summary)?;
    } else {
        print!("{}", heli_sim::summary::table(&summary));
    }
    Ok(if summary.outcome == Outcome::Pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// A flag set by SIGINT or SIGTERM.
pub(crate) fn stop_on_signals() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing the signal handler")?;
    }
    Ok(stop)
}

/// Where the devices are, and the line a launcher waits for.
pub(crate) fn print_devices(devices: &hil::HilDevices, compass_cal: &std::path::Path) {
    for (port, link, target) in &devices.ports {
        println!(
            "hilsim: {:<5} {} -> {}",
            port.name(),
            link.display(),
            target.display()
        );
    }
    println!(
        "hilsim: adc   {} (compass x,y,z: in_voltage0-2_raw, battery: in_voltage3_raw)",
        devices.adc.display()
    );
    println!("hilsim: compass calibration {}", compass_cal.display());
    println!("hilsim: ready");
}

/// Replays `flight`; exit 0 when the commands match, 1 when they differ.
fn replay(args: &HilsimArgs, flight: &Path, json: Option<JsonOut>) -> Result<ExitCode> {
    if !(args.wait_s.is_finite() && args.wait_s > 0.0) {
        anyhow::bail!(
            "--wait-s must be a positive number of seconds, not {}",
            args.wait_s
        );
    }
    if !(0.0..=1.0).contains(&args.tolerance_share) {
        anyhow::bail!(
            "--tolerance-share must be a share of the commands from 0 to 1, not {}",
            args.tolerance_share
        );
    }
    let bytes = std::fs::read(flight).with_context(|| format!("{}", flight.display()))?;
    let contents = heli_log::read(&bytes);
    let setup = heli_sim::replay::setup::setup_of(&contents)
        .with_context(|| format!("{}", flight.display()))?;
    let rec = Recording::from_log(&contents)
        .map_err(|e| anyhow!(e))
        .with_context(|| format!("{}", flight.display()))?;
    // A lockstep flight names its scenario (whose plan the vehicle knows by that name); a
    // vehicle's flight names its plan.
    let flight_entry = |key: &str| {
        contents
            .metadata
            .iter()
            .filter(|m| m.name == heli_log::metadata::FLIGHT)
            .find_map(|m| m.entries.get(key).cloned())
    };
    let plan_name = flight_entry("plan")
        .or_else(|| flight_entry("scenario"))
        .unwrap_or_else(|| "(not recorded)".into());
    let stop = stop_on_signals()?;
    let options = ReplayOptions {
        speed: args.speed,
        wait_s: args.wait_s,
        tolerance: Tolerance {
            pulse_us: args.tolerance_us,
            share: args.tolerance_share,
            ..Tolerance::default()
        },
    };
    let report = hil_replay::run(&rec, &args.ptys, options, &stop, |devices| {
        let cal = devices.dir.join(heli_vehicle::compass_file::HIL_FILE_NAME);
        if let Err(e) = heli_vehicle::compass_file::write(&cal, &setup.config.compass) {
            eprintln!("heli hilsim: {e:#}");
        }
        println!(
            "hilsim: replaying {} ({:.1} s of device inputs, {} servo commands), {}x real time",
            flight.display(),
            rec.duration_s(),
            rec.servo.len(),
            args.speed
        );
        println!(
            "hilsim: recorded with calibration {} s, warm-up {} s, mode {}, plan {}: start the flight computer the same way",
            setup.config.calibration_s,
            setup.config.imu_warm_up_s,
            setup.params.mode.name(),
            plan_name
        );
        print_devices(devices, &cal);
    })
    .map_err(|e| anyhow!(e))?;
    let c = &report.comparison;
    if let Some(json) = json {
        json.print(&report)?;
    } else {
        println!(
            "played      {} device inputs over {:.1} s",
            report.inputs_played, report.played_s
        );
        if let Some(stop_s) = report.operator_stop_s {
            println!(
                "stopped     the recorded flight's operator pressed Stop at t={stop_s:.1} s: commands compared up to it (a replay plays the devices, not the operator: the flight computer flies on past it: end it with ctl stop, or ctl kill confirmed on the ground bench if it refuses)"
            );
        }
        if let Some(restart_s) = report.restart_s {
            println!(
                "restarted   the recorded flight's computer was started again at t={restart_s:.1} s (a brown-out in the simulation): commands compared up to it (the replay does not restart the flight computer it plays to)"
            );
        }
        println!(
            "compared    {} of {} recorded servo commands paired ({} sent), largest time offset {:.1} ms, {} on the other IMU samples",
            c.paired,
            c.recorded,
            c.replayed,
            c.max_offset_us as f64 * 1e-3,
            c.shifted
        );
        for (name, ch) in CHANNELS.iter().zip(&c.channels) {
            println!(
                "  {name:<10} largest difference {:>4} us at t={:.2} s, rms {:.2} us",
                ch.max_us, ch.at_s, ch.rms_us
            );
        }
        println!(
            "tolerance   {} us and {} ms; {} commands out of it ({:.2} %, {:.1} % allowed), first at {}",
            c.tolerance.pulse_us,
            c.tolerance.window_us / 1000,
            c.out_of_tolerance,
            100.0 * c.out_of_tolerance as f64 / (c.recorded.max(1)) as f64,
            100.0 * c.tolerance.share,
            c.first_difference_s
                .map_or("none".to_string(), |t| format!("t={t:.2} s"))
        );
        println!(
            "outcome     {}",
            if c.matches() {
                "MATCH: the flight software gives the recorded commands"
            } else if c.recorded == 0 {
                "NOTHING COMPARED: the log has no servo commands"
            } else {
                "DIFFERENT"
            }
        );
    }
    Ok(if c.matches() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
