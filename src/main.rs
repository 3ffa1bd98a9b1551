//! `heli`: the command-line front of the heli avionics.
//!
//! The binary only parses arguments and wires the library crates together; the work is in
//! `heli-sim`, `heli-fsw` and the others.

mod campaign_cmd;
mod certify_cmd;
mod fieldday_cmd;
mod ground_cmd;
mod hilsim_cmd;
mod link_cmd;
mod log_cmd;
mod model_cmd;
mod replay_cmd;

use std::io::IsTerminal;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use heli_scenario as scenario;
use heli_sim::lockstep::RunOptions;
use heli_sim::summary::Outcome;

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
        /// latency stage by stage and the flight process's CPU share and memory.
        #[arg(long, value_name = "SECONDS")]
        hil: Option<f64>,
        /// With --hil: the program whose flight process is measured (default: the onboard
        /// program `heli-vehicle` beside this one; without it, this program's `heli flight`).
        #[arg(long, value_name = "PATH", requires = "hil")]
        flight_program: Option<std::path::PathBuf>,
        /// With --hil: the flight process without its real-time settings (memory locking,
        /// SCHED_FIFO, CPUs kept awake), as an unprivileged process would fly.
        #[arg(long, requires = "hil")]
        no_realtime: bool,
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
        bootstrap: heli_vehicle::cli::BootstrapArgs,
        #[command(subcommand)]
        ctl: Option<heli_vehicle::cli::BootstrapCommand>,
    },
    /// The flight process the bootstrap starts (speaks a line protocol on stdin/stdout).
    #[command(hide = true)]
    Flight(heli_vehicle::cli::FlightProcessArgs),
    /// One device's stand-alone driver: readable lines per packet, logging with --log.
    Driver(heli_vehicle::cli::DriverArgs),
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
    /// The lab's tests of a build and a parameter set: the regression library of recorded
    /// flights replayed to the onboard program and the robustness suite; when they pass, a
    /// signed attestation the vehicle checks ("lab-tested"; docs/security.md). Exit status 0
    /// only when certified.
    Certify(certify_cmd::CertifyArgs),
    /// The field-day fault campaign: each single fault of a field day (kills, full or
    /// read-only storage, a port hung up, stalls, a silent servo board, a brown-out) injected
    /// into the real processes against the HILSim while hovering and rolling, judged by the
    /// truth, the logs (official Python MCAP reader) and what the operator was told
    /// (docs/robustness.md). Real time, about 30 minutes whole. Exit status 0 only when every
    /// trial passes.
    FieldDay(fieldday_cmd::FieldDayArgs),
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
        /// Export what can be read of a cut-off or damaged log (without it such a log is
        /// refused, exit 2).
        #[arg(long)]
        partial: bool,
    },
    /// Feed the log's recorded device inputs to a fresh flight computer and compare its
    /// servo commands and state estimates with the log's, bit for bit. Exit 0: an exact
    /// match over the whole flight; 1: a difference; 2: it could not be replayed (nothing
    /// to compare); 3: the log is cut off or damaged (what could be read is compared).
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
    /// Print the JSON summary on stdout instead of the table (with --list: the scenarios).
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
    /// Write the simulator's truth beside the flight software's estimate to this file (CSV,
    /// one row per 20 ms control period, with the attitude error between them).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["library", "ui", "list"])]
    truth: Option<std::path::PathBuf>,
    /// The whole system instead, in real time, as separate processes: the HILSim (default
    /// scenario demo), the vehicle on its pseudo-terminals and the ground station's display
    /// in the browser (its URL is printed). Ctrl-C stops everything.
    #[arg(long)]
    ui: bool,
    /// With --ui: where the display is served (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:8080")]
    http: std::net::SocketAddr,
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
    // A negative number reaches its option's own check (`--speed -3: must be …`).
    let cli: Cli = heli_vehicle::args::parse();
    let result = match cli.command {
        Command::Sim(args) => sim(args),
        Command::Model(args) => model_cmd::model(args),
        Command::Log { action } => log_cmd::log(action),
        Command::Bench {
            json,
            hil,
            link,
            flight_program,
            no_realtime,
        } => bench(json, hil, link, flight_program, !no_realtime),
        Command::Hilsim(args) => hilsim_cmd::hilsim(&args),
        Command::Vehicle { bootstrap, ctl } => heli_vehicle::cli::vehicle(&bootstrap, ctl.as_ref()),
        Command::Ground(args) => ground_cmd::ground(&args),
        Command::Link {
            action: LinkAction::Keygen { out, force },
        } => link_cmd::keygen(&out, force),
        Command::Flight(args) => heli_vehicle::flight_process::run(&args),
        Command::Driver(args) => heli_vehicle::cli::driver(&args),
        Command::FieldDay(args) => fieldday_cmd::field_day(&args),
        Command::Certify(args) => certify_cmd::certify(&args),
        Command::Campaign { run, merge } => match merge {
            Some(campaign_cmd::MergeCommand::Merge(args)) => campaign_cmd::merge(&args),
            Some(campaign_cmd::MergeCommand::Suite(args)) => campaign_cmd::suite(&args),
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
        return Ok(heli_sim::system::run(&heli_sim::system::UiOptions {
            program: std::env::current_exe().context("finding this program")?,
            scenario: args.scenario.unwrap_or_else(|| "demo".into()),
            http: args.http.to_string(),
            calibration_s: args.calibration_s,
        })?);
    }
    if let Some(dir) = &args.library {
        let passed = heli_sim::library::record(dir, &mut |line| println!("{line}"))?;
        return Ok(if passed {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        });
    }
    if args.list {
        let all = scenario::builtins();
        if args.json {
            let list: Vec<serde_json::Value> = all
                .iter()
                .map(|s| serde_json::json!({"name": s.name, "description": s.description}))
                .collect();
            println!("{}", serde_json::Value::Array(list));
        } else {
            // The names' column as wide as the longest name.
            let width = all
                .iter()
                .map(|s| s.name.chars().count())
                .max()
                .unwrap_or(0);
            for s in &all {
                println!("{:<width$}  {}", s.name, s.description);
            }
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
    let summary = run_flight(
        scenario,
        options,
        args.log.as_deref(),
        args.truth.as_deref(),
        show_progress,
    )?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print!("{}", heli_sim::summary::table(&summary));
    }
    Ok(if summary.outcome == Outcome::Pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Flies `scenario` in lockstep, logging to `log` and tracing the truth to `truth` when
/// given, with a progress bar.
pub(crate) fn run_flight(
    scenario: heli_scenario::Scenario,
    options: RunOptions,
    log: Option<&std::path::Path>,
    truth: Option<&std::path::Path>,
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
    let summary = heli_sim::logging::fly(scenario, options, log, truth, |t, total| {
        if let Some(bar) = &bar {
            bar.set_position((t / total * 1000.0) as u64);
            bar.set_message(format!("{name} t={t:>6.1} s"));
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    Ok(summary)
}

/// Prints a measurement as JSON, or with its own table.
fn report<T: serde::Serialize>(value: &T, json: bool, table: fn(&T)) -> Result<ExitCode> {
    if json {
        println!("{}", serde_json::to_string_pretty(value)?);
    } else {
        table(value);
    }
    Ok(ExitCode::SUCCESS)
}

/// `heli bench`: the lockstep benchmarks, or `--link` the link's, or `--hil SECONDS` the
/// HIL path against this program's flight process.
fn bench(
    json: bool,
    hil: Option<f64>,
    link: bool,
    flight_program: Option<std::path::PathBuf>,
    realtime: bool,
) -> Result<ExitCode> {
    if link {
        return report(
            &heli_ground::bench::measure()?,
            json,
            heli_ground::bench::print,
        );
    }
    if let Some(seconds) = hil {
        let exe = std::env::current_exe().context("finding this program")?;
        let onboard = exe.with_file_name("heli-vehicle");
        let program = match flight_program {
            Some(p) => p,
            None if onboard.is_file() => onboard,
            None => exe,
        };
        eprintln!("measuring the flight process of {}", program.display());
        let b = heli_sim::bench::hil::run(
            seconds,
            &[program.into_os_string(), "flight".into()],
            realtime,
        )?;
        return report(&b, json, heli_sim::bench::hil::print);
    }
    report(&heli_sim::bench::run(), json, heli_sim::bench::print)
}

/// Writes to standard output; a reader that stops early (`| head`) is not an error.
/// The onboard program `heli-vehicle` beside this one, as the lab's tools fly it
/// (`heli certify`, `heli field-day`). `cargo build --release` and `cargo run --release`
/// build only this program: where the onboard one is missing, the error says how to build
/// it, or to name one.
pub(crate) fn onboard_program(option: &str) -> Result<std::path::PathBuf> {
    let exe = std::env::current_exe().context("finding this program")?;
    let onboard = exe.with_file_name("heli-vehicle");
    if !onboard.is_file() {
        bail!(
            "the onboard program {} is not built: `cargo build --release --workspace` builds it beside this one{option}",
            onboard.display()
        );
    }
    Ok(onboard)
}

fn write_stdout(text: &str) -> Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}
