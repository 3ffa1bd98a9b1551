//! `heli sim --ui`: the whole system in one command, as separate processes like on the field —
//! the HILSim on pseudo-terminals (`heli hilsim --ptys`), the vehicle's bootstrap on them
//! serving the signed MAVLink link on loopback (`heli vehicle --link`), and the ground
//! station's display (`heli ground --http`) — with the URL of the display printed, and all
//! of it stopped cleanly on Ctrl-C. Each process's output goes to a file in the run's
//! directory. The processes are the workstation program's own subcommands
//! ([`UiOptions::program`]).

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use std::io::{Error, Result};

/// Adds what was being done to an error.
fn context(what: impl std::fmt::Display) -> impl FnOnce(Error) -> Error {
    move |e| Error::new(e.kind(), format!("{what}: {e}"))
}

/// What `heli sim --ui` runs.
pub struct UiOptions {
    /// The workstation program whose subcommands are the processes (`heli`).
    pub program: PathBuf,
    /// The HILSim's scenario (the world, the pilot, the faults).
    pub scenario: String,
    /// Where the display is served.
    pub http: String,
    /// The vehicle's bias calibration (s).
    pub calibration_s: f64,
}

/// One of the system's processes.
struct Proc {
    name: &'static str,
    child: Child,
    /// Its output lines until it is ready (then dropped: the log file keeps them).
    lines: Option<Receiver<String>>,
    /// The lines read until it was ready.
    seen: Vec<String>,
    log: PathBuf,
    /// The log's length (bytes) when this run began.
    log_from: u64,
    /// The thread copying its error output to the log (joined to read an ended one's last
    /// words).
    err_copier: Option<std::thread::JoinHandle<()>>,
}

impl Proc {
    /// Starts `heli ARGS` in its own process group (Ctrl-C reaches only `heli sim --ui`,
    /// which stops the others in order), its output copied to `DIR/NAME.log`. Its pages are
    /// served with the session's keys, so that a simulator started again keeps them open.
    fn spawn(
        program: &Path,
        name: &'static str,
        dir: &Path,
        args: &[String],
        keys: &PageKeys,
    ) -> Result<Self> {
        use std::os::unix::process::CommandExt;
        let log = dir.join(format!("{name}.log"));
        // Appended to: a process started again (the simulator after a crash) adds to it.
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .map_err(context(format!("creating {}", log.display())))?;
        // Where this run's lines begin (a process started again appends to its log).
        let log_from = file.metadata().map_or(0, |m| m.len());
        let mut child = Command::new(program)
            .args(args)
            .env(heli_web::gate::KEY_ENV, &keys.operator)
            .env(heli_web::gate::OBSERVER_KEY_ENV, &keys.observer)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
            .map_err(context(format!("starting heli {name}")))?;
        let (tx, lines) = channel();
        let out = child.stdout.take();
        let err = child.stderr.take();
        let mut err_file = file.try_clone()?;
        std::thread::spawn(move || {
            if let Some(out) = out {
                for line in BufReader::new(out).lines().map_while(Result::ok) {
                    let _ = writeln!(file, "{line}");
                    let _ = tx.send(line);
                }
            }
        });
        let err_copier = std::thread::spawn(move || {
            if let Some(err) = err {
                for line in BufReader::new(err).lines().map_while(Result::ok) {
                    let _ = writeln!(err_file, "{line}");
                }
            }
        });
        Ok(Self {
            name,
            child,
            lines: Some(lines),
            seen: Vec::new(),
            log,
            log_from,
            err_copier: Some(err_copier),
        })
    }

    /// Waits for a line containing `needle`, then stops collecting lines; fails if the
    /// process ends first or `stop` is set (Ctrl-C).
    fn wait_for(&mut self, needle: &str, timeout: Duration, stop: &AtomicBool) -> Result<String> {
        let end = Instant::now() + timeout;
        let Some(lines) = self.lines.take() else {
            return Err(Error::other(format!(
                "heli {}: its output is no longer read",
                self.name
            )));
        };
        while Instant::now() < end {
            if stop.load(Ordering::Relaxed) {
                return Err(Error::other(format!(
                    "interrupted while heli {} was starting",
                    self.name
                )));
            }
            match lines.recv_timeout(Duration::from_millis(100)) {
                Ok(line) if line.contains(needle) => return Ok(line),
                Ok(line) => self.seen.push(line),
                Err(_) => {
                    if let Some(status) = self.child.try_wait()? {
                        let said = self.last_words();
                        return Err(Error::other(format!(
                            "heli {} ended ({status}) before it was ready{said}: see {}",
                            self.name,
                            self.log.display()
                        )));
                    }
                }
            }
        }
        Err(Error::other(format!(
            "heli {} was not ready within {timeout:?}: see {}",
            self.name,
            self.log.display()
        )))
    }

    /// The last lines an ended process wrote to its error output (`: …`), once its copying
    /// thread has written them to the log; nothing if it said nothing.
    fn last_words(&mut self) -> String {
        if let Some(copier) = self.err_copier.take() {
            let _ = copier.join();
        }
        // This run's lines only: an earlier run's are in the same file before them.
        let text = std::fs::read(&self.log)
            .ok()
            .and_then(|all| {
                let from = usize::try_from(self.log_from).ok()?;
                all.get(from..)
                    .map(|b| String::from_utf8_lossy(b).into_owned())
            })
            .unwrap_or_default();
        let said: Vec<&str> = text
            .lines()
            .filter(|l| !l.trim().is_empty() && !self.seen.iter().any(|s| s == l))
            .collect();
        let last = said.get(said.len().saturating_sub(3)..).unwrap_or_default();
        if last.is_empty() {
            String::new()
        } else {
            format!(": {}", last.join(" / "))
        }
    }

    /// Sends SIGTERM and waits up to `grace` before killing it.
    fn terminate(&mut self, grace: Duration) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = Command::new("kill")
                .args(["-TERM", &self.child.id().to_string()])
                .status();
        }
        self.wait_or_kill(grace);
    }

    fn wait_or_kill(&mut self, grace: Duration) {
        let end = Instant::now() + grace;
        while Instant::now() < end {
            if self.child.try_wait().ok().flatten().is_some() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        eprintln!(
            "heli sim --ui: {} did not stop in {grace:?}: killed",
            self.name
        );
        // The whole process group: the vehicle's flight process goes with its bootstrap.
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.child.id())])
            .status();
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn free_udp_port() -> Result<u16> {
    Ok(std::net::UdpSocket::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

/// Runs the whole system until Ctrl-C (or SIGTERM), or until one of its processes ends.
pub fn run(options: &UiOptions) -> Result<ExitCode> {
    if !(options.calibration_s.is_finite() && (1.0..=600.0).contains(&options.calibration_s)) {
        return Err(Error::other("--calibration-s must be between 1 and 600 s"));
    }
    let program = options.program.as_path();
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .map_err(context("installing the signal handler"))?;
    }
    // A fresh directory of our own (it holds the link's key): made here, not found.
    let dir = std::env::temp_dir().join(format!("heli-ui-{}", std::process::id()));
    std::fs::create_dir(&dir).map_err(context(format!("creating {}", dir.display())))?;
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))
            .map_err(context(format!("restricting {}", dir.display())))?;
    }
    std::fs::create_dir(dir.join("logs"))
        .map_err(context(format!("creating {}", dir.display())))?;
    let dir_s = dir.display().to_string();
    let key = dir.join("link.key");
    let key_s = key.display().to_string();
    heli_link::setup::keygen(&key, false).map_err(Error::other)?;
    let link = format!("udp:127.0.0.1:{}", free_udp_port()?);
    let dev = format!("{dir_s}/dev");
    let keys = PageKeys::new()?;
    let mut procs: Vec<Proc> = Vec::new();
    let hil_args = |view: &str| {
        strings(&[
            "hilsim",
            "--ptys",
            &dev,
            "--scenario",
            &options.scenario,
            "--duration",
            "86400",
            "--view",
            view,
            "--pilot",
        ])
    };
    let started = (|| -> Result<(String, String, String)> {
        let mut hil = Proc::spawn(program, "hilsim", &dir, &hil_args("127.0.0.1:0"), &keys)?;
        hil.wait_for("hilsim: ready", Duration::from_secs(20), &stop)?;
        // Printed before "ready".
        let view = hil
            .seen
            .iter()
            .find(|l| l.contains("hilsim: view"))
            .cloned()
            .unwrap_or_default();
        procs.push(hil);
        let calibration = options.calibration_s.to_string();
        let mut vehicle = Proc::spawn(
            program,
            "vehicle",
            &dir,
            &strings(&[
                "vehicle",
                "--hilsim",
                &dev,
                "--log-dir",
                &format!("{dir_s}/logs"),
                "--socket",
                &format!("{dir_s}/ctl.sock"),
                "--calibration-s",
                &calibration,
                "--link",
                &link,
                "--key",
                &key_s,
                // The simulator is a lab bench: its build is not certified, and its
                // flights fly on the bench's standing override (each says so).
                "--fly-untested",
            ]),
            &keys,
        )?;
        vehicle.wait_for("bootstrap: listening", Duration::from_secs(20), &stop)?;
        procs.push(vehicle);
        let mut ground = Proc::spawn(
            program,
            "ground",
            &dir,
            &strings(&[
                "ground",
                "--link",
                &link,
                "--key",
                &key_s,
                "--http",
                &options.http,
                "--save-root",
                &format!("{dir_s}/flights"),
            ]),
            &keys,
        )?;
        // The operator's address, then the observers' (the line after it).
        let observers = ground.wait_for("ground: observers", Duration::from_secs(20), &stop)?;
        let line = ground
            .seen
            .iter()
            .find(|l| l.contains("ground: display at"))
            .cloned()
            .unwrap_or_default();
        procs.push(ground);
        let url_in = |line: &str, log: &str| {
            line.split_whitespace()
                .find(|w| w.starts_with("http://"))
                .unwrap_or(log)
                .to_string()
        };
        Ok((
            url_in(&line, "(see ground.log)"),
            url_in(&observers, "(see ground.log)"),
            url_in(&view, "(see hilsim.log)"),
        ))
    })();
    let (url, observer_url, view_url) = match started {
        Ok(urls) => urls,
        Err(e) => {
            shut_down(program, &mut procs, &dir_s);
            return Err(e);
        }
    };
    println!("heli sim --ui: the display is at {url}");
    println!("  observers (watch only, another key) at {observer_url}");
    println!("  open it, Take control, Connect, then Start Logging (autonomous, plan demo):");
    println!(
        "  the vehicle calibrates for {} s, takes off, hovers, rolls, flies home and lands",
        options.calibration_s
    );
    println!(
        "  HILSim scenario {}; vehicle link {link} (key {key_s})",
        options.scenario
    );
    println!("  the simulator's truth in 3D (not the estimate) is at {view_url}");
    println!(
        "    (fly it yourself there: 'take the transmitter', gamepad or keyboard; trainer's failures)"
    );
    println!("  processes' output, logs and saved flights in {dir_s}");
    println!("  Ctrl-C stops everything");
    let _ = std::io::stdout().flush();
    // The simulator is started again on the same view address after it ends.
    let view_addr = view_url
        .trim_start_matches("http://")
        .split('/')
        .next()
        .unwrap_or_default()
        .to_string();
    let ctl_socket = format!("{dir_s}/ctl.sock");
    let mut code = ExitCode::SUCCESS;
    while !stop.load(Ordering::Relaxed) {
        let ended = procs
            .iter_mut()
            .position(|p| p.child.try_wait().ok().flatten().is_some());
        // The simulator ended (its helicopter crashed, or its time ran out): that ends the
        // flight, not the station. The flight is ended on the vehicle — killed, since the
        // world it flew in is gone and a Stop would wait for a landing — (its log closed; the
        // ground station saves it, as for any flight ended without its Stop) and a new
        // simulator stands ready for the next Connect.
        if let Some(i) = ended
            && procs.get(i).is_some_and(|p| p.name == "hilsim")
            && let Some(hil) = procs.get_mut(i)
        {
            println!(
                "heli sim --ui: the simulator ended ({}): stopping the vehicle's flight; the ground station saves its log",
                outcome_in(&hil.log)
            );
            ctl(program, &["kill", "confirmed"], &ctl_socket);
            match Proc::spawn(program, "hilsim", &dir, &hil_args(&view_addr), &keys).and_then(
                |mut p| {
                    p.wait_for("hilsim: ready", Duration::from_secs(20), &stop)
                        .map(|_| p)
                },
            ) {
                Ok(p) => {
                    *hil = p;
                    println!(
                        "heli sim --ui: a new simulator is ready at {view_url}: Connect and Start Logging for the next flight"
                    );
                    let _ = std::io::stdout().flush();
                    continue;
                }
                Err(e) => {
                    eprintln!("heli sim --ui: the simulator could not be started again: {e}");
                    code = ExitCode::FAILURE;
                    break;
                }
            }
        }
        if let Some(p) = ended.and_then(|i| procs.get(i)) {
            eprintln!(
                "heli sim --ui: heli {} ended on its own: see {}",
                p.name,
                p.log.display()
            );
            code = ExitCode::FAILURE;
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    shut_down(program, &mut procs, &dir_s);
    Ok(code)
}

/// What the simulator's log says of how its run ended: its `outcome` line, or its last.
fn outcome_in(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    lines
        .iter()
        .rev()
        .find(|l| l.trim_start().starts_with("outcome"))
        .or(lines.last())
        .map_or_else(
            || "no word in its log".to_string(),
            |l| l.split_whitespace().collect::<Vec<_>>().join(" "),
        )
}

/// Stops the display, then the vehicle (its flight process ends and closes its log), then
/// the HILSim.
fn shut_down(program: &Path, procs: &mut [Proc], dir: &str) {
    println!("heli sim --ui: stopping");
    for p in procs.iter_mut().rev() {
        if p.name == "vehicle" && p.child.try_wait().ok().flatten().is_none() {
            // The simulation ends: its flight with it (a bootstrap does not quit while its
            // helicopter is in the air).
            let socket = format!("{dir}/ctl.sock");
            ctl(program, &["kill", "confirmed"], &socket);
            ctl(program, &["quit"], &socket);
            p.wait_or_kill(Duration::from_secs(10));
        } else {
            p.terminate(Duration::from_secs(5));
        }
    }
    println!("heli sim --ui: stopped; everything it wrote is in {dir}");
}

/// The session's page keys: every server of the session, and a simulator started again,
/// serve their pages with them (`heli_web::gate`).
struct PageKeys {
    operator: String,
    observer: String,
}

impl PageKeys {
    fn new() -> Result<Self> {
        Ok(Self {
            operator: heli_web::gate::new_key().map_err(Error::other)?,
            observer: heli_web::gate::new_key().map_err(Error::other)?,
        })
    }
}

/// `heli vehicle ctl WORDS --socket SOCKET`, its answer not wanted.
fn ctl(program: &Path, words: &[&str], socket: &str) {
    let _ = Command::new(program)
        .args(["vehicle", "ctl"])
        .args(words)
        .args(["--socket", socket])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
}
