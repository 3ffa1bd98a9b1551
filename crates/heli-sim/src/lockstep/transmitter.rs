//! The pilot's transmitter as the simulation flies it: the scripted sticks and switches, the
//! transmitter-loss windows, and the hovering pilot's hands when the auto switch is off.

use super::*;
use heli_fsw::phase::Phase;
use heli_types::FlightMode;

/// Below this height of the centre of mass (m) a pilot sees the helicopter on its skids
/// (it rests at 0.35 m).
const PILOT_SEES_ON_SKIDS_M: f64 = 0.6;

impl Simulation {
    pub(super) fn pilot(&self) -> PilotCommand {
        let t_s = self.now_us as f64 * 1e-6;
        let lost = self
            .scenario
            .faults
            .transmitter_lost
            .iter()
            .any(|[start, end]| t_s >= *start && t_s < *end);
        if let Some(live) = self.live_pilot {
            return PilotCommand {
                signal_lost: live.signal_lost || lost,
                ..live
            };
        }
        let p = &self.scenario.pilot;
        let scripted = p.scripted(self.script_t_s());
        let sticks = match self.hand_sticks {
            // The pilot hovers by hand; the scripted inputs ride on top.
            Some(hands) => Controls {
                aileron: hands.aileron + scripted.aileron - p.aileron,
                elevator: hands.elevator + scripted.elevator - p.elevator,
                rudder: hands.rudder + scripted.rudder - p.rudder,
                collective: hands.collective + scripted.collective - p.collective,
                throttle: scripted.throttle,
            }
            .clamped(),
            None => scripted,
        };
        PilotCommand {
            sticks,
            auto_mode: p.auto_at(t_s),
            bypass: p.bypass_at(t_s),
            signal_lost: lost,
        }
    }

    /// Hands the transmitter to a person (`Some`: their sticks and switches, as their
    /// transmitter sends them), or back to the scenario's scripted pilot (`None`). The
    /// receiver's faults (a frozen channel, a flickering switch, a lost signal) still act on
    /// it, and the servo controller board turns it into uplink bytes as it would a
    /// receiver's.
    pub fn set_live_pilot(&mut self, pilot: Option<PilotCommand>) {
        self.live_pilot = pilot;
    }

    /// Triggers a failure of the fault catalog from now on (the trainer's panel); returns
    /// what was done, or why it was refused.
    pub fn trigger_fault(
        &mut self,
        fault: &heli_scenario::trainer::TrainerFault,
    ) -> Result<String, heli_scenario::trainer::TrainerError> {
        let now_s = self.t_s();
        fault.apply(&mut self.scenario, now_s)
    }

    pub(super) fn pilot_of(scenario: &Scenario) -> PilotCommand {
        let p = &scenario.pilot;
        PilotCommand {
            sticks: p.scripted(0.0),
            auto_mode: p.auto_at(0.0),
            bypass: false,
            signal_lost: false,
        }
    }

    /// Where the scripted pilot is in the script (s): the flight's time less what it has
    /// waited for the mode to engage.
    pub(super) fn script_t_s(&self) -> f64 {
        self.now_us.saturating_sub(self.script_delay_us) as f64 * 1e-6
    }

    /// The scripted pilot of an augmented flight watches the mode annunciation as a pilot
    /// does: with the auto switch on, it does not begin its script (lift off, in the flights
    /// of the suite) while the flight software has not engaged the mode asked for and the
    /// helicopter is still on its skids; it waits, and flies the script from where it was
    /// once the mode engages. (Flying an augmented script's sticks in manual would be a
    /// pilot ignoring the refusal on the display.)
    fn wait_for_mode(&mut self) {
        let FlightMode::Augmented(asked) = self.scenario.mode else {
            return;
        };
        let p = &self.scenario.pilot;
        let t_s = self.now_us as f64 * 1e-6;
        let script_t_s = self.script_t_s();
        let script_begun = p.inputs.iter().any(|i| i.start_s <= script_t_s);
        let engaged = self.core().phase() == Phase::Augmented(asked);
        let on_skids = -self.heli.state.pos_ned_m.z < PILOT_SEES_ON_SKIDS_M;
        if p.auto_at(t_s) && script_begun && !engaged && on_skids {
            self.script_delay_us += UPLINK_PERIOD_US;
        }
    }

    /// The hovering pilot's hands, at the uplink rate, while the auto switch is off.
    pub(super) fn move_hands(&mut self) {
        if self.live_pilot.is_none() {
            self.wait_for_mode();
        }
        let t_s = self.now_us as f64 * 1e-6;
        let p = &self.scenario.pilot;
        if !p.hovers_in_manual || p.auto_at(t_s) {
            self.hand_sticks = None;
            self.hands.release();
            return;
        }
        let s = self.heli.state;
        let truth = seen_by_pilot(
            self.now_us,
            s.att,
            s.vel_ned_mps(),
            s.pos_ned_m,
            s.rate_body_rps,
        );
        self.hand_sticks = Some(self.hands.sticks(&truth, UPLINK_PERIOD_US as f64 * 1e-6));
    }
}
