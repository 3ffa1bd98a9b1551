//! `heli`: the command-line front of the heli avionics (DESIGN.md §7).
//!
//! The binary only parses arguments and wires the library crates together; the work is in
//! `heli-sim`, `heli-fsw` and the others.

use std::io::IsTerminal;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use heli_sim::lockstep::{RunOptions, Simulation};
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sim(args) => sim(args),
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
    let bar = show_progress.then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} sim {msg} [{bar:40}] {percent:>3}%")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let name = scenario.name.clone();
    let summary = Simulation::new(scenario).run(options, |t, total| {
        if let Some(bar) = &bar {
            bar.set_position((t / total * 1000.0) as u64);
            bar.set_message(format!("{name} t={t:>6.1} s"));
        }
    });
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
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

fn print_table(s: &Summary) {
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
            "{:<28} {:>10.3} {:>10.3}  {}",
            c.name,
            c.value,
            c.limit,
            if c.pass { "pass" } else { "FAIL" }
        );
    }
    println!();
    let e = &s.estimator;
    println!(
        "estimator  attitude error rms {:.2} deg (max {:.2}), position rms {:.2} m, velocity rms {:.2} m/s",
        e.att_err_rms_deg, e.att_err_max_deg, e.pos_err_rms_m, e.vel_err_rms_mps
    );
    let l = &s.loop_;
    println!(
        "main loop  {} IMU packets ({} dropped), {} watchdog fires, {} control steps, slowest step {:.0} us",
        l.imu_samples, l.imu_dropped, l.watchdog_fires, l.control_steps, l.step_time_max_us
    );
    println!(
        "links      imu {} frames / {} bad, uplink {} / {}, gps {} / {}, altimeter {} readings ({}), battery min {:.2} V",
        s.devices.imu.frames,
        s.devices.imu.checksum_errors,
        s.devices.uplink.frames,
        s.devices.uplink.checksum_errors,
        s.devices.gps.frames,
        s.devices.gps.checksum_errors,
        s.devices.baro_readings,
        s.devices.baro_link,
        s.devices.battery_min_v
    );
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
