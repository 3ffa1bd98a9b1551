//! The batteries, watched by the main control process (thesis §2.2.3: "power loss ... is
//! perhaps the most damaging threat to the system"): the flight battery on its analog
//! channel, the servo board's receiver battery (RTXB) and the servo battery (Sbat) from the
//! uplink, each through a fuel gauge ([`heli_power`]), and the hot-swap's digital input
//! that says whether the avionics run on the flight batteries or the ground battery.
//!
//! What is raised: a level reached (warning, then critical) with the charge and time left;
//! an abnormal drain (the field rule: "end the flight test", which the ground acts on); a
//! change of power source with the time spent on each.
//!
//! What is done, in autonomous flight (as ArduPilot's battery failsafe and PX4's do): at
//! the warning level, return to the take-off point at the present height and land there; at
//! the critical level, land where it is. A roll under way is finished first. A pilot flying
//! (manual, augmented) is told and decides. On the ground battery the flight battery's
//! channel is not judged (the flight pack is off the bus).

//!
//! A component: it owns the gauges, the levels raised and acted on and the hot-swap's log;
//! the core hands it each reading and the hot-swap's input, and asks it whether a failsafe
//! is due.

use heli_power::{FuelGauge, GaugeConfig, GaugeState, Level, PowerSource, Reading, SwapLog};

use super::battery_channel::BatteryChannel;
use super::event::CoreEvent;
use super::{Action, Stamped};
use crate::phase::Phase;

pub use super::event::Battery;

/// What the computer knows of its batteries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerConfig {
    /// The flight battery's gauge.
    pub flight: GaugeConfig,
    /// The receiver battery's gauge.
    pub receiver: GaugeConfig,
    /// The servo battery's gauge.
    pub servo: GaugeConfig,
    /// Speed of the return to the take-off point at the warning level (m/s).
    pub return_speed_mps: f64,
}

impl Default for PowerConfig {
    fn default() -> Self {
        Self {
            flight: GaugeConfig::flight(),
            receiver: GaugeConfig::receiver(),
            servo: GaugeConfig::servo(),
            return_speed_mps: 3.0,
        }
    }
}

impl PowerConfig {
    /// Every gauge told the day's temperature (°C), as the operator gives it.
    pub fn at_temperature(mut self, temperature_c: f64) -> Self {
        for g in [&mut self.flight, &mut self.receiver, &mut self.servo] {
            g.temperature_c = temperature_c;
        }
        self
    }
}

/// The batteries' watch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Power {
    gauges: [FuelGauge; 3],
    /// The level last raised for each battery.
    raised: [Level; 3],
    /// The abnormal drain raised for each battery.
    drain_raised: [bool; 3],
    /// The failsafe already taken (the worst level acted on).
    acted: Level,
    swap: SwapLog,
    /// The flight battery's ADC channel, watched before its gauge believes it.
    channel: BatteryChannel,
}

impl Power {
    /// A watch with no reading yet.
    pub fn new(config: &PowerConfig) -> Self {
        Self {
            gauges: [
                FuelGauge::new(config.flight),
                FuelGauge::new(config.receiver),
                FuelGauge::new(config.servo),
            ],
            raised: [Level::Good; 3],
            drain_raised: [false; 3],
            acted: Level::Good,
            swap: SwapLog::default(),
            channel: BatteryChannel::default(),
        }
    }

    /// The flight battery's channel at a control step: a reading overdue is raised.
    pub fn watch_channel(&mut self, now_us: u64, out: &mut Vec<Action>) {
        self.channel.watch(now_us, &mut |e| {
            out.push(Action::Event(Stamped::new(now_us, e)));
        });
    }

    /// The flight battery's channel watch.
    pub fn channel(&self) -> &BatteryChannel {
        &self.channel
    }

    /// A battery's gauge state (`None` before its first reading).
    pub fn state(&self, battery: Battery) -> Option<GaugeState> {
        self.gauges.get(battery.index()).and_then(FuelGauge::state)
    }

    /// The power source now (`None` before the hot-swap's input was read).
    pub fn source(&self) -> Option<PowerSource> {
        self.swap.source()
    }

    /// Time on the flight batteries and on the ground battery up to `now_us` (s).
    pub fn times(&self, now_us: u64) -> (f64, f64) {
        self.swap.times(now_us as f64 * 1e-6)
    }

    /// Whether any battery has been read.
    pub fn any_read(&self) -> bool {
        self.gauges.iter().any(|g| g.state().is_some())
    }

    /// The worst level of any battery.
    pub fn worst(&self) -> Level {
        self.gauges
            .iter()
            .filter_map(|g| g.state().map(|s| s.level))
            .max()
            .unwrap_or(Level::Good)
    }
}

/// The battery failsafe a level asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failsafe {
    /// Back to the take-off point at this height, and down there (the warning level).
    ReturnAndLand,
    /// Down where it is (the critical level).
    LandHere,
}

/// The warning level's plan: back to the take-off point at `height_m` (at least 2 m) at
/// `speed_mps`, then down.
pub fn return_plan(
    height_m: f64,
    speed_mps: f64,
) -> Result<heli_types::Plan, heli_types::PlanError> {
    heli_types::Plan::new(&[
        heli_types::Leg::Fly {
            north_m: 0.0,
            east_m: 0.0,
            alt_m: height_m.max(2.0),
            speed_mps,
        },
        heli_types::Leg::Land,
    ])
}

impl Power {
    /// A battery's voltage read at `now_us`: its gauge updated, a level reached or an
    /// abnormal drain raised (once each).
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn read_battery(
        &mut self,
        battery: Battery,
        volts: f64,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        // On the ground battery the flight pack is off the bus: nothing to judge.
        if battery == Battery::Flight && self.source() == Some(PowerSource::Ground) {
            // Its channel is read, though: on time, not late.
            self.channel.heard(now_us);
            return;
        }
        // The flight battery's channel is judged before its gauge: a frozen or garbled
        // reading is not the pack's.
        let volts = if battery == Battery::Flight {
            let raised = &mut |e| out.push(Action::Event(Stamped::new(now_us, e)));
            match self.channel.reading(volts, now_us, raised) {
                Some(v) => v,
                None => return,
            }
        } else {
            volts
        };
        let i = battery.index();
        let Some(gauge) = self.gauges.get_mut(i) else {
            return;
        };
        let reading = Reading {
            t_s: now_us as f64 * 1e-6,
            volts,
            current_a: None,
            temp_c: None,
        };
        // A reading that is not one was refused at the input (`input_is_finite`); one out
        // of order changes nothing.
        let Ok(state) = gauge.update(reading) else {
            return;
        };
        if let Some(raised) = self.raised.get_mut(i)
            && state.level > *raised
        {
            *raised = state.level;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::BatteryLevel {
                    battery,
                    level: state.level,
                    percent: (state.soc * 100.0).round().clamp(0.0, 100.0) as u8,
                    minutes_left: (state.time_left_s / 60.0).round().clamp(0.0, 9999.0) as u16,
                },
            )));
        }
        if let Some(drain) = self.drain_raised.get_mut(i)
            && state.draining_abnormally
            && !*drain
        {
            *drain = true;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::BatteryDrainingAbnormally { battery },
            )));
        }
    }

    /// The hot-swap's input read at `now_us`: a change of source raised with the time on
    /// each; the flight pack back on the bus starts its gauge again from its voltage.
    pub fn read_power_source(&mut self, source: PowerSource, now_us: u64, out: &mut Vec<Action>) {
        let before = self.source();
        if self.swap.update(now_us as f64 * 1e-6, source).is_none() {
            return;
        }
        if source == PowerSource::Flight && before == Some(PowerSource::Ground) {
            // The flight pack is on the bus again: its gauge starts from its voltage.
            if let Some(g) = self.gauges.get_mut(Battery::Flight.index()) {
                g.restart();
            }
        }
        let (flight_s, ground_s) = self.times(now_us);
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::PowerSource {
                source,
                flight_s,
                ground_s,
            },
        )));
    }

    /// The battery failsafe, once per level, in autonomous flight in the air (`phase`,
    /// having been `airborne_once`): return and land at the warning level, land here at
    /// the critical one. A roll under way is finished first; a landing under way goes on
    /// where it meant to (the level is taken as acted on).
    pub fn failsafe(&mut self, phase: &Phase, airborne_once: bool) -> Option<Failsafe> {
        let worst = self.worst();
        if worst <= self.acted
            || phase.rolling()
            || !airborne_once
            || !matches!(
                phase,
                Phase::TakingOff { .. }
                    | Phase::Holding { .. }
                    | Phase::Flying { .. }
                    | Phase::Maneuver { .. }
                    | Phase::Landing { .. }
            )
        {
            return None;
        }
        self.acted = worst;
        // Already landing: it goes on where it meant to.
        if matches!(phase, Phase::Landing { .. }) {
            return None;
        }
        Some(if worst == Level::Critical {
            Failsafe::LandHere
        } else {
            Failsafe::ReturnAndLand
        })
    }
}
