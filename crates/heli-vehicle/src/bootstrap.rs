//! The bootstrap (thesis §2.3.1 and §4.1.3): always on, it starts and stops the flight
//! process and says what became of it.
//!
//! - Connect: a running flight process is killed, a fresh one is started as a separate OS
//!   process, and the reply waits for its `ready` line.
//! - Start Logging: the parameters go to the child's standard input; the reply waits for its
//!   `started` line.
//! - Stop: the child is told to stop. On the ground it ends the flight and exits, and the
//!   reply gives its exit status. In the air it lands first (the reply says so, the state is
//!   `landing`, and its exit follows on the skids) or refuses while the pilot flies (the
//!   reply gives the reason): a Stop never drops the helicopter. A child that answers
//!   nothing within [`STOP_TIMEOUT`] is killed.
//! - Kill (`kill confirmed`; the link's Stop with the kill code): the child ends the flight
//!   now, in the air too.
//! - Quit: as Stop; in the air the bootstrap does not quit (the reply says why).
//! - A child that exits on its own (a crash, `kill -9`) is reported at once with its exit
//!   status; a later Connect starts a fresh one.
//! - At start, a flight process that flies on since the last bootstrap died is taken back
//!   without interrupting it (`crate::adopt`); otherwise a fresh warm-start record of a flight
//!   in the air (a brown-out of the whole computer) starts one to resume it.
//!
//! The flight process speaks [`crate::supervisor`]'s messages, one a line on its standard
//! input and output; requests get typed [`Reply`]s; what the bootstrap reports is [`Said`]:
//! its own lines, the link's and the flight process's messages, each with its severity.

use std::ffi::OsString;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::PathBuf;
use std::process::{Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

use heli_fsw::core::Severity;
use heli_link::{GroundCommand, StartParameters};
use heli_types::{FlightMode, Leg};

use crate::ctl::{Reply, Request, RequestHandle};
use crate::error::VehicleError;
use crate::supervisor::{FromFlight, ProtocolError, ToFlight, VERSION};

mod child;
mod statement;

pub use statement::LabStatement;

/// How long Connect waits for the flight process's `ready`.
pub const READY_TIMEOUT: Duration = Duration::from_secs(10);
/// How long Stop waits for the flight process to clean up before killing it.
pub const STOP_TIMEOUT: Duration = Duration::from_secs(10);

/// Most flight processes the bootstrap starts again after crashes in flight within
/// [`RESTART_WINDOW`]; beyond that it gives up (a crash loop is no flight).
pub const MAX_RESTARTS: usize = 3;
/// The window of [`MAX_RESTARTS`].
pub const RESTART_WINDOW: Duration = Duration::from_secs(60);
/// A warm-start file written longer ago than this is from another flight: at power-on the
/// bootstrap resumes only a fresher one.
pub const RESUME_AFTER_POWER_ON_MAX: Duration = Duration::from_secs(60);

/// What the bootstrap runs.
#[derive(Clone, Debug)]
pub struct BootstrapConfig {
    /// The control socket to listen on (replaced if a stale one is there).
    pub socket: PathBuf,
    /// The flight process's program and arguments.
    pub child: Vec<OsString>,
    /// The flight processes' warm-start files (`crate::warm`; the log directory's and the
    /// fallback directory's): the freshest readable one, if fresh and airborne, makes the
    /// bootstrap resume the flight at power-on.
    pub warm_files: Vec<PathBuf>,
    /// The flight processes' adoption socket (`crate::adopt`): at start the bootstrap takes
    /// back a flight process that flies on there since its last bootstrap died.
    pub adopt_socket: Option<PathBuf>,
}

/// Where the bootstrap is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// No flight process.
    Idle,
    /// Started, waiting for `ready`.
    Connecting,
    /// Up, waiting for Start Logging.
    Connected,
    /// Parameters sent, waiting for `started`.
    Starting,
    /// Flying and logging.
    Flying,
    /// Told to stop, waiting for the exit.
    Stopping,
    /// Stopped in the air: the flight computer lands first; the exit follows on the ground.
    Landing,
}

impl State {
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            State::Idle => "idle",
            State::Connecting => "connecting",
            State::Connected => "connected",
            State::Starting => "starting",
            State::Flying => "flying",
            State::Stopping => "stopping",
            State::Landing => "landing",
        }
    }
}

/// What the bootstrap reports: its own lines, the link's, and the flight process's messages.
/// Printed (one line each), and sent to the ground as status texts.
#[derive(Clone, Debug, PartialEq)]
pub enum Said {
    /// A line of the bootstrap's own.
    Bootstrap {
        /// How much it matters.
        severity: Severity,
        /// What it says.
        text: String,
    },
    /// A line of the link's.
    Link {
        /// How much it matters.
        severity: Severity,
        /// What it says.
        text: String,
    },
    /// A message of the flight process.
    Flight(FromFlight),
    /// A line of the flight process that is not a message of the protocol.
    Unreadable {
        /// The line (its first 200 characters are printed).
        line: String,
        /// Why it is not one.
        error: ProtocolError,
    },
}

impl Said {
    /// How much it matters: a flight event's own severity, a refusal's warning, the
    /// bootstrap's and the link's as they said it.
    pub fn severity(&self) -> Severity {
        match self {
            Said::Bootstrap { severity, .. } | Said::Link { severity, .. } => *severity,
            Said::Flight(FromFlight::Event { severity, .. }) => *severity,
            Said::Flight(FromFlight::Refused(_)) | Said::Unreadable { .. } => Severity::WarningHi,
            Said::Flight(_) => Severity::ActivityLo,
        }
    }
}

impl std::fmt::Display for Said {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Said::Bootstrap { text, .. } => write!(f, "bootstrap: {text}"),
            Said::Link { text, .. } => write!(f, "link: {text}"),
            Said::Flight(message) => write!(f, "flight: {message}"),
            Said::Unreadable { line, error } => {
                write!(f, "flight: {line:.200} (not the protocol: {error})")
            }
        }
    }
}

/// What the bootstrap keeps told of its state and of the flight's telemetry and plan, and
/// asks whether a ground is heard: the MAVLink link's side (`crate::link::LinkShared`).
pub trait LinkPort: Send + Sync {
    /// The bootstrap's state changed; `flying` is the mode of the flight under way.
    fn set_state(&self, state: State, flying: Option<FlightMode>);
    /// The flight process's telemetry snapshot.
    fn set_telemetry(&self, values: &serde_json::Value);
    /// The flight process's plan.
    fn set_plan(&self, legs: &[Leg]);
    /// Whether a ground station has been heard in the last few seconds.
    fn ground_fresh(&self) -> bool;
    /// Whether the configuration is lab-tested (the heartbeat's fourth byte).
    fn set_tested(&self, tested: heli_link::status::Tested);
}

/// A human reading of an exit status: `exit code 0`, `signal 9 (SIGKILL)`.
pub fn describe_exit(status: ExitStatus) -> String {
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exit code {code}"),
        (None, Some(sig)) => {
            let name = nix::sys::signal::Signal::try_from(sig)
                .map(|s| s.as_str())
                .unwrap_or("?");
            format!("signal {sig} ({name})")
        }
        (None, None) => "unknown exit".to_string(),
    }
}

enum Msg {
    Request(Request, Sender<Reply>),
    FromChild(u32, Said),
    ChildExited(u32, Exit),
}

/// How a flight process ended.
#[derive(Clone, Copy, Debug)]
enum Exit {
    /// Its exit status: a process this bootstrap started.
    Status(ExitStatus),
    /// A process taken back from an earlier bootstrap: its exit status went to the init
    /// system; whether it said `stopped` before it ended.
    Adopted { said_stopped: bool },
}

impl Exit {
    fn success(self) -> bool {
        match self {
            Exit::Status(status) => status.success(),
            Exit::Adopted { said_stopped } => said_stopped,
        }
    }

    fn describe(self) -> String {
        match self {
            Exit::Status(status) => describe_exit(status),
            Exit::Adopted { said_stopped: true } => {
                "ended after saying stopped; taken back, its exit status went to the init system"
                    .into()
            }
            Exit::Adopted {
                said_stopped: false,
            } => "ended without saying stopped; taken back, its exit status is unknown".into(),
        }
    }
}

struct Child {
    generation: u32,
    pid: u32,
    /// The line to it: its standard input, or the adoption socket.
    stdin: Option<Box<dyn Write + Send>>,
}

struct Pending {
    reply: Sender<Reply>,
    until: Instant,
}

/// The supervisor.
pub struct Bootstrap {
    config: BootstrapConfig,
    state: State,
    child: Option<Child>,
    generation: u32,
    pending: Option<Pending>,
    last_exit: Option<String>,
    last_telemetry: Option<serde_json::Value>,
    /// What the flight process was last told of the link (`link fresh` / `link lost`).
    told_link: Option<bool>,
    log: Option<String>,
    report: Box<dyn FnMut(&Said)>,
    tx: Sender<Msg>,
    rx: Receiver<Msg>,
    /// Told each time the control thread has written a reply.
    written: Option<Receiver<()>>,
    /// The start of the flight under way, to start a crashed flight process again with.
    flying: Option<StartParameters>,
    /// A flight process started again is waiting for its `ready`.
    restarting: bool,
    /// When flight processes were started again, for [`MAX_RESTARTS`].
    restarts: Vec<Instant>,
    /// The MAVLink link's view of the bootstrap, when it serves one.
    link: Option<std::sync::Arc<dyn LinkPort>>,
    /// How long Connect and Start Logging wait for the flight process's answer.
    ready_timeout: Duration,
    /// How long Stop waits for the flight process to exit before killing it.
    stop_timeout: Duration,
    /// The statement of the lab attestation, on a vehicle that checks one.
    lab: Option<LabStatement>,
}

impl Bootstrap {
    /// A bootstrap that reports every change through `report`.
    pub fn new(config: BootstrapConfig, report: Box<dyn FnMut(&Said)>) -> Self {
        let (tx, rx) = channel();
        Self {
            config,
            state: State::Idle,
            child: None,
            generation: 0,
            pending: None,
            last_exit: None,
            last_telemetry: None,
            told_link: None,
            log: None,
            report,
            tx,
            rx,
            written: None,
            flying: None,
            restarting: false,
            restarts: Vec::new(),
            link: None,
            ready_timeout: READY_TIMEOUT,
            stop_timeout: STOP_TIMEOUT,
            lab: None,
        }
    }

    /// Waits `ready` for the flight process's `ready` and `started` and `stop` for its exit
    /// (defaults [`READY_TIMEOUT`] and [`STOP_TIMEOUT`]): a slow flight computer may need
    /// longer, a test less.
    pub fn with_timeouts(mut self, ready: Duration, stop: Duration) -> Self {
        self.ready_timeout = ready;
        self.stop_timeout = stop;
        self
    }

    /// Keeps `shared` told of the state and the telemetry, for the MAVLink link.
    pub fn with_link(mut self, shared: std::sync::Arc<dyn LinkPort>) -> Self {
        self.link = Some(shared);
        self
    }

    /// A handle to send this bootstrap requests from another thread.
    pub fn requests(&self) -> RequestHandle {
        let tx = self.tx.clone();
        RequestHandle::new(move |request, reply| {
            let _ = tx.send(Msg::Request(request, reply));
        })
    }

    /// Listens on the control socket and serves until `quit`.
    pub fn run(mut self) -> Result<(), VehicleError> {
        let socket = &self.config.socket;
        let listener = match crate::control_socket::bind(socket) {
            Ok(Some(listener)) => listener,
            Ok(None) => {
                return Err(VehicleError::Socket {
                    path: socket.clone(),
                    source: None,
                });
            }
            Err(crate::control_socket::BindError::Io(e)) => {
                return Err(VehicleError::Socket {
                    path: socket.clone(),
                    source: Some(e),
                });
            }
            Err(crate::control_socket::BindError::Unsafe(why)) => {
                return Err(VehicleError::Socket {
                    path: socket.clone(),
                    source: Some(std::io::Error::other(why.to_string())),
                });
            }
        };
        let handle = self.requests();
        let (written_tx, written_rx) = channel();
        self.written = Some(written_rx);
        std::thread::Builder::new()
            .name("ctl".into())
            .spawn(move || crate::ctl::serve(&listener, &handle, &written_tx))
            .map_err(|source| VehicleError::Thread {
                name: "ctl".into(),
                source,
            })?;
        self.say(
            Severity::ActivityHi,
            &format!("listening on {}", self.config.socket.display()),
        );
        self.take_back_or_resume();
        let result = self.main_loop();
        let _ = std::fs::remove_file(&self.config.socket);
        result
    }

    fn say(&mut self, severity: Severity, text: &str) {
        (self.report)(&Said::Bootstrap {
            severity,
            text: text.to_string(),
        });
    }

    fn set_state(&mut self, state: State) {
        if self.state != state {
            self.state = state;
            if let Some(link) = &self.link {
                link.set_state(state, self.flying.as_ref().map(|p| p.controller));
            }
            let pid = self.child.as_ref().map(|c| c.pid);
            match pid {
                Some(pid) => self.say(
                    Severity::ActivityLo,
                    &format!("state {} (pid {pid})", state.name()),
                ),
                None => self.say(Severity::ActivityLo, &format!("state {}", state.name())),
            }
        }
    }

    /// Tells the flight process whether a ground is heard, when that changes (and once to
    /// each new process). A vehicle without a link tells nothing: the flight core then
    /// leaves the `link` condition unjudged.
    fn tell_link_state(&mut self) {
        let Some(fresh) = self.link.as_ref().map(|l| l.ground_fresh()) else {
            return;
        };
        let running = matches!(
            self.state,
            State::Connected | State::Starting | State::Flying
        );
        if !running {
            self.told_link = None;
            return;
        }
        if self.told_link != Some(fresh) && self.tell_child(&ToFlight::Link { fresh }) {
            self.told_link = Some(fresh);
        }
    }

    fn main_loop(&mut self) -> Result<(), VehicleError> {
        loop {
            self.tell_link_state();
            self.state_lab();
            let msg = match self.rx.recv_timeout(Duration::from_millis(100)) {
                Ok(m) => Some(m),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => return Ok(()),
            };
            match msg {
                Some(Msg::Request(Request::Quit, reply)) => {
                    if let Err(why) = self.stop_child_and_wait() {
                        let _ = reply.send(Reply::refused(format!(
                            "not quitting: the helicopter is in the air and the flight goes on ({why})"
                        )));
                        continue;
                    }
                    if let Some(written) = &self.written {
                        while written.try_recv().is_ok() {}
                    }
                    let _ = reply.send(Reply::Quitting);
                    self.say(Severity::ActivityHi, "quit");
                    // Let the control thread write the reply before the process ends.
                    if let Some(written) = &self.written {
                        let _ = written.recv_timeout(Duration::from_secs(1));
                    }
                    return Ok(());
                }
                Some(Msg::Request(Request::Ground(cmd), reply)) => self.command(cmd, reply),
                Some(Msg::FromChild(generation, said)) => self.heard(generation, said),
                Some(Msg::ChildExited(generation, status)) => self.child_exited(generation, status),
                None => {}
            }
            if self
                .pending
                .as_ref()
                .is_some_and(|p| Instant::now() > p.until)
            {
                let state = self.state;
                self.answer(Reply::refused(format!("timed out while {}", state.name())));
                if matches!(state, State::Connecting | State::Stopping | State::Starting) {
                    self.kill_child();
                }
            }
        }
    }

    /// Tells the flight process to stop and waits for it (up to [`STOP_TIMEOUT`]); kills it
    /// if it does not go. `Err` with the flight computer's words when it does not stop
    /// because the helicopter is in the air (landing first, or refused): it flies on.
    fn stop_child_and_wait(&mut self) -> Result<(), String> {
        let Some(generation) = self.child.as_ref().map(|c| c.generation) else {
            return Ok(());
        };
        if self.tell_child(&ToFlight::Stop) {
            self.set_state(State::Stopping);
            let until = Instant::now().checked_add(self.stop_timeout);
            while let Some(left) = until.and_then(|u| u.checked_duration_since(Instant::now())) {
                match self.rx.recv_timeout(left) {
                    Ok(Msg::ChildExited(g, status)) if g == generation => {
                        self.child_exited(g, status);
                        return Ok(());
                    }
                    Ok(Msg::FromChild(g, said)) => {
                        let answer = match &said {
                            Said::Flight(FromFlight::Landing(why) | FromFlight::Refused(why)) => {
                                Some(why.clone())
                            }
                            _ => None,
                        };
                        // `heard` takes an answer only from the current process, and then
                        // leaves stopping (landing, or flying on): the state says it answered.
                        self.heard(g, said);
                        if self.state != State::Stopping
                            && let Some(why) = answer
                        {
                            return Err(why);
                        }
                    }
                    Ok(Msg::Request(_, reply)) => {
                        let _ = reply.send(Reply::refused("the bootstrap is quitting"));
                    }
                    Ok(Msg::ChildExited(g, status)) => self.child_exited(g, status),
                    Err(_) => break,
                }
            }
        }
        self.kill_child();
        Ok(())
    }

    fn answer(&mut self, reply: Reply) {
        if let Some(p) = self.pending.take() {
            let _ = p.reply.send(reply);
        }
    }

    fn command(&mut self, cmd: GroundCommand, reply: Sender<Reply>) {
        if self.pending.is_some() {
            let _ = reply.send(Reply::refused(format!("busy ({})", self.state.name())));
            return;
        }
        match cmd {
            GroundCommand::Connect => {
                // A new flight: nothing of the last one is resumed.
                self.flying = None;
                self.restarting = false;
                if self.child.is_some() {
                    self.say(
                        Severity::WarningLo,
                        "connect: killing the running flight process first",
                    );
                    self.kill_child();
                }
                match self.spawn_child() {
                    Ok(()) => self.wait_for(reply, self.ready_timeout, State::Connecting),
                    Err(e) => {
                        let _ = reply.send(Reply::refused(e.to_string()));
                    }
                }
            }
            GroundCommand::StartLogging(p) => {
                if self.state != State::Connected {
                    let _ = reply.send(Reply::refused(format!(
                        "not connected (state {}): send connect first",
                        self.state.name()
                    )));
                    return;
                }
                if self.tell_child(&ToFlight::Start(p.clone())) {
                    self.flying = Some(p);
                    self.wait_for(reply, self.ready_timeout, State::Starting);
                } else {
                    let _ = reply.send(Reply::refused("the flight process is not listening"));
                }
            }
            GroundCommand::Stop => {
                if self.child.is_none() {
                    let _ = reply.send(Reply::NothingToStop);
                    return;
                }
                if self.tell_child(&ToFlight::Stop) {
                    self.wait_for(reply, self.stop_timeout, State::Stopping);
                } else {
                    // Already dying: its exit is reported when it arrives.
                    self.kill_child();
                    let _ = reply.send(Reply::Killed);
                }
            }
            GroundCommand::Kill => {
                if self.child.is_none() {
                    let _ = reply.send(Reply::NothingToStop);
                    return;
                }
                self.say(
                    Severity::WarningHi,
                    "kill: ending the flight process now, in the air too",
                );
                if self.tell_child(&ToFlight::Kill) {
                    self.wait_for(reply, self.stop_timeout, State::Stopping);
                } else {
                    // Already dying: its exit is reported when it arrives.
                    self.kill_child();
                    let _ = reply.send(Reply::Killed);
                }
            }
            GroundCommand::TelemetryRequest | GroundCommand::Final(_) => {
                let status = serde_json::json!({
                    "state": self.state.name(),
                    "pid": self.child.as_ref().map(|c| c.pid),
                    "last_exit": self.last_exit,
                    "log": self.log,
                    "telemetry": self.last_telemetry,
                    "lab": self.lab_line(),
                });
                let _ = reply.send(Reply::Status(status));
            }
        }
    }

    fn wait_for(&mut self, reply: Sender<Reply>, timeout: Duration, state: State) {
        self.pending = Some(Pending {
            reply,
            until: Instant::now()
                .checked_add(timeout)
                .unwrap_or_else(Instant::now),
        });
        self.set_state(state);
    }
}
