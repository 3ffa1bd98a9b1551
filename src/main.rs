//! `heli`: the command-line front of the heli avionics.
//!
//! The binary only parses arguments and wires the library crates together; the work is in
//! `heli-sim`, `heli-fsw` and the others.

mod bench_hil;
mod bench_link;
mod campaign_cmd;
mod driver_cmd;
mod ground_cmd;
mod hil_replay_cmd;
mod hilsim_cmd;
mod hilsim_view;
mod library_cmd;
mod link_cmd;
mod replay_cmd;
mod sim_ui;
mod suite_cmd;
mod vehicle_cmd;

use std::io::IsTerminal;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use heli_log::FlightLog;
use heli_sim::analysis;
use heli_sim::lockstep::{RunOptions, Simulation};
use heli_sim::logging::StreamLogger;
use heli_sim::params::Airframe;
use heli_sim::scenario;
use heli_sim::summary::{Outcome, Summary};

/// Avionics of MIT's X-Cell 60 acrobatic helicopter, rebuilt: flight software, ground
/// station and hardware-in-the-loop simulator.
#[derive(Parser)]
#[command(name = "heli", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fly a whole simulated flight in one process: helicopter model, simulated devices and
    /// the flight software in lockstep on a virtual clock.
    Sim(SimArgs),
    /// Analyse the X-Cell 60 model alone: trim, modes, governor response.
    Model(ModelArgs),
    /// Measure parser throughput, control-step latency, lockstep speed and memory.
    Bench {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Instead: fly the hover scenario this many seconds in real time against the
        /// flight process on the HILSim's pseudo-terminals, and measure the IMU-to-servo
        /// latency and the flight process's CPU share and memory.
        #[arg(long, value_name = "SECONDS")]
        hil: Option<f64>,
        /// Instead: the MAVLink link on loopback: log download throughput and command
        /// round-trip time.
        #[arg(long, conflicts_with = "hil")]
        link: bool,
    },
    /// The HILSim alone, in real time: the helicopter's devices on pseudo-terminals and
    /// IIO-style ADC files for a flight computer outside (`heli vehicle --hilsim DIR`).
    Hilsim(hilsim_cmd::HilsimArgs),
    /// The vehicle's bootstrap: starts and stops the flight process on Connect / Stop from
    /// its control socket; `heli vehicle ctl COMMAND` sends it one.
    #[command(args_conflicts_with_subcommands = true)]
    Vehicle {
        #[command(flatten)]
        flight: vehicle_cmd::FlightArgs,
        /// The bootstrap's control socket.
        #[arg(long, global = true, env = "HELI_VEHICLE_SOCKET", default_value = vehicle_cmd::DEFAULT_SOCKET)]
        socket: std::path::PathBuf,
        /// Serve the MAVLink 2 link on this address (udp:HOST:PORT; e.g. udp:0.0.0.0:14550).
        #[arg(long)]
        link: Option<String>,
        /// The signing key file (heli link keygen); without one the link is unauthenticated.
        #[arg(long, env = "HELI_LINK_KEY")]
        key: Option<std::path::PathBuf>,
        #[command(subcommand)]
        ctl: Option<VehicleCtl>,
    },
    /// The flight process the bootstrap starts (speaks a line protocol on stdin/stdout).
    #[command(hide = true)]
    Flight(vehicle_cmd::FlightArgs),
    /// One device's stand-alone driver: readable lines per packet, logging with --log.
    Driver(driver_cmd::DriverArgs),
    /// Monte Carlo campaigns: many flights of a scenario with values drawn or stepped, in
    /// parallel, summed up in one report (docs/campaigns.md). Exit status 0 only when every
    /// flight passed.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Campaign {
        #[command(flatten)]
        run: campaign_cmd::RunArgs,
        #[command(subcommand)]
        merge: Option<campaign_cmd::MergeCommand>,
    },
    /// The ground station as a command-line client of the vehicle's MAVLink link
    /// (docs/link.md).
    Ground(ground_cmd::GroundArgs),
    /// The MAVLink link's signing key.
    Link {
        #[command(subcommand)]
        action: LinkAction,
    },
    /// Read flight logs.
    Log {
        #[command(subcommand)]
        action: LogAction,
    },
}

#[derive(Subcommand)]
enum VehicleCtl {
    /// Send the bootstrap one command: connect, start-logging SUFFIX MODE [PLAN], stop,
    /// status, quit.
    Ctl {
        /// The command and its arguments.
        #[arg(required = true, num_args = 1..)]
        command: Vec<String>,
    },
}

#[derive(Subcommand)]
enum LinkAction {
    /// Make a new signing key file (32 random bytes, readable by its owner only).
    Keygen {
        /// Where to write it.
        #[arg(long, default_value = "heli-link.key")]
        out: std::path::PathBuf,
        /// Replace an existing key file.
        #[arg(long)]
        force: bool,
    },
}

#[derive(Subcommand)]
enum LogAction {
    /// Channels, message counts, time span, and whether the file was cut off.
    Info {
        /// The log file.
        file: std::path::PathBuf,
    },
    /// One channel as CSV (a `t_s` column, then one column per field).
    Export {
        /// The log file.
        file: std::path::PathBuf,
        /// Channel: imu, state, servo, uplink, gps, baro, compass, events.
        #[arg(long)]
        channel: String,
        /// Write here instead of standard output.
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
    /// Feed the log's recorded device inputs to a fresh flight computer and compare its
    /// servo commands and state estimates with the log's, bit for bit.
    Replay {
        /// The log file.
        file: std::path::PathBuf,
    },
    /// Plot one channel's fields against time (SVG or PNG), with the flight's events marked.
    Plot {
        /// The log file.
        file: std::path::PathBuf,
        /// Channel: imu, state, servo, uplink, gps, baro, compass.
        #[arg(long)]
        channel: String,
        /// Field to plot, one panel each; a vector field plots all its components
        /// (`pos_ned_m`) or one (`pos_ned_m[2]`). Repeat for more. Default: every numeric field.
        #[arg(long = "field")]
        fields: Vec<String>,
        /// Start of the time window (s of vehicle clock).
        #[arg(long)]
        from: Option<f64>,
        /// End of the time window (s of vehicle clock).
        #[arg(long)]
        to: Option<f64>,
        /// Image to write, `.svg` or `.png` [default: <log>_<channel>.svg beside the log].
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
}

#[derive(clap::Args)]
struct ModelArgs {
    #[command(subcommand)]
    analysis: ModelAnalysis,
    /// Airframe parameters (TOML; fields not given keep the X-Cell 60 values).
    #[arg(long, global = true)]
    airframe: Option<std::path::PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long, global = true)]
    json: bool,
}

#[derive(Subcommand)]
enum ModelAnalysis {
    /// Steady level flight: trim controls, attitude, rotor torque and power.
    Trim {
        /// Forward speed (m/s).
        #[arg(long, default_value_t = 0.0)]
        speed: f64,
    },
    /// Linearised roll and pitch rotor-fuselage modes at hover.
    Modes,
    /// Rotor-speed response to a governor set-point step at hover.
    GovernorStep {
        /// Step size (rpm).
        #[arg(long, default_value_t = 100.0)]
        step: f64,
    },
}

#[derive(clap::Args)]
struct SimArgs {
    /// Built-in scenario name or path to a scenario TOML file (default: the most complete
    /// built-in flight).
    #[arg(long)]
    scenario: Option<String>,
    /// Stop after this many simulated seconds.
    #[arg(long)]
    duration: Option<f64>,
    /// Pace the simulation to the wall clock.
    #[arg(long)]
    realtime: bool,
    /// Seed for every noise source (overrides the scenario's).
    #[arg(long)]
    seed: Option<u64>,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// List the built-in scenarios and exit.
    #[arg(long)]
    list: bool,
    /// Fly every built-in scenario and keep its log in this directory (`NAME.mcap`, and
    /// `index.txt`): recorded flights for `heli hilsim --replay` to check later software on.
    #[arg(long, value_name = "DIR")]
    library: Option<std::path::PathBuf>,
    /// Write the flight log (MCAP: the seven streams and the events) to this file.
    #[arg(long)]
    log: Option<std::path::PathBuf>,
    /// The whole system instead, in real time, as separate processes: the HILSim (default
    /// scenario demo), the vehicle on its pseudo-terminals and the ground station's display
    /// in the browser (its URL is printed). Ctrl-C stops everything.
    #[arg(long)]
    ui: bool,
    /// With --ui: where the display is served (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:8080")]
    http: String,
    /// With --ui: the vehicle's bias calibration (s); the thesis's 80 s by default.
    #[arg(long, default_value_t = 80.0)]
    calibration_s: f64,
}

/// A reader that stops early (`heli log info x.mcap | head`) closes the pipe; Rust ignores
/// SIGPIPE, so the next `println!` panics. Every command prints with `println!`, so the
/// whole class is handled here: such a panic ends the program quietly, as SIGPIPE would.
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sim(args) => sim(args),
        Command::Model(args) => model(args),
        Command::Log { action } => log(action),
        Command::Bench {
            json, link: true, ..
        } => bench_link::command(json),
        Command::Bench {
            json, hil: None, ..
        } => bench(json),
        Command::Bench {
            json,
            hil: Some(seconds),
            ..
        } => bench_hil::command(seconds, json),
        Command::Hilsim(args) => hilsim_cmd::hilsim(&args),
        Command::Vehicle {
            flight,
            socket,
            link,
            key,
            ctl,
        } => match ctl {
            Some(VehicleCtl::Ctl { command }) => vehicle_cmd::ctl(&command, &socket),
            None => vehicle_cmd::vehicle(&flight, &socket, link.as_deref(), key.as_deref()),
        },
        Command::Ground(args) => ground_cmd::ground(&args),
        Command::Link {
            action: LinkAction::Keygen { out, force },
        } => link_cmd::keygen(&out, force),
        Command::Flight(args) => vehicle_cmd::flight_process(&args),
        Command::Driver(args) => driver_cmd::driver(&args),
        Command::Campaign { run, merge } => match merge {
            Some(campaign_cmd::MergeCommand::Merge(args)) => campaign_cmd::merge(&args),
            Some(campaign_cmd::MergeCommand::Suite(args)) => suite_cmd::suite(&args),
            None => campaign_cmd::campaign(&run),
        },
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("heli: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn sim(args: SimArgs) -> Result<ExitCode> {
    if args.ui {
        return sim_ui::run(&sim_ui::UiOptions {
            scenario: args.scenario.unwrap_or_else(|| "demo".into()),
            http: args.http,
            calibration_s: args.calibration_s,
        });
    }
    if let Some(dir) = &args.library {
        return library_cmd::record(dir);
    }
    if args.list {
        for s in scenario::builtins() {
            println!("{:<16} {}", s.name, s.description);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let mut scenario = match &args.scenario {
        Some(name) => scenario::load(name).with_context(|| format!("loading scenario '{name}'"))?,
        None => scenario::builtins()
            .into_iter()
            .next()
            .context("no built-in scenario")?,
    };
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    fly(scenario, &args)
}

/// Flies `scenario` as `heli sim` does (`args` for duration, pace, log and output), prints
/// the table or the JSON, and exits 0 only on a pass.
fn fly(scenario: scenario::Scenario, args: &SimArgs) -> Result<ExitCode> {
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration must be a positive number of seconds, not {d}");
    }
    let options = RunOptions {
        realtime: args.realtime,
        duration_s: args.duration,
    };
    let show_progress = !args.json && std::io::stderr().is_terminal();
    let summary = run_flight(scenario, options, args.log.as_deref(), show_progress)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_table(&summary);
    }
    Ok(if summary.outcome == Outcome::Pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Flies `scenario` in lockstep, logging to `log` when given (with the device inputs, so
/// that `heli log replay` and `heli hilsim --replay` can play it again).
pub(crate) fn run_flight(
    scenario: scenario::Scenario,
    options: RunOptions,
    log: Option<&std::path::Path>,
    show_progress: bool,
) -> Result<heli_sim::Summary> {
    let bar = show_progress.then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} sim {msg} [{bar:40}] {percent:>3}%")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let name = scenario.name.clone();
    let mut logger = match log {
        Some(path) => {
            let mut log = FlightLog::create(path)
                .with_context(|| format!("creating the flight log {}", path.display()))?;
            // What flew, when, and the whole scenario, so that the flight can be flown again.
            let parameters = [
                ("scenario".to_string(), scenario.name.clone()),
                ("seed".to_string(), scenario.seed.to_string()),
                ("scenario_toml".to_string(), toml::to_string(&scenario)?),
            ];
            let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
            let entries =
                heli_log::metadata::flight(software, std::time::SystemTime::now(), parameters);
            log.write_metadata(heli_log::metadata::FLIGHT, &entries)
                .with_context(|| format!("writing the flight log {}", path.display()))?;
            Some(StreamLogger::new(log))
        }
        None => None,
    };
    let mut log_error = None;
    let mut simulation = Simulation::new(scenario)?;
    if logger.is_some() {
        // So that the log can be replayed (`heli log replay`).
        simulation.log_device_inputs();
    }
    let mut summary = simulation.run_observed(
        options,
        |t, total| {
            if let Some(bar) = &bar {
                bar.set_position((t / total * 1000.0) as u64);
                bar.set_message(format!("{name} t={t:>6.1} s"));
            }
        },
        |sim| {
            if let (Some(l), None) = (logger.as_mut(), &log_error) {
                log_error = l.drain(sim).err();
            }
        },
    );
    if let (Some(l), Some(path)) = (logger, log) {
        match log_error.map_or_else(|| l.finish().map(|_| ()), Err) {
            Ok(()) => summary.log = Some(path.display().to_string()),
            // The flight went on; only its log is lost. Say so, never hide it.
            Err(e) => eprintln!("heli: the flight log {} is incomplete: {e}", path.display()),
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    Ok(summary)
}

fn model(args: ModelArgs) -> Result<ExitCode> {
    let airframe = match &args.airframe {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let airframe: Airframe = toml::from_str(&text)
                .with_context(|| format!("invalid airframe file {}", path.display()))?;
            heli_sim::validate::airframe(&airframe)
                .map_err(|e| anyhow::anyhow!("airframe file {}: {e}", path.display()))?;
            airframe
        }
        None => Airframe::default(),
    };
    match args.analysis {
        ModelAnalysis::Trim { speed } => {
            if !speed.is_finite() || !(0.0..=25.0).contains(&speed) {
                bail!("--speed must be between 0 and 25 m/s (the model's envelope), not {speed}");
            }
            let t = analysis::trim(&airframe, speed).context("the trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&t)?);
            } else {
                println!(
                    "trim at {:.1} m/s ({} iterations, residual {:.1e})",
                    t.speed_mps, t.iterations, t.residual
                );
                println!("  collective        {:8.3} deg", t.collective_deg);
                println!("  lateral cyclic    {:8.4} rad", t.lat_cyclic_rad);
                println!("  longitudinal cyc. {:8.4} rad", t.lon_cyclic_rad);
                println!("  tail pitch cmd    {:8.4} rad", t.tail_pitch_cmd_rad);
                println!(
                    "  roll / pitch      {:8.2} / {:.2} deg",
                    t.roll_deg, t.pitch_deg
                );
                println!(
                    "  flapping a1 / b1  {:8.3} / {:.3} deg",
                    t.flap_lon_deg, t.flap_lat_deg
                );
                println!("  thrust            {:8.2} N", t.thrust_n);
                println!("  main-rotor torque {:8.3} N m", t.mr_torque_nm);
                println!(
                    "  shaft power       {:8.1} W (throttle {:.3})",
                    t.power_w, t.throttle
                );
            }
        }
        ModelAnalysis::Modes => {
            let m = analysis::hover_modes(&airframe).context("the hover trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&m)?);
            } else {
                println!("rotor-fuselage modes at hover");
                println!(
                    "  roll  (p, b1)  wn {:6.2} rad/s  zeta {:.3}",
                    m.roll.natural_frequency_rps, m.roll.damping
                );
                println!(
                    "  pitch (q, a1)  wn {:6.2} rad/s  zeta {:.3}",
                    m.pitch.natural_frequency_rps, m.pitch.damping
                );
                println!("full linearisation, eigenvalues (re, im):");
                for [re, im] in &m.full_eigenvalues {
                    println!("  {re:10.4} {im:+10.4}i");
                }
            }
        }
        ModelAnalysis::GovernorStep { step } => {
            if !step.is_finite() || step == 0.0 || step.abs() > 400.0 {
                bail!("--step must be a non-zero number of rpm up to 400, not {step}");
            }
            let g = analysis::governor_step(&airframe, step)
                .context("the hover trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&g)?);
            } else {
                println!("governor step of {:.0} rpm at hover", g.step_rpm);
                println!(
                    "  poles: wn {:.3} rad/s, zeta {:.3}",
                    g.natural_frequency_rps, g.damping
                );
                println!(
                    "  response: overshoot {:.1} %, first peak at {:.2} s",
                    100.0 * g.overshoot,
                    g.peak_time_s
                );
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn log(action: LogAction) -> Result<ExitCode> {
    let read = |file: &std::path::Path| -> Result<heli_log::LogContents> {
        let bytes = std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
        let contents = heli_log::read(&bytes);
        if let Some(stop) = &contents.stopped
            && stop.kind == heli_log::StopKind::NotMcap
        {
            bail!("{} is {stop}", file.display());
        }
        Ok(contents)
    };
    match action {
        LogAction::Replay { file } => return replay_cmd::replay(&file, &read(&file)?),
        LogAction::Info { file } => {
            let contents = read(&file)?;
            print_log_info(&file, &contents)?;
        }
        LogAction::Export { file, channel, out } => {
            let contents = read(&file)?;
            let csv = heli_log::to_csv(&contents, &channel);
            if csv.is_empty() {
                bail!(
                    "no messages on channel '{channel}' in {} (see `heli log info`)",
                    file.display()
                );
            }
            match out {
                Some(path) => std::fs::write(&path, csv)
                    .with_context(|| format!("writing {}", path.display()))?,
                None => write_stdout(&csv)?,
            }
        }
        LogAction::Plot {
            file,
            channel,
            fields,
            from,
            to,
            out,
        } => {
            use heli_log::plot;
            let out = out.unwrap_or_else(|| {
                let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("log");
                let name: String = channel
                    .chars()
                    .map(|c| {
                        if c.is_alphanumeric() || c == '-' {
                            c
                        } else {
                            '_'
                        }
                    })
                    .collect();
                file.with_file_name(format!("{stem}_{name}.svg"))
            });
            let format = plot::ImageFormat::from_path(&out)
                .ok_or_else(|| plot::PlotError::UnknownFormat(out.display().to_string()))?;
            let contents = read(&file)?;
            let window = plot::Window {
                from_s: from,
                to_s: to,
            };
            let (panels, left_out) = plot::panels(&contents, &channel, &fields, window)
                .with_context(|| format!("plotting {}", file.display()))?;
            let marks = plot::events(&contents, window);
            let title = format!("{} - {channel}", file.display());
            plot::render(&panels, &marks, &title, format, &out)?;
            println!("wrote {} ({} panels)", out.display(), panels.len());
            // The event texts begin with their time.
            for (i, (_, text)) in marks.iter().enumerate() {
                println!("  {:>3}  {text}", i + 1);
            }
            if left_out > 0 {
                println!(
                    "  {left_out} more fields not drawn (at most {} panels per plot): name fewer with --field",
                    plot::MAX_PANELS
                );
            }
            if let Some(why) = &contents.stopped {
                println!("  reading the log stopped early ({why}); plotted what was read");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Most faults `heli log info` lists one by one.
const FAULTS_LISTED: usize = 20;

/// `heli log info`: channels with their counts, rates, gaps and schemas, the metadata, the
/// warnings and worse, and whether the file is whole. A log with no message, or a corrupt
/// one, is an error (after what could be read is shown).
fn print_log_info(file: &std::path::Path, contents: &heli_log::LogContents) -> Result<()> {
    use heli_log::StopKind;
    if contents.messages.is_empty() {
        let why = contents
            .stopped
            .as_ref()
            .map_or(String::new(), |s| format!(" ({s})"));
        bail!("{} holds no messages{why}", file.display());
    }
    println!("{}", file.display());
    if let Some((first, last)) = contents.span_us() {
        println!(
            "  time     {:.3} s to {:.3} s",
            first as f64 * 1e-6,
            last as f64 * 1e-6
        );
    }
    println!("  channel       messages            rate  largest interval        sequence");
    for c in heli_log::stats::channels(contents) {
        let rate = c.rate_hz.map_or("-".to_string(), |hz| {
            if hz >= 1.0 {
                format!("{hz:.1} Hz")
            } else {
                format!("{hz:.3} Hz")
            }
        });
        let interval = format!(
            "{:.3} s before {:.2} s",
            c.largest_interval_us as f64 * 1e-6,
            c.largest_interval_end_us as f64 * 1e-6
        );
        let sequence = match (c.sequence_gaps, c.sequence_breaks) {
            (0, 0) => "no gaps".to_string(),
            (gaps, 0) => format!("{gaps} gaps, {} missing", c.missing),
            (gaps, breaks) => format!("{gaps} gaps, {} missing, {breaks} restarts", c.missing),
        };
        println!(
            "  {:<12} {:>6} messages {:>10}  {interval:<22}  {sequence}  [{}]",
            c.topic,
            c.messages,
            rate,
            c.schema.as_deref().unwrap_or("no schema")
        );
    }
    for m in &contents.metadata {
        println!("  metadata '{}'", m.name);
        for (key, value) in &m.entries {
            let lines = value.lines().count();
            if lines > 1 {
                println!("    {key:<26} ({lines} lines)");
            } else {
                println!("    {key:<26} {value}");
            }
        }
    }
    let faults = heli_log::stats::faults(contents);
    if faults.is_empty() {
        println!("  faults   none (no event at level warning or worse)");
    } else {
        println!(
            "  faults   {} events at level warning or worse",
            faults.len()
        );
        for f in faults.iter().take(FAULTS_LISTED) {
            println!("    {:<8} {}", f.level.name(), f.text);
        }
        if faults.len() > FAULTS_LISTED {
            println!("    ... and {} more", faults.len() - FAULTS_LISTED);
        }
    }
    if contents.bad_messages > 0 {
        println!("  {} messages could not be decoded", contents.bad_messages);
    }
    match &contents.stopped {
        None if contents.closed => println!("  complete: closed by its writer"),
        None => println!(
            "  complete up to its last flush, not closed by its writer (crash, kill or power loss)"
        ),
        Some(stop) if stop.kind == StopKind::Truncated => {
            println!("  cut off: read up to the last whole chunk; {stop}")
        }
        Some(stop) => bail!(
            "{} is damaged: {stop}; the messages before it are listed above",
            file.display()
        ),
    }
    Ok(())
}

fn bench(json: bool) -> Result<ExitCode> {
    let report = heli_sim::bench::run();
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("parsers (8 MB of back-to-back frames through the flight software's drivers)");
    for p in &report.parsers {
        println!(
            "  {:<8} {:>8.1} MB/s  ({} frames)",
            p.device, p.mb_per_s, p.frames
        );
    }
    let c = &report.control_step;
    println!(
        "control step (hover, {} steps with the estimator running): median {:.1} us, p99 {:.1} us, max {:.1} us (budget 20 000 us)",
        c.steps, c.median_us, c.p99_us, c.max_us
    );
    for (name, rtf) in &report.realtime_factor {
        println!("lockstep {name:<6} {rtf:.0}x real time");
    }
    if let Some(mib) = report.peak_rss_mib {
        println!("peak memory {mib:.1} MiB");
    }
    Ok(ExitCode::SUCCESS)
}

/// Writes to standard output; a reader that stops early (`| head`) is not an error.
fn write_stdout(text: &str) -> Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

/// A measured value with `decimals` decimals, or `-` when it was not measured.
pub(crate) fn shown(value: Option<f64>, decimals: usize) -> String {
    value.map_or_else(|| "-".to_string(), |v| format!("{v:.decimals$}"))
}

pub(crate) fn print_table(s: &Summary) {
    println!("scenario   {} (seed {})", s.scenario, s.seed);
    println!(
        "simulated  {:.1} s in {:.2} s wall time: {:.0}x real time",
        s.sim_time_s, s.wall_time_s, s.realtime_factor
    );
    println!();
    println!(
        "{:<28} {:>10} {:>10}  result",
        "criterion", "value", "limit"
    );
    for c in &s.criteria {
        println!(
            "{:<28} {:>10} {:>10.3}  {}",
            c.name,
            shown(c.value, 3),
            c.limit,
            if c.pass { "pass" } else { "FAIL" }
        );
    }
    println!();
    if let Some(h) = &s.hil {
        // Hardware in the loop: the flight software is elsewhere; only what crossed the
        // wires is known here.
        let l = &h.latency_us;
        println!(
            "flight computer  {} servo packets; IMU written -> servo readable p50 {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us",
            h.servo_packets, l.p50, l.p99, l.p999, l.max
        );
        if h.dropped_writes > 0 {
            println!("devices    {} writes found no reader", h.dropped_writes);
        }
        println!("battery    min {} V", shown(s.devices.battery_min_v, 2));
    } else {
        let e = &s.estimator;
        println!(
            "estimator  attitude error rms {} deg (max {}), position rms {} m, velocity rms {} m/s",
            shown(e.att_err_rms_deg, 2),
            shown(e.att_err_max_deg, 2),
            shown(e.pos_err_rms_m, 2),
            shown(e.vel_err_rms_mps, 2)
        );
        let l = &s.loop_;
        println!(
            "main loop  {} IMU packets ({} dropped), {} watchdog fires, {} control steps, slowest step {:.0} us",
            l.imu_samples, l.imu_dropped, l.watchdog_fires, l.control_steps, l.step_time_max_us
        );
        println!(
            "links      imu {} frames / {} bad, uplink {} / {}, gps {} / {}, altimeter {} readings ({}), battery min {} V",
            s.devices.imu.frames,
            s.devices.imu.checksum_errors,
            s.devices.uplink.frames,
            s.devices.uplink.checksum_errors,
            s.devices.gps.frames,
            s.devices.gps.checksum_errors,
            s.devices.baro_readings,
            s.devices.baro_link,
            shown(s.devices.battery_min_v, 2)
        );
    }
    let watchdog_events = s
        .events
        .iter()
        .filter(|e| e.ends_with("watchdog fired"))
        .count();
    for event in s.events.iter().filter(|e| !e.ends_with("watchdog fired")) {
        println!("event      {event}");
    }
    if watchdog_events > 0 {
        println!("event      watchdog fired {watchdog_events} times (each listed in --json)");
    }
    if let Some(crash) = &s.crash {
        println!("CRASH      {crash}");
    }
    println!();
    let outcome = match s.outcome {
        Outcome::Pass => "PASS",
        Outcome::Fail => "FAIL",
        Outcome::Crash => "CRASH",
    };
    println!("outcome    {outcome}");
}
