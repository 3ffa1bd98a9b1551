//! The ground station, sans-I/O: the link's ground end ([`GroundLink`]) with everything the
//! operator's display needs — the panel of §2.4, the rows of Fig. 2-4, the battery meter, the
//! GPS indicator, the message area, the safety checks of §4.3, the operators' control token
//! and the log transfer after Stop. Datagrams, operators' requests and the time go in;
//! datagrams to send, files to save and a [`View`] come out. The web server
//! ([`crate::server`]) is only its I/O.

use std::path::{Path, PathBuf};

use heli_link::ground::GroundLink;
use heli_link::signing::Key;
use heli_link::status::{BootstrapState, VehicleStatus};
use heli_types::FlightMode;
use mavlink::dialects::common::*;

use crate::checks::BatteryCurve;
use crate::command::{InFlight, Progress};
use crate::messages::MessageArea;
use crate::operators::{ClientId, Operators};
use crate::panel::Panel;
use crate::refusal::SaveError;
use crate::transfer::Transfer;

mod requests;
pub use requests::{Op, Request, StartForm};

/// A command with no final answer for this long (µs) is given up.
pub const COMMAND_TIMEOUT_US: u64 = 30_000_000;
/// The ground's heartbeat period (µs).
const HEARTBEAT_US: u64 = 1_000_000;
/// No heartbeat from the vehicle for this long (µs): the panel forgets its state.
const VEHICLE_LOST_US: u64 = 5_000_000;

/// How the station is set up.
#[derive(Clone, Debug)]
pub struct StationConfig {
    /// The directory the operator's base directories are under (logs are saved only below
    /// it).
    pub save_root: PathBuf,
    /// The flight battery's discharge curve (the meter).
    pub curve: BatteryCurve,
    /// The link's signing key.
    pub key: Option<Key>,
    /// The link id this station signs on (its own: another ground's frames are another
    /// stream).
    pub link_id: u8,
    /// The packs' logbook (`--packs FILE`; empty without one).
    pub packs: crate::pack_log::PackLog,
    /// Where the packs' totals are saved.
    pub packs_totals: Option<PathBuf>,
}

/// What the station wants done.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// Send this datagram to the vehicle.
    Send(Vec<u8>),
    /// Save these bytes at this path (then call [`Station::saved`]).
    Save(PathBuf, Vec<u8>),
    /// Write these bytes over the file at this path (the packs' totals).
    Write(PathBuf, Vec<u8>),
}

/// A command on its way.
#[derive(Clone, Debug)]
pub(crate) struct Pending {
    command: InFlight,
    name: &'static str,
    /// For Stop: where the log goes.
    dest: Option<PathBuf>,
    /// For Start Logging: the flight's parameters.
    params: Option<FlightParams>,
    /// What the vehicle said of it (`start logging: …` status text).
    said: Option<String>,
}

/// The ground station.
pub struct Station {
    /// The link's ground end.
    pub link: GroundLink,
    pub(crate) config: StationConfig,
    pub(crate) panel: Panel,
    pub(crate) operators: Operators,
    pub(crate) pending: Option<Pending>,
    pub(crate) transfer: Option<Transfer>,
    pub(crate) messages: MessageArea,
    texts_seen: usize,
    pub(crate) chosen: FlightMode,
    heartbeat_sent_us: Option<u64>,
    outbox: Vec<Vec<u8>>,
    /// When our last command was answered: heartbeats from before say the old state.
    answered_us: u64,
    /// A flight was seen under way since the station started or since the last Stop.
    flight_seen: bool,
    /// The field rule's message, until acknowledged.
    pub(crate) field_rule: crate::power_view::FieldRule,
    /// The packs' logbook.
    pub(crate) packs: crate::pack_log::PackLog,
    /// Files to write at the next tick.
    pub(crate) writes: Vec<(PathBuf, Vec<u8>)>,
    /// The ground's time at the last input (µs), and at the first: the message area's clock.
    now_us: u64,
    first_us: Option<u64>,
    /// The last command and what became of it.
    pub(crate) command: Option<CommandView>,
    /// The parameters of the flight this station started, until its Stop: every page shows
    /// them, not its own form's, and the log a Stop with final parameters saves must be the
    /// flight of their suffix.
    pub(crate) flight_params: Option<FlightParams>,
    /// The vehicle's last refusals of the flight under way, in its words.
    pub(crate) refusals: Refusals,
    /// The vehicle's last lab statement (`crate::lab`).
    pub(crate) lab_statement: Option<String>,
    /// Suffixes the vehicle has a log of, as far as this station knows (the flights it
    /// started, and those the vehicle refused as existing).
    suffixes_used: std::collections::BTreeSet<String>,
    /// A Stop in the air was answered "landing first": the flight ends on the ground, and
    /// then its log is saved where the final parameters said (`None`: not saved).
    landing_then_save: Option<Option<PathBuf>>,
}

/// The vehicle's last words refusing a take-off or a mode (cleared at each Start Logging).
#[derive(Clone, Debug, Default)]
pub(crate) struct Refusals {
    /// `take-off refused: …`.
    pub(crate) takeoff: Option<String>,
    /// `velocity flight refused: …`.
    pub(crate) mode: Option<String>,
}

/// The last command sent to the vehicle and its outcome, as every page shows it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CommandView {
    /// connect, start logging or stop.
    pub name: &'static str,
    /// sent, accepted, refused or unanswered.
    pub outcome: &'static str,
    /// What the vehicle said of it (its reason when refused).
    pub text: String,
}

/// The parameters of the flight under way, as sent at Start Logging.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FlightParams {
    /// The log file suffix.
    pub suffix: String,
    /// The controller's name.
    pub controller: &'static str,
    /// The plan's name (empty: the vehicle's default).
    pub plan: String,
    /// The flight pack named (empty: none).
    pub pack: String,
}

impl Station {
    /// A station on a link signed with the configuration's key.
    pub fn new(config: StationConfig) -> Self {
        Self {
            link: GroundLink::on_link(config.key.clone(), config.link_id),
            packs: config.packs.clone(),
            writes: Vec::new(),
            config,
            panel: Panel::default(),
            operators: Operators::default(),
            pending: None,
            transfer: None,
            messages: MessageArea::default(),
            texts_seen: 0,
            chosen: FlightMode::Manual,
            heartbeat_sent_us: None,
            outbox: Vec::new(),
            answered_us: 0,
            flight_seen: false,
            field_rule: crate::power_view::FieldRule::default(),
            now_us: 0,
            first_us: None,
            command: None,
            flight_params: None,
            refusals: Refusals::default(),
            lab_statement: None,
            suffixes_used: Default::default(),
            landing_then_save: None,
        }
    }

    /// The ground's time moves to `now_us` (every input says it).
    fn clock(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        self.first_us.get_or_insert(now_us);
    }

    /// The ground's time at the last input (µs).
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Seconds since the station's first input (the message area's times).
    pub fn session_s(&self) -> f64 {
        self.now_us
            .saturating_sub(self.first_us.unwrap_or(self.now_us)) as f64
            / 1e6
    }

    /// Adds a line to the message area.
    pub fn note(&mut self, severity: &'static str, text: impl Into<String>) {
        let now_s = self.session_s();
        self.messages.push(severity, "ground", text.into(), now_s);
    }

    /// Every message kept, oldest change first (for a page opened late).
    pub fn message_history(&self) -> Vec<crate::messages::Message> {
        self.messages.newest(usize::MAX)
    }

    /// A datagram from the vehicle.
    pub fn receive(&mut self, datagram: &[u8], now_us: u64) {
        self.clock(now_us);
        self.link.receive(datagram, now_us);
        self.take_texts();
    }

    /// The vehicle's new status texts into the message area.
    fn take_texts(&mut self) {
        let new: Vec<(MavSeverity, String)> = self
            .link
            .texts
            .iter()
            .skip(self.texts_seen)
            .cloned()
            .collect();
        self.texts_seen = self.link.texts.len();
        let now_s = self.session_s();
        for (severity, text) in new {
            self.field_rule.see(&text);
            if let Some(statement) = crate::lab::statement_of(&text) {
                self.lab_statement = Some(statement.to_string());
            }
            if let Some(i) = text.find("take-off refused") {
                self.refusals.takeoff = text.get(i..).map(str::to_string);
            } else if let Some(i) = text.find(" flight refused: ") {
                // `… t=12.00 s velocity flight refused: …`: from the mode's name on.
                let start = text
                    .get(..i)
                    .and_then(|head| head.rfind(' '))
                    .map_or(0, |k| k.saturating_add(1));
                self.refusals.mode = text.get(start..).map(str::to_string);
            }
            // The vehicle's word on the command under way (`start logging: …`): its reason
            // when it refuses.
            if let Some(p) = self.pending.as_mut()
                && let Some(said) = text.strip_prefix(p.name).and_then(|r| r.strip_prefix(": "))
            {
                p.said = Some(said.to_string());
            }
            self.messages.push(
                crate::messages::severity_word(severity),
                "vehicle",
                text,
                now_s,
            );
        }
    }

    /// The vehicle's status from its last heartbeat, if recent.
    pub fn vehicle_status(&self, now_us: u64) -> Option<VehicleStatus> {
        let (at, hb) = self.link.heartbeat.as_ref()?;
        (now_us.saturating_sub(*at) < VEHICLE_LOST_US)
            .then(|| VehicleStatus::from_heartbeat(hb))
            .flatten()
    }

    /// One step: the heartbeat, the command under way, the log transfer.
    pub fn tick(&mut self, now_us: u64) -> Vec<Output> {
        self.clock(now_us);
        let mut out: Vec<Output> = self
            .writes
            .drain(..)
            .map(|(p, b)| Output::Write(p, b))
            .collect();
        if self
            .heartbeat_sent_us
            .is_none_or(|t| now_us.saturating_sub(t) >= HEARTBEAT_US)
        {
            out.push(Output::Send(self.link.heartbeat_frame(now_us)));
            self.heartbeat_sent_us = Some(now_us);
        }
        self.link.flush_texts(now_us);
        self.take_texts();
        // The heartbeat is the truth, once it is newer than our last command's answer.
        let heard_after = self
            .link
            .heartbeat
            .as_ref()
            .is_some_and(|(t, _)| *t >= self.answered_us);
        if heard_after || self.vehicle_status(now_us).is_none() {
            let status = self.vehicle_status(now_us);
            self.panel.vehicle(status.map(|s| s.state));
        }
        if heard_after {
            self.landed_after_stop(now_us);
            self.flight_ended_alone(now_us);
        }
        // A flight seen under way: its log is the newest on the vehicle, the one a Stop with
        // final parameters saves.
        // (A heartbeat from before our last command's answer says the old state: a Stop's
        // answer is not undone by the "flying" heartbeat sent just before it.)
        if heard_after
            && self
                .vehicle_status(now_us)
                .is_some_and(|s| s.state == BootstrapState::Flying)
        {
            self.flight_seen = true;
        }
        // What has been shown is not kept twice: texts once in the message area, answers
        // once no command waits for them.
        self.link.texts.clear();
        self.texts_seen = 0;
        if self.pending.is_none() {
            self.link.acks.clear();
        }
        // The flight's plan, fetched once per flight over the mission protocol.
        if self
            .vehicle_status(now_us)
            .is_some_and(|s| s.state == BootstrapState::Flying)
        {
            if let Some(frame) = self.link.mission_tick(now_us) {
                out.push(Output::Send(frame));
            }
        } else {
            self.link.mission.restart();
        }
        self.command_tick(now_us, &mut out);
        if let Some(mut transfer) = self.transfer.take() {
            let step = transfer.tick(&mut self.link, now_us);
            out.extend(step.frames.into_iter().map(Output::Send));
            for n in step.notes {
                self.note(if step.failed { "error" } else { "info" }, n);
            }
            if let Some((path, bytes)) = step.save {
                out.push(Output::Save(path, bytes));
            }
            if !step.done {
                self.transfer = Some(transfer);
            }
        }
        out
    }

    /// A flight that ended without this station's Stop (stopped on the vehicle's console, or
    /// its process gone and not restarted; in `heli sim --ui`, the simulated helicopter
    /// crashed): its log is saved all the same, where a Stop would have put it
    /// (`flight_SUFFIX.mcap` under the save root), and the operator is told.
    fn flight_ended_alone(&mut self, now_us: u64) {
        let idle = self
            .vehicle_status(now_us)
            .is_some_and(|s| s.state == BootstrapState::Idle);
        if !(idle && self.flight_seen && self.pending.is_none() && self.transfer.is_none()) {
            return;
        }
        self.flight_seen = false;
        let suffix = self.flight_params.take().map(|f| f.suffix);
        let mut dest = self.config.save_root.clone();
        dest.push(format!(
            "flight_{}.mcap",
            suffix.as_deref().unwrap_or("unnamed")
        ));
        let whither = match &suffix {
            Some(_) => dest.display().to_string(),
            None => format!(
                "{} (named by the suffix in the log)",
                self.config.save_root.display()
            ),
        };
        self.note(
            "warning",
            format!("the flight ended on the vehicle without Stop: saving its log to {whither}"),
        );
        self.packs_end();
        self.transfer = Some(match suffix {
            Some(s) => Transfer::of_flight(dest, Some(s), now_us),
            // Not started here: saved under the suffix its own log names.
            None => Transfer::of_unnamed_flight(dest, now_us),
        });
    }

    /// A Stop's landing is over (the vehicle is idle): the flight ended on the ground; its
    /// log is saved where the Stop's final parameters said.
    fn landed_after_stop(&mut self, now_us: u64) {
        let idle = self
            .vehicle_status(now_us)
            .is_some_and(|s| s.state == BootstrapState::Idle);
        if !(idle && self.pending.is_none()) {
            return;
        }
        let Some(dest) = self.landing_then_save.take() else {
            return;
        };
        self.flight_seen = false;
        let suffix = self.flight_params.take().map(|f| f.suffix);
        self.note("info", "stop: landed; the flight ended on the ground");
        if let Some(dest) = dest {
            self.transfer = Some(Transfer::of_flight(dest, suffix, now_us));
        }
    }

    fn command_tick(&mut self, now_us: u64, out: &mut Vec<Output>) {
        let Some(mut p) = self.pending.take() else {
            return;
        };
        let (progress, retry) = p.command.tick(&mut self.link, now_us);
        out.extend(retry.map(Output::Send));
        match progress {
            Progress::Answered(r) => self.answered(&p, r, now_us),
            Progress::TimedOut => {
                self.panel.answered();
                self.command = Some(CommandView {
                    name: p.name,
                    outcome: "unanswered",
                    text: format!(
                        "no answer from the vehicle in {} s",
                        COMMAND_TIMEOUT_US / 1_000_000
                    ),
                });
                self.note(
                    "error",
                    format!(
                        "{}: no answer from the vehicle in {} s",
                        p.name,
                        COMMAND_TIMEOUT_US / 1_000_000
                    ),
                );
            }
            Progress::Waiting => self.pending = Some(p),
        }
    }

    fn answered(&mut self, p: &Pending, result: MavResult, now_us: u64) {
        self.panel.answered();
        self.answered_us = now_us;
        let accepted = result == MavResult::MAV_RESULT_ACCEPTED;
        let word = if accepted {
            "accepted".to_string()
        } else {
            format!("{result:?}")
                .trim_start_matches("MAV_RESULT_")
                .to_lowercase()
        };
        let said = p.said.clone().unwrap_or_default();
        self.note(
            if accepted { "info" } else { "error" },
            if accepted || said.is_empty() {
                format!("{}: {word}", p.name)
            } else {
                format!("{}: {word}: {said}", p.name)
            },
        );
        self.command = Some(CommandView {
            name: p.name,
            outcome: if accepted { "accepted" } else { "refused" },
            text: if said.is_empty() { word } else { said.clone() },
        });
        match (p.name, accepted) {
            ("connect", true) => self.panel.vehicle(Some(BootstrapState::Connected)),
            ("start logging", true) => {
                self.panel.vehicle(Some(BootstrapState::Flying));
                self.flight_seen = true;
                self.suffixes_used
                    .extend(p.params.as_ref().map(|f| f.suffix.clone()));
                self.flight_params = p.params.clone();
            }
            ("start logging", false) => {
                if said.contains("exists") {
                    self.suffixes_used
                        .extend(p.params.as_ref().map(|f| f.suffix.clone()));
                }
                self.panel.logging_failed();
                self.note("error", "logging failed: press Stop to reset the display");
            }
            // In the air: the flight ends (and its log is saved) once it has landed.
            ("stop", true) if said.contains(heli_link::messages::LANDING_FIRST) => {
                self.landing_then_save = Some(p.dest.clone());
                self.note(
                    "warning",
                    "stop: the helicopter is in the air and lands where it is first; the flight ends, and its log is saved, on the ground",
                );
            }
            ("stop", true) => {
                self.panel.vehicle(Some(BootstrapState::Idle));
                self.flight_seen = false;
                let suffix = self.flight_params.take().map(|f| f.suffix);
                if let Some(dest) = p.dest.clone() {
                    self.transfer = Some(Transfer::of_flight(dest, suffix, now_us));
                }
            }
            _ => {}
        }
    }

    /// A page joins; returns its id.
    pub fn join(&mut self) -> ClientId {
        self.operators.join()
    }

    /// A page opened with the observer's key joins (it watches, never commands); returns
    /// its id.
    pub fn join_observer(&mut self) -> ClientId {
        self.operators.join_observer()
    }

    /// A page leaves.
    pub fn leave(&mut self, id: ClientId) {
        self.operators.leave(id);
    }

    /// The runtime saved (or failed to save) a transferred log asked for at `path`; it says
    /// where it went (another name when a file of that name exists).
    pub fn saved(&mut self, path: &Path, result: Result<PathBuf, SaveError>) {
        match result {
            Ok(at) if at == path => self.note("info", format!("log saved: {}", at.display())),
            Ok(at) => self.note(
                "info",
                format!(
                    "log saved: {} ({} exists already, not overwritten)",
                    at.display(),
                    path.display()
                ),
            ),
            Err(e) => self.note("error", format!("log not saved to {}: {e}", path.display())),
        }
    }

    /// Frames a request produced, to send now.
    pub fn take_outbox(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.outbox)
    }
}
