//! The simulator's side of the view (`heli hilsim --view ADDR [--pilot]`): its truth to the
//! view's pages, with the scenario's flight plan; with `--pilot`, the pages' transmitter and
//! the trainer's failures back into the simulation.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use heli_proto::scb::Controls;
use heli_scenario::Scenario;
use heli_scenario::trainer::TrainerFault;
use heli_types::Transmitter;

use super::{TruthFeed, ViewInput};
use crate::devices::scb::PilotCommand;
use crate::lockstep::Simulation;

/// How often a frame is taken from the simulation (wall clock): the pages get 30 a second.
pub const FRAME_EVERY: Duration = Duration::from_millis(30);

/// A page holding the transmitter that sends nothing for this long has lost its signal, as
/// a receiver loses a transmitter switched off (the page sends 50 frames a second).
pub const PILOT_SILENT: Duration = Duration::from_millis(500);

/// How many of the trainer's messages each frame carries.
const LOG_KEPT: usize = 20;

/// Serves the view for `scenario` on `addr` and prints its URL; with `pilot`, also returns
/// the cockpit that takes the pages' transmitter and failures.
pub fn serve(
    addr: SocketAddr,
    scenario: &Scenario,
    pilot: bool,
) -> std::io::Result<(TruthFeed, Option<Cockpit>)> {
    // The plan's legs, into the points the display draws.
    let plan = heli_link::mission::plan_points(&heli_link::mission::mission_items(&scenario.plan));
    let setup = serde_json::json!({
        "type": "setup",
        "scenario": scenario.name,
        "plan": plan,
        "pilot": pilot,
        "transmitter": {
            "auto": scenario.pilot.auto,
            "throttle": scenario.pilot.throttle,
        },
    });
    let (tx, rx) = channel();
    let control = pilot.then_some(tx);
    let (served, feed) = super::spawn(addr, setup.to_string(), control)?;
    println!(
        "hilsim: view {} (the simulator's truth)",
        served.operator_url
    );
    println!("hilsim: observers (watch only) at {}", served.observer_url);
    if pilot {
        println!("hilsim: pilot in the loop: fly from the view's page (gamepad or keyboard)");
    }
    Ok((feed, pilot.then(|| Cockpit::new(rx))))
}

/// Publishes the simulation's truth now, with the cockpit's messages.
pub fn publish(feed: &TruthFeed, sim: &Simulation, cockpit: Option<&Cockpit>) {
    let frame = sim.truth_frame();
    if let Ok(mut value) = serde_json::to_value(frame) {
        if let Some(map) = value.as_object_mut() {
            map.insert("type".into(), "truth".into());
            // When this state was taken (the workstation's clock, ms since 1970): the page
            // shows the latency from the simulator's state to its frame on screen.
            let taken_ms = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64() * 1e3);
            map.insert("taken_unix_ms".into(), taken_ms.into());
            if let Some(c) = cockpit {
                let log: Vec<serde_json::Value> = c
                    .log
                    .iter()
                    .map(|(t, m)| serde_json::json!({"t_s": t, "message": m}))
                    .collect();
                map.insert("trainer".into(), log.into());
            }
        }
        feed.publish(value.to_string());
    }
}

/// The pages' side of the transmitter and the trainer's panel, applied to the simulation
/// between its steps.
pub struct Cockpit {
    inputs: Receiver<ViewInput>,
    /// When the holding page last sent its sticks (None: the scenario's pilot flies).
    last_frame: Option<Instant>,
    /// The last sticks and switches the page sent.
    held: Option<PilotCommand>,
    signal_lost: bool,
    /// What happened, newest last: (simulated time, message).
    log: VecDeque<(f64, String)>,
}

fn command(f: &Transmitter) -> PilotCommand {
    PilotCommand {
        sticks: Controls {
            aileron: f.aileron,
            elevator: f.elevator,
            rudder: f.rudder,
            collective: f.collective,
            throttle: f.throttle,
        },
        auto_mode: f.auto,
        bypass: f.bypass,
        signal_lost: false,
    }
}

impl Cockpit {
    fn new(inputs: Receiver<ViewInput>) -> Self {
        Self {
            inputs,
            last_frame: None,
            held: None,
            signal_lost: false,
            log: VecDeque::new(),
        }
    }

    fn say(&mut self, t_s: f64, message: String) {
        println!("hilsim: t={t_s:.2} s {message}");
        self.log.push_back((t_s, message));
        while self.log.len() > LOG_KEPT {
            self.log.pop_front();
        }
    }

    /// Takes what the pages sent since the last step into `sim`.
    pub fn apply(&mut self, sim: &mut Simulation) {
        let t_s = sim.now_us() as f64 * 1e-6;
        while let Ok(input) = self.inputs.try_recv() {
            match input {
                ViewInput::Pilot(frame) => {
                    if self.held.is_none() {
                        self.say(t_s, "pilot: the page has the transmitter".into());
                    }
                    if self.signal_lost {
                        self.signal_lost = false;
                        self.say(t_s, "pilot: transmitter signal back".into());
                    }
                    let cmd = command(&frame);
                    self.held = Some(cmd);
                    self.last_frame = Some(Instant::now());
                    sim.set_live_pilot(Some(cmd));
                }
                ViewInput::Release => {
                    if self.held.take().is_some() {
                        self.say(
                            t_s,
                            "pilot: transmitter back to the scenario's pilot".into(),
                        );
                    }
                    self.last_frame = None;
                    self.signal_lost = false;
                    sim.set_live_pilot(None);
                }
                // Taken: the first sticks say so.
                ViewInput::Take => {}
                ViewInput::Gone => {
                    if self.held.is_some() {
                        self.say(t_s, "pilot: the page holding the transmitter closed".into());
                    }
                }
                ViewInput::Fault(json) => {
                    let said = TrainerFault::parse(&json).and_then(|f| sim.trigger_fault(&f));
                    match said {
                        Ok(what) => self.say(t_s, format!("trainer: {what}")),
                        Err(why) => self.say(t_s, format!("trainer: refused: {why}")),
                    }
                }
            }
        }
        // A page that holds the transmitter and went quiet: the receiver loses the signal.
        if let (Some(cmd), Some(last)) = (self.held, self.last_frame)
            && !self.signal_lost
            && last.elapsed() > PILOT_SILENT
        {
            self.signal_lost = true;
            self.say(
                t_s,
                "pilot: the page went silent, transmitter signal lost".into(),
            );
            sim.set_live_pilot(Some(PilotCommand {
                signal_lost: true,
                ..cmd
            }));
        }
    }
}
