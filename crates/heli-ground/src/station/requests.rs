//! The operators' requests to the station: what a page asks ([`Request`], [`Op`], Start
//! Logging's [`StartForm`]), who may ask it (the control token), and the commands it sends
//! to the vehicle once the ground's own checks (the field rule, the pack, the parameters,
//! the plan, the lab's statement, the final parameters) have passed.

use std::path::{Component, Path, PathBuf};

use heli_link::command::PLANS;
use heli_link::status::{BootstrapState, VehicleStatus};
use heli_link::{GroundCommand, StartParameters};
use serde::Deserialize;

use super::{COMMAND_TIMEOUT_US, CommandView, FlightParams, Pending, Refusals, Station};
use crate::command::InFlight;
use crate::operators::ClientId;
use crate::panel::PanelState;
use crate::refusal::{FinalProblem, Refusal};

/// An operator's request, as the page sends it (JSON).
#[derive(Clone, Debug, Deserialize)]
pub struct Request {
    /// Rises with every request of a page.
    pub seq: u64,
    /// What is asked.
    #[serde(flatten)]
    pub op: Op,
}

/// What an operator asks.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "op", rename_all = "kebab-case")]
pub enum Op {
    /// Take the control token.
    Take,
    /// Give it back.
    Release,
    /// Connect.
    Connect,
    /// Start Logging with the flight parameters.
    Start(StartForm),
    /// Acknowledge the field rule's message (a pack drained abnormally: the flight test is
    /// over), which blocks Start Logging until then.
    Acknowledge,
    /// Whether Start Logging with these parameters would be sent and taken (nothing is
    /// sent): the page asks as the operator types.
    CheckStart(StartForm),
    /// Acknowledge the pinned errors and critical messages, every one changed up to `upto`
    /// (the newest the page has shown).
    AcknowledgeMessages {
        /// The newest message change seen (`seq`).
        upto: u64,
    },
    /// Kill: end the flight process now, in the air too (the helicopter falls); sent only
    /// with `confirmed`, which the page sets after the operator typed the word.
    Kill {
        /// The operator confirmed it.
        #[serde(default)]
        confirmed: bool,
    },
    /// Stop, with the final parameters (both absent: no log transfer).
    Stop {
        /// Base directory, below the station's save root.
        #[serde(default)]
        base_dir: Option<String>,
        /// File suffix of the saved log.
        #[serde(default)]
        suffix: Option<String>,
    },
}

/// Start Logging's form, as the page sends it.
#[derive(Clone, Debug, Deserialize)]
pub struct StartForm {
    /// The log file suffix.
    pub suffix: String,
    /// The controller's name.
    pub controller: String,
    /// The flight plan's name (empty or absent: the vehicle's default).
    #[serde(default)]
    pub plan: Option<String>,
    /// The flight pack installed, as the packs file names it (absent: not said).
    #[serde(default)]
    pub pack: Option<String>,
    /// The operator's override: fly an augmented or autonomous flight on a configuration
    /// the vehicle says is not lab-tested (the page asks first).
    #[serde(default)]
    pub override_untested: bool,
}

impl Station {
    /// An operator's request (JSON text) from page `client`: what was done, or why nothing
    /// was. The refusals of the operator in control are noted in the message area too; a
    /// watching page's go only to that page.
    pub fn request(
        &mut self,
        client: ClientId,
        text: &str,
        now_us: u64,
    ) -> Result<String, Refusal> {
        self.clock(now_us);
        let req: Result<Request, _> = serde_json::from_str(text).map_err(Refusal::Malformed);
        // A check of Start Logging's form is the page's question, not an event of the field.
        let quiet = matches!(
            &req,
            Ok(Request {
                op: Op::CheckStart(_),
                ..
            })
        );
        let result = req.and_then(|req| self.request_inner(client, req, now_us));
        if let Err(e) = &result
            && !quiet
            && self.operators.holder() == Some(client)
        {
            let mut line = format!("operator {client}: {e}");
            if line.len() > 200 {
                let cut = (0..=200)
                    .rev()
                    .find(|i| line.is_char_boundary(*i))
                    .unwrap_or(0);
                line.truncate(cut);
                line.push('…');
            }
            // The operator's own mistake, answered in red on the page: kept as a warning
            // (not pinned as a fault of the vehicle or the station would be).
            self.note("warning", line);
        }
        result
    }

    fn request_inner(
        &mut self,
        client: ClientId,
        req: Request,
        now_us: u64,
    ) -> Result<String, Refusal> {
        self.operators.accept(client, req.seq)?;
        match req.op {
            Op::Take => self
                .operators
                .take(client)
                .map(|()| "you are in control".to_string())
                .map_err(Refusal::from),
            Op::Release => {
                self.operators.release(client);
                Ok("control released".into())
            }
            Op::Acknowledge => {
                self.operators.may_command(client)?;
                match self.field_rule.acknowledge() {
                    Some(text) => {
                        self.note("info", format!("acknowledged: {text}"));
                        Ok("acknowledged: Start Logging is allowed again".into())
                    }
                    None => Err(Refusal::NothingToAcknowledge),
                }
            }
            Op::CheckStart(form) => self.start_check(&form).map(|p| {
                let mut ok = format!("Start Logging would send flight_{}", p.file_suffix);
                if let Some(wait) = self.takeoff_wait(p.controller) {
                    ok.push_str(&format!("; the take-off would wait: {wait}"));
                }
                ok
            }),
            Op::AcknowledgeMessages { upto } => {
                self.operators.may_command(client)?;
                match self.messages.acknowledge(upto) {
                    0 => Err(Refusal::NothingToAcknowledge),
                    n => {
                        let text = format!(
                            "operator {client} acknowledged {n} pinned message{}",
                            if n == 1 { "" } else { "s" }
                        );
                        self.note("info", text.clone());
                        Ok(text)
                    }
                }
            }
            op => {
                self.operators.may_command(client)?;
                self.command(op, now_us)
            }
        }
    }

    fn command(&mut self, op: Op, now_us: u64) -> Result<String, Refusal> {
        if self.pending.is_some() {
            return Err(Refusal::CommandPending);
        }
        let state = self.panel.state();
        let (connect, start, stop) = state.buttons();
        let mut started = None;
        let (command, name, meanwhile, dest) = match op {
            Op::Connect if connect => (
                GroundCommand::Connect,
                "connect",
                PanelState::Connecting,
                None,
            ),
            Op::Start(form) if start => {
                let p = self.start_check(&form)?;
                let pack = form.pack;
                self.packs_begin(pack.as_deref())?;
                self.chosen = p.controller;
                self.refusals = Refusals::default();
                started = Some(FlightParams {
                    suffix: p.file_suffix.clone(),
                    controller: p.controller.name(),
                    plan: p.plan.clone().unwrap_or_default(),
                    pack: pack.clone().unwrap_or_default(),
                });
                (
                    GroundCommand::StartLogging(p),
                    "start logging",
                    PanelState::Starting,
                    None,
                )
            }
            Op::Stop { base_dir, suffix } if stop => {
                let dest = self.final_parameters(base_dir, suffix)?;
                if dest.is_some() && !self.flight_seen {
                    return Err(Refusal::FinalParameters(FinalProblem::NoFlight));
                }
                if dest.is_some() && self.transfer.is_some() {
                    return Err(Refusal::FinalParameters(FinalProblem::TransferUnderWay));
                }
                // Logging failed and no flight under way (the vehicle refused the start and
                // waits, connected, or is idle): only the display is reset.
                if state == PanelState::LoggingFailed
                    && self.vehicle_status(now_us).is_none_or(|s| {
                        matches!(s.state, BootstrapState::Idle | BootstrapState::Connected)
                    })
                {
                    self.panel.reset();
                    self.note("info", "display reset");
                    return Ok("display reset".into());
                }
                self.panel.reset();
                self.packs_end();
                (GroundCommand::Stop, "stop", PanelState::Stopping, dest)
            }
            Op::Kill { confirmed } if state.kill_active() => {
                if !confirmed {
                    return Err(Refusal::KillUnconfirmed);
                }
                self.landing_then_save = None;
                (GroundCommand::Kill, "kill", PanelState::Stopping, None)
            }
            other => {
                return Err(Refusal::NotActive {
                    button: match other {
                        Op::Connect => "Connect",
                        Op::Start(_) | Op::CheckStart(_) => "Start Logging",
                        Op::Acknowledge | Op::AcknowledgeMessages { .. } => "Acknowledge",
                        Op::Kill { .. } => "Kill",
                        _ => "Stop",
                    },
                    panel: state.name(),
                });
            }
        };
        let (sent, frame) = InFlight::send(&mut self.link, &command, COMMAND_TIMEOUT_US, now_us)
            .ok_or(Refusal::TooLongForTheLink)?;
        self.note("info", format!("{name}: sent"));
        self.command = Some(CommandView {
            name,
            outcome: "sent",
            text: String::new(),
        });
        self.pending = Some(Pending {
            command: sent,
            name,
            dest,
            params: started,
            said: None,
        });
        self.panel.sent(meanwhile);
        self.outbox.push(frame);
        Ok(format!("{name}: sent"))
    }

    /// What Start Logging would send, or why the ground or the vehicle would refuse it:
    /// the field rule, the pack, the parameters, the plan, a suffix already logged.
    fn start_check(&self, form: &StartForm) -> Result<StartParameters, Refusal> {
        let StartForm {
            suffix,
            controller,
            plan,
            pack,
            override_untested,
        } = form;
        if let Some(why) = self.field_rule.blocks_start() {
            return Err(Refusal::FieldRule(why));
        }
        self.packs.check(pack.as_deref()).map_err(Refusal::Pack)?;
        let mut p =
            StartParameters::new(suffix.trim(), controller.trim()).map_err(Refusal::Parameters)?;
        let plan = plan.clone().filter(|p| !p.trim().is_empty());
        if let Some(name) = plan.as_deref()
            && !PLANS.contains(&name)
        {
            return Err(Refusal::UnknownPlan(name.to_string()));
        }
        if self.suffixes_used.contains(&p.file_suffix) {
            return Err(Refusal::SuffixUsed(p.file_suffix));
        }
        p.plan = plan;
        let tested = self
            .link
            .heartbeat
            .as_ref()
            .and_then(|(_, hb)| VehicleStatus::from_heartbeat(hb))
            .map(|s| s.tested)
            .unwrap_or_default();
        if let Some(why) = crate::lab::needs_override(
            tested,
            self.lab_statement.as_deref(),
            p.controller,
            *override_untested,
        ) {
            return Err(Refusal::Untested(why));
        }
        p.override_untested = *override_untested;
        Ok(p)
    }

    /// The path a stopped flight's log is saved at, from the final parameters: both or
    /// neither; the base directory relative, below the save root.
    fn final_parameters(
        &self,
        base_dir: Option<String>,
        suffix: Option<String>,
    ) -> Result<Option<PathBuf>, Refusal> {
        let refuse = |problem| Err(Refusal::FinalParameters(problem));
        let base_dir = base_dir.filter(|s| !s.trim().is_empty());
        let suffix = suffix.filter(|s| !s.trim().is_empty());
        let (base, suffix) = match (base_dir, suffix) {
            (None, None) => return Ok(None),
            (Some(b), Some(s)) => (b, s),
            _ => {
                return refuse(FinalProblem::OnlyOne);
            }
        };
        if let Err(e) = StartParameters::new(suffix.trim(), "manual") {
            return refuse(FinalProblem::Suffix(e));
        }
        let rel = Path::new(base.trim());
        if !rel
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
        {
            return refuse(FinalProblem::NotBelowRoot {
                base,
                root: self.config.save_root.clone(),
            });
        }
        // `.` parts say nothing: the path is said without them (`day1`, not `./day1/.`).
        let mut dest: PathBuf = self
            .config
            .save_root
            .components()
            .chain(rel.components())
            .filter(|c| !matches!(c, Component::CurDir))
            .collect();
        dest.push(format!("flight_{}.mcap", suffix.trim()));
        Ok(Some(dest))
    }

    /// Start Logging names flight pack `pack`: refused if the packs file does not have it.
    pub(crate) fn packs_begin(&mut self, pack: Option<&str>) -> Result<(), Refusal> {
        self.packs.begin(pack).map_err(Refusal::Pack)
    }

    /// Stop: the flight's times from the vehicle's hot-swap log are added to its packs, and
    /// the totals saved.
    pub(crate) fn packs_end(&mut self) {
        let named = |name: &str| self.link.named.get(name).map(|(_, v)| f64::from(*v));
        let (flight_s, ground_s) = (named("PWR_FLT_S"), named("PWR_GND_S"));
        if let Some(text) = self.packs.end(flight_s, ground_s) {
            self.note("info", text);
            if let Some(path) = self.config.packs_totals.clone() {
                self.writes.push((path, self.packs.totals_json()));
            }
        }
    }
}
