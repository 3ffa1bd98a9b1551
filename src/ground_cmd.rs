//! `heli ground --link udp:HOST:PORT COMMAND`: the ground station as a command-line client
//! of the vehicle's MAVLink link (`heli_ground::client`, whose commands and downloads are the
//! display's own), or with `--http ADDR` the operator's display (`heli_ground::server`):
//! arguments in, results printed.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use heli_ground::client::Client;
use heli_ground::transfer::Which;
use heli_link::GroundCommand;
use heli_link::messages::StartParameters;
use heli_link::setup::{load_key, parse_address};
use mavlink::dialects::common::MavResult;

/// `heli ground` options.
#[derive(Args)]
pub struct GroundArgs {
    /// The vehicle's link address.
    #[arg(long, global = true, default_value = "udp:127.0.0.1:14550")]
    link: String,
    /// The signing key file shared with the vehicle (heli link keygen).
    #[arg(long, global = true, env = "HELI_LINK_KEY")]
    key: Option<PathBuf>,
    /// The link id this ground signs its frames on (1-255; default a random one per run, so
    /// that grounds signing at once never look like each other's replays).
    #[arg(long, global = true, value_parser = clap::value_parser!(u8).range(1..))]
    link_id: Option<u8>,
    /// How long to wait for the vehicle's answer (s).
    #[arg(long, global = true, default_value_t = 30.0)]
    timeout: f64,
    /// Serve the operator's display (thesis Fig. 2-4) in a browser at this address
    /// (`127.0.0.1:8080`; port 0 picks a free one) instead of running one command.
    #[arg(long)]
    http: Option<SocketAddr>,
    /// With --http: the directory the operator's base directories are under; flight logs are
    /// saved only below it.
    #[arg(long, default_value = "flights")]
    save_root: PathBuf,
    /// With --http: a host name the display may be reached by, besides IP addresses and
    /// localhost (repeatable); any other name in a request's Host is refused (DNS rebinding).
    #[arg(long)]
    allow_host: Vec<String>,
    /// With --http: the battery packs' file (docs/power.md): their names, roles and charge
    /// cycles; the time each powered the avionics is added up in FILE.times.json.
    #[arg(long)]
    packs: Option<PathBuf>,
    #[command(subcommand)]
    action: Option<GroundAction>,
}

/// What the ground does.
#[derive(Subcommand)]
pub enum GroundAction {
    /// Connect: the bootstrap starts the flight process.
    Connect,
    /// Start Logging with the flight parameters.
    Start {
        /// Suffix of this flight's log file (1-15 letters, digits, '-' or '_').
        suffix: String,
        /// Controller: manual, autonomous, rate, attitude or velocity.
        mode: String,
        /// Flight plan the vehicle knows by name (hover, demo, rolls); its default if absent.
        plan: Option<String>,
        /// Fly an augmented or autonomous flight although the vehicle's build or parameters
        /// are not the lab-tested ones (heli certify); the vehicle logs the override.
        #[arg(long)]
        override_untested: bool,
    },
    /// Stop: ends the flight on the ground. In the air the vehicle lands first when it flies
    /// (this waits for the flight to end on the skids), or refuses while the pilot flies.
    /// Then, with the final parameters, the flight's log is saved as
    /// BASE_DIR/flight_SUFFIX.mcap.
    Stop {
        /// Base directory for the flight's log.
        #[arg(long)]
        base_dir: Option<PathBuf>,
        /// File suffix for the flight's log.
        #[arg(long)]
        suffix: Option<String>,
    },
    /// Kill: ends the flight process now, in the air too — the helicopter falls. Asks for
    /// confirmation on a terminal; `--confirm` confirms beforehand (scripts).
    Kill {
        /// The operator confirms the kill (no question asked).
        #[arg(long)]
        confirm: bool,
    },
    /// The vehicle's heartbeat, telemetry and messages for a few seconds.
    Status {
        /// How long to listen (s).
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
    },
    /// The vehicle's parameters; `params set NAME VALUE` sets one (checked on board: a bad
    /// value is refused with its reason and changes nothing).
    Params {
        /// `set NAME VALUE`.
        #[arg(num_args = 0..=3)]
        set: Vec<String>,
    },
    /// The logs on the vehicle.
    Logs,
    /// Download one log.
    Download {
        /// Log id (from `heli ground logs`).
        id: u16,
        /// Where to write it.
        #[arg(long)]
        out: PathBuf,
    },
}

/// A session with the vehicle, its status texts printed as they come.
fn open(args: &GroundArgs, timeout: Duration) -> Result<Client> {
    let vehicle = parse_address(&args.link)?;
    let key = load_key(args.key.as_deref())?;
    let on_text = Box::new(|severity, text: &str| {
        eprintln!(
            "vehicle [{}]: {text}",
            heli_ground::messages::severity_word(severity)
        );
    });
    Ok(Client::open(
        vehicle,
        key,
        link_id(args)?,
        timeout,
        on_text,
    )?)
}

/// The link id to sign on: the one given, or a random one.
fn link_id(args: &GroundArgs) -> Result<u8> {
    match args.link_id {
        Some(id) => Ok(id),
        None => heli_link::setup::random_link_id()
            .map_err(|e| anyhow::anyhow!("choosing a link id (/dev/urandom): {e}")),
    }
}

/// Downloads log `which` to `out` with a progress bar.
fn download(s: &mut Client, which: Which, out: &Path) -> Result<()> {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "log {msg} {bar:40} {bytes}/{total_bytes} {bytes_per_sec} eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let name = match which {
        Which::Newest => "newest".to_string(),
        Which::Id(id) => id.to_string(),
    };
    bar.set_message(name.clone());
    let (at, bytes) = s.download(which, out, &mut |received, size| {
        bar.set_length(u64::from(size));
        bar.set_position(received);
    })?;
    bar.finish();
    if at == out {
        println!("log {name}: {bytes} bytes to {}", at.display());
    } else {
        println!(
            "log {name}: {bytes} bytes to {} ({} exists already, not overwritten)",
            at.display(),
            out.display()
        );
    }
    Ok(())
}

fn outcome(what: &str, result: MavResult) -> Result<ExitCode> {
    if result == MavResult::MAV_RESULT_ACCEPTED {
        println!("{what}: accepted");
        Ok(ExitCode::SUCCESS)
    } else {
        bail!("{what}: {result:?} (the vehicle's messages above say why)")
    }
}

/// `heli ground …`.
pub fn ground(args: &GroundArgs) -> Result<ExitCode> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        bail!("--timeout must be a positive number of seconds");
    }
    let timeout = Duration::from_secs_f64(args.timeout.min(86_400.0));
    if let Some(http) = args.http {
        if args.action.is_some() {
            bail!("--http serves the display: give no command with it");
        }
        return display(args, http);
    }
    let Some(action) = &args.action else {
        bail!(
            "give a command (connect, start, stop, status, params, logs, download) or --http ADDR for the display"
        );
    };
    let mut s = open(args, timeout)?;
    match action {
        GroundAction::Connect => outcome("connect", s.command(&GroundCommand::Connect)?),
        GroundAction::Start {
            suffix,
            mode,
            plan,
            override_untested,
        } => {
            let mut p = StartParameters::new(suffix, mode).map_err(anyhow::Error::msg)?;
            p.plan = plan.clone();
            p.override_untested = *override_untested;
            let c = GroundCommand::StartLogging(p);
            outcome("start logging", s.command(&c)?)
        }
        GroundAction::Stop { base_dir, suffix } => {
            let result = s.command(&GroundCommand::Stop)?;
            if result != MavResult::MAV_RESULT_ACCEPTED {
                return outcome("stop", result);
            }
            println!("stop: accepted");
            wait_for_the_end(&mut s, timeout)?;
            // The thesis's cleanup routine: the final parameters say where the flight's
            // log goes. The newest log on the vehicle is the flight just stopped.
            let (Some(dir), Some(suffix)) = (base_dir, suffix) else {
                return Ok(ExitCode::SUCCESS);
            };
            StartParameters::new(suffix, "manual").map_err(anyhow::Error::msg)?;
            download(
                &mut s,
                Which::Newest,
                &dir.join(format!("flight_{suffix}.mcap")),
            )?;
            Ok(ExitCode::SUCCESS)
        }
        GroundAction::Kill { confirm } => {
            if !confirm && !confirmed_on_terminal()? {
                bail!("kill: not confirmed; nothing sent");
            }
            outcome("kill", s.command(&GroundCommand::Kill)?)
        }
        GroundAction::Status { seconds } => {
            s.listen(*seconds);
            let Some((_, hb)) = s.link.heartbeat.clone() else {
                bail!(
                    "no heartbeat from {} (is `heli vehicle --link` running, with the same key?)",
                    args.link
                );
            };
            let states = [
                "idle",
                "connecting",
                "connected",
                "starting",
                "flying",
                "stopping",
            ];
            let modes = ["-", "manual", "autonomous", "rate", "attitude", "velocity"];
            let state = states.get((hb.custom_mode & 0xFF) as usize).unwrap_or(&"?");
            let mode = modes
                .get(((hb.custom_mode >> 8) & 0xFF) as usize)
                .unwrap_or(&"?");
            println!("vehicle: {:?}, bootstrap {state}, mode {mode}", hb.mavtype);
            for (id, n) in &s.link.counts {
                let name = s
                    .link
                    .latest
                    .get(id)
                    .map_or("?", |(_, m)| mavlink::Message::message_name(m));
                println!("  {name:<22} {n:>5} in {seconds:.1} s");
            }
            Ok(ExitCode::SUCCESS)
        }
        GroundAction::Params { set } => match set.as_slice() {
            [] => {
                s.params()?;
                for (name, (value, _, _)) in &s.link.params {
                    println!("{name:<16} {value}");
                }
                Ok(ExitCode::SUCCESS)
            }
            [verb, name, value] if verb == "set" => {
                let v: f32 = value
                    .parse()
                    .with_context(|| format!("param {name}: '{value}' is not a number"))?;
                let kept = s.param_set(name, v)?;
                if kept == v {
                    println!("{name} = {kept}");
                    Ok(ExitCode::SUCCESS)
                } else {
                    bail!(
                        "param {name}: refused, kept {kept} (the vehicle's message above says why)"
                    )
                }
            }
            _ => bail!("expected `params` or `params set NAME VALUE`"),
        },
        GroundAction::Logs => {
            let logs = s.logs()?;
            if logs.is_empty() {
                println!("no logs on the vehicle");
            }
            for e in logs {
                let time = if e.time_utc == 0 {
                    "time not known".to_string()
                } else {
                    heli_link::attest::utc_text(u64::from(e.time_utc))
                };
                println!("{:>4}  {:>10} bytes  {time}", e.id, e.size);
            }
            Ok(ExitCode::SUCCESS)
        }
        GroundAction::Download { id, out } => {
            download(&mut s, Which::Id(*id), out)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `heli ground --http ADDR`: the operator's display in a browser.
fn display(args: &GroundArgs, http: SocketAddr) -> Result<ExitCode> {
    let (packs, packs_totals) = match &args.packs {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("packs file {}", path.display()))?;
            let totals_path = path.with_extension("times.json");
            let totals = match std::fs::read_to_string(&totals_path) {
                Ok(t) => Some(t),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) => bail!("{}: {e}", totals_path.display()),
            };
            let log = heli_ground::pack_log::PackLog::parse(&text, totals.as_deref())
                .map_err(|e| anyhow::anyhow!("packs file {}: {e}", path.display()))?;
            (log, Some(totals_path))
        }
        None => (heli_ground::pack_log::PackLog::default(), None),
    };
    let config = heli_ground::server::ServerConfig {
        vehicle: parse_address(&args.link)?,
        http,
        allow_hosts: args.allow_host.clone(),
        station: heli_ground::station::StationConfig {
            save_root: args.save_root.clone(),
            curve: heli_ground::checks::BatteryCurve::default(),
            key: load_key(args.key.as_deref())?,
            link_id: link_id(args)?,
            packs,
            packs_totals,
        },
    };
    let link = args.link.clone();
    heli_ground::server::run(config, |served| {
        println!(
            "ground: display at {} (vehicle at {link}); Ctrl-C to stop",
            served.operator_url
        );
        println!("ground: observers (watch only) at {}", served.observer_url);
    })
    .map_err(anyhow::Error::msg)?;
    println!("ground: stopped");
    Ok(ExitCode::SUCCESS)
}

/// After an accepted Stop: a flight that lands first ends on the skids later; waits (up to
/// `timeout`, at least two minutes: a landing from 60 m) until the bootstrap is idle.
fn wait_for_the_end(s: &mut Client, timeout: Duration) -> Result<()> {
    let idle = |s: &Client| {
        s.link.heartbeat.as_ref().is_some_and(|(_, hb)| {
            heli_link::status::VehicleStatus::from_heartbeat(hb)
                .is_some_and(|v| v.state == heli_link::status::BootstrapState::Idle)
        })
    };
    let end = std::time::Instant::now() + timeout.max(Duration::from_secs(120));
    let mut said = false;
    s.listen(0.5);
    while !idle(s) {
        if !said {
            println!(
                "stop: the helicopter is in the air: landing first; waiting for the flight to end on the ground"
            );
            said = true;
        }
        if std::time::Instant::now() > end {
            bail!("stop: the flight has not ended (still landing?); its log stays on the vehicle");
        }
        s.listen(0.5);
    }
    if said {
        println!("stop: landed; the flight ended");
    }
    Ok(())
}

/// Asks the operator on the terminal to type `kill`; false without a terminal.
fn confirmed_on_terminal() -> Result<bool> {
    use std::io::{BufRead, IsTerminal, Write};
    if !std::io::stdin().is_terminal() {
        eprintln!("kill: no terminal to confirm on: give --confirm");
        return Ok(false);
    }
    eprint!(
        "kill ends the flight process now, in the air too: the helicopter FALLS.\n\
         (Stop lands it first, or is refused while the pilot flies.)\n\
         Type 'kill' to confirm: "
    );
    std::io::stderr().flush()?;
    let mut answer = String::new();
    std::io::stdin().lock().read_line(&mut answer)?;
    Ok(answer.trim() == "kill")
}
