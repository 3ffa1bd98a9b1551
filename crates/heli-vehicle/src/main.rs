//! `heli-vehicle`: the program deployed on the flight computer. It links only what flies
//! (device formats, estimation, control, the flight core, the link and the log writer):
//! the always-on bootstrap, the flight process it starts, and each device's stand-alone
//! driver. The workstation's `heli vehicle`, `heli flight` and `heli driver` run the same
//! code.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use heli_vehicle::cli::{self, BootstrapArgs, BootstrapCommand, DriverArgs, FlightProcessArgs};

/// The onboard program of the heli avionics: without a subcommand, the bootstrap that starts
/// and stops the flight process on Connect / Stop from its control socket and its link.
#[derive(Parser)]
#[command(name = "heli-vehicle", version, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(flatten)]
    bootstrap: BootstrapArgs,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    #[command(flatten)]
    Bootstrap(BootstrapCommand),
    /// The flight process the bootstrap starts (speaks a line protocol on stdin/stdout).
    #[command(hide = true)]
    Flight(FlightProcessArgs),
    /// One device's stand-alone driver: readable lines per packet, logging with --log.
    Driver(DriverArgs),
}

fn main() -> ExitCode {
    let cli: Cli = heli_vehicle::args::parse();
    let result = match cli.command {
        None => cli::vehicle(&cli.bootstrap, None),
        Some(Command::Bootstrap(command)) => cli::vehicle(&cli.bootstrap, Some(&command)),
        Some(Command::Flight(args)) => heli_vehicle::flight_process::run(&args),
        Some(Command::Driver(args)) => cli::driver(&args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("heli-vehicle: {e:#}");
            ExitCode::from(2)
        }
    }
}
