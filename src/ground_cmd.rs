//! `heli ground --link udp:HOST:PORT COMMAND`: the ground station as a command-line client
//! of the vehicle's MAVLink link (the same client library, `heli_link::ground`, as the web
//! display that `--http ADDR` serves, `heli_ground::server`). Connect, Start Logging, Stop (with the final parameters: the
//! flight's log is downloaded into the base directory under the suffix), status, the log
//! list and downloads.

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use heli_link::GroundCommand;
use heli_link::command::command_long;
use heli_link::ground::{COMMAND_RETRY_US, GroundLink};
use heli_link::messages::StartParameters;
use heli_vehicle::link::unix_us;
use mavlink::dialects::common::MavResult;

use heli_link::setup::{load_key, parse_address as parse_link};

/// `heli ground` options.
#[derive(Args)]
pub struct GroundArgs {
    /// The vehicle's link address.
    #[arg(long, global = true, default_value = "udp:127.0.0.1:14550")]
    link: String,
    /// The signing key file shared with the vehicle (heli link keygen).
    #[arg(long, global = true, env = "HELI_LINK_KEY")]
    key: Option<PathBuf>,
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
    },
    /// Stop; then, with the final parameters, the flight's log is saved as
    /// BASE_DIR/flight_SUFFIX.mcap.
    Stop {
        /// Base directory for the flight's log.
        #[arg(long)]
        base_dir: Option<PathBuf>,
        /// File suffix for the flight's log.
        #[arg(long)]
        suffix: Option<String>,
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

/// A ground station session on a socket.
struct Session {
    socket: UdpSocket,
    vehicle: SocketAddr,
    link: GroundLink,
    last_heartbeat: Option<Instant>,
    texts_shown: usize,
}

impl Session {
    fn open(args: &GroundArgs) -> Result<Self> {
        let vehicle = parse_link(&args.link)?;
        let key = load_key(args.key.as_deref())?;
        let bind: SocketAddr = if vehicle.is_ipv4() {
            "0.0.0.0:0".parse()?
        } else {
            "[::]:0".parse()?
        };
        let socket = UdpSocket::bind(bind).context("opening a UDP socket")?;
        // Datagrams from the vehicle's address only.
        socket
            .connect(vehicle)
            .with_context(|| format!("link {}", args.link))?;
        socket.set_read_timeout(Some(Duration::from_millis(10)))?;
        Ok(Self {
            socket,
            vehicle,
            link: GroundLink::new(key),
            last_heartbeat: None,
            texts_shown: 0,
        })
    }

    fn send(&self, datagram: &[u8]) {
        let _ = self.socket.send(datagram);
    }

    /// One turn: heartbeat when due, receive what came, print new status texts.
    fn pump(&mut self) {
        if self
            .last_heartbeat
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(1))
        {
            let hb = self.link.heartbeat_frame(unix_us());
            self.send(&hb);
            self.last_heartbeat = Some(Instant::now());
        }
        // Wait up to the socket's timeout for the first datagram, then take all that came
        // without waiting again.
        let mut buf = [0u8; 2048];
        let _ = self.socket.set_nonblocking(false);
        while let Ok(n) = self.socket.recv(&mut buf) {
            self.link.receive(buf.get(..n).unwrap_or(&[]), unix_us());
            let _ = self.socket.set_nonblocking(true);
        }
        self.link.flush_texts(unix_us());
        for (severity, text) in self.link.texts.iter().skip(self.texts_shown) {
            eprintln!(
                "vehicle [{}]: {text}",
                heli_ground::view::severity_word(*severity)
            );
        }
        self.texts_shown = self.link.texts.len();
        if let Some(dl) = self.link.download_tick(unix_us()) {
            self.send(&dl);
        }
    }

    /// Sends a command until it is acknowledged with a final result, or `timeout` passes.
    /// Retries carry a rising `confirmation`, so the vehicle answers them without carrying
    /// the command out twice; after `IN_PROGRESS` they go slowly, to recover a lost final
    /// acknowledgement.
    fn command(&mut self, command: &GroundCommand, timeout: Duration) -> Result<MavResult> {
        let mut long = command_long(command, (1, 1))
            .context("this command or its parameters cannot go over the link")?;
        let id = long.command;
        let start = Instant::now();
        let acks_before = self.link.acks.len();
        let mut sent: Option<Instant> = None;
        let mut in_progress = false;
        while start.elapsed() < timeout {
            let retry = if in_progress {
                Duration::from_secs(2)
            } else {
                Duration::from_micros(COMMAND_RETRY_US)
            };
            if sent.is_none_or(|t| t.elapsed() >= retry) {
                let frame = self.link.command_frame(long.clone(), unix_us());
                self.send(&frame);
                sent = Some(Instant::now());
                long.confirmation = long.confirmation.saturating_add(1);
            }
            self.pump();
            for (c, r) in self.link.acks.iter().skip(acks_before) {
                if *c == id {
                    if *r == MavResult::MAV_RESULT_IN_PROGRESS {
                        in_progress = true;
                    } else {
                        return Ok(*r);
                    }
                }
            }
        }
        bail!(
            "no answer from the vehicle at {} within {:.0} s{}",
            self.vehicle,
            timeout.as_secs_f64(),
            if self.link.heartbeat.is_none() {
                " (no heartbeat either: is `heli vehicle --link` running there, with the same key?)"
            } else {
                ""
            }
        )
    }

    fn listen(&mut self, seconds: f64) {
        let end = Instant::now() + Duration::from_secs_f64(seconds.clamp(0.0, 3600.0));
        while Instant::now() < end {
            self.pump();
        }
    }

    fn param_list(&mut self, timeout: Duration) -> Result<()> {
        let start = Instant::now();
        let mut asked: Option<Instant> = None;
        while start.elapsed() < timeout {
            if asked.is_none_or(|t| t.elapsed() > Duration::from_secs(1)) {
                let frame = self.link.param_list_frame(unix_us());
                self.send(&frame);
                asked = Some(Instant::now());
            }
            self.pump();
            let count = self
                .link
                .params
                .values()
                .next()
                .map(|(_, _, n)| usize::from(*n));
            if count.is_some_and(|n| self.link.params.len() >= n) {
                return Ok(());
            }
        }
        bail!(
            "the vehicle's parameters did not arrive within {:.0} s",
            timeout.as_secs_f64()
        )
    }

    fn param_set(&mut self, name: &str, value: f32, timeout: Duration) -> Result<f32> {
        let start = Instant::now();
        let mut asked: Option<Instant> = None;
        let texts_before = self.link.texts.len();
        self.link.params.remove(name);
        while start.elapsed() < timeout {
            if asked.is_none_or(|t| t.elapsed() > Duration::from_secs(1)) {
                let frame = self.link.param_set_frame(name, value, unix_us());
                self.send(&frame);
                asked = Some(Instant::now());
            }
            self.pump();
            if let Some((kept, _, _)) = self.link.params.get(name) {
                return Ok(*kept);
            }
            if self
                .link
                .texts
                .iter()
                .skip(texts_before)
                .any(|(_, t)| t.contains("no such parameter"))
            {
                bail!("param {name}: the vehicle has no such parameter");
            }
        }
        bail!(
            "param {name}: no answer within {:.0} s",
            timeout.as_secs_f64()
        )
    }

    fn log_list(&mut self, timeout: Duration) -> Result<()> {
        let frame = self.link.log_list_frame(unix_us());
        self.send(&frame);
        let start = Instant::now();
        let mut asked = Instant::now();
        while start.elapsed() < timeout {
            self.pump();
            let want = self
                .link
                .log_entries
                .values()
                .next()
                .map(|e| usize::from(e.num_logs));
            if want
                .is_some_and(|n| self.link.log_entries.values().filter(|e| e.id > 0).count() >= n)
            {
                return Ok(());
            }
            if asked.elapsed() > Duration::from_secs(1) {
                let frame = self.link.log_list_frame(unix_us());
                self.send(&frame);
                asked = Instant::now();
            }
        }
        bail!(
            "the vehicle's log list did not arrive within {:.0} s",
            timeout.as_secs_f64()
        )
    }

    fn download(&mut self, id: u16, out: &Path, timeout: Duration) -> Result<()> {
        self.log_list(timeout)?;
        let Some(entry) = self
            .link
            .log_entries
            .get(&id)
            .cloned()
            .filter(|e| e.num_logs > 0)
        else {
            bail!("the vehicle has no log {id} (heli ground logs lists them)");
        };
        let bar = indicatif::ProgressBar::new(u64::from(entry.size));
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "log {msg} {bar:40} {bytes}/{total_bytes} {bytes_per_sec} eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(id.to_string());
        let req = self.link.start_download(id, entry.size, unix_us());
        self.send(&req);
        let mut last_progress = Instant::now();
        let mut received = 0;
        loop {
            self.pump();
            let Some(dl) = self.link.download.as_ref() else {
                break;
            };
            if dl.received() != received {
                received = dl.received();
                last_progress = Instant::now();
                bar.set_position(received);
            }
            if dl.complete() {
                break;
            }
            if last_progress.elapsed() > timeout {
                bail!(
                    "log {id}: nothing new for {:.0} s ({received} of {} bytes)",
                    timeout.as_secs_f64(),
                    entry.size
                );
            }
        }
        bar.finish();
        let end = self.link.log_end_frame(unix_us());
        self.send(&end);
        let bytes = self
            .link
            .download
            .take()
            .map(|d| d.bytes)
            .unwrap_or_default();
        if let Some(dir) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        std::fs::write(out, &bytes).with_context(|| format!("writing {}", out.display()))?;
        println!("log {id}: {} bytes to {}", bytes.len(), out.display());
        Ok(())
    }
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
    let mut s = Session::open(args)?;
    match action {
        GroundAction::Connect => outcome("connect", s.command(&GroundCommand::Connect, timeout)?),
        GroundAction::Start { suffix, mode, plan } => {
            let mut p = StartParameters::new(suffix, mode).map_err(anyhow::Error::msg)?;
            p.plan = plan.clone();
            let c = GroundCommand::StartLogging(p);
            outcome("start logging", s.command(&c, timeout)?)
        }
        GroundAction::Stop { base_dir, suffix } => {
            let result = s.command(&GroundCommand::Stop, timeout)?;
            if result != MavResult::MAV_RESULT_ACCEPTED {
                return outcome("stop", result);
            }
            println!("stop: accepted");
            // The thesis's cleanup routine: the final parameters say where the flight's
            // log goes. The newest log on the vehicle is the flight just stopped.
            let (Some(dir), Some(suffix)) = (base_dir, suffix) else {
                return Ok(ExitCode::SUCCESS);
            };
            StartParameters::new(suffix, "manual").map_err(anyhow::Error::msg)?;
            s.log_list(timeout)?;
            let newest = s
                .link
                .log_entries
                .values()
                .filter(|e| e.id > 0)
                .max_by_key(|e| (e.time_utc, e.id))
                .map(|e| e.id)
                .context("the vehicle has no log to save")?;
            s.download(newest, &dir.join(format!("flight_{suffix}.mcap")), timeout)?;
            Ok(ExitCode::SUCCESS)
        }
        GroundAction::Status { seconds } => {
            s.listen(*seconds);
            let Some((_, hb)) = s.link.heartbeat.clone() else {
                bail!(
                    "no heartbeat from {} (is `heli vehicle --link` running, with the same key?)",
                    s.vehicle
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
                s.param_list(timeout)?;
                for (name, (value, _, _)) in &s.link.params {
                    println!("{name:<16} {value}");
                }
                Ok(ExitCode::SUCCESS)
            }
            [verb, name, value] if verb == "set" => {
                let v: f32 = value
                    .parse()
                    .with_context(|| format!("param {name}: '{value}' is not a number"))?;
                let kept = s.param_set(name, v, timeout)?;
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
            s.log_list(timeout)?;
            let logs: Vec<_> = s.link.log_entries.values().filter(|e| e.id > 0).collect();
            if logs.is_empty() {
                println!("no logs on the vehicle");
            }
            for e in logs {
                println!("{:>4}  {:>10} bytes  time {}", e.id, e.size, e.time_utc);
            }
            Ok(ExitCode::SUCCESS)
        }
        GroundAction::Download { id, out } => {
            s.download(*id, out, timeout)?;
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
        vehicle: parse_link(&args.link)?,
        http,
        station: heli_ground::station::StationConfig {
            save_root: args.save_root.clone(),
            curve: heli_ground::checks::BatteryCurve::default(),
            key: load_key(args.key.as_deref())?,
            packs,
            packs_totals,
        },
    };
    let link = args.link.clone();
    heli_ground::server::run(config, |addr| {
        println!("ground: display at http://{addr}/ (vehicle at {link}); Ctrl-C to stop");
    })
    .map_err(anyhow::Error::msg)?;
    println!("ground: stopped");
    Ok(ExitCode::SUCCESS)
}
