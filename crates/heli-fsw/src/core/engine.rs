//! The engine-failure response: the rotor's speed, read by the servo controller board's
//! tachometer, watched in the air; when it falls fast below a fraction of the governed
//! speed, or stays below a lower one, the engine has failed (the governor would hold it otherwise), the event is raised as
//! fatal, and an autonomous or augmented flight autorotates to the ground
//! (`heli_control::autorotation`), at once, from whatever attitude: a roll under way is
//! not finished (its collective would spend the rotor's speed), the autorotation rights
//! the helicopter by the shortest way first. A pilot
//! flying by hand (auto switch off, or the bypass) is told and keeps flying: autorotating a
//! helicopter is what the thesis's safety pilot trained for.
//!
//! A component: it owns the rotor's recent speeds, the failure once raised and the
//! autorotation under way; the core hands it the rotor's speed at each control step, the
//! phase and the estimate, and it raises the failure and says what to fly.

use std::collections::VecDeque;

use heli_control::HoverController;
use heli_control::autorotation::{Autorotation, AutorotationGains};
use heli_nav::{NavState, seconds_between};
use heli_proto::scb::Controls;

use super::event::CoreEvent;
use super::{Action, Stamped};
use crate::phase::Phase;

/// When the rotor speed means the engine has failed: falling fast below a first fraction
/// of the governed speed (the engine's power gone, the rotor spends its energy at hover
/// collective at about 800 rpm/s), or held below a second fraction (a slower loss).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineWatch {
    /// The governor's speed in flight (rpm).
    pub governed_rpm: f64,
    /// Below this fraction of it ...
    pub falling_fraction: f64,
    /// ... a rotor falling faster than this over [`EngineWatch::falling_over_s`] (rpm/s)
    /// has lost its engine. The steepest fall of the demonstration's rolls below 95 % is
    /// 410 rpm/s; an engine failure in the hover, 820.
    pub falling_rpm_per_s: f64,
    /// See [`EngineWatch::falling_rpm_per_s`] (s).
    pub falling_over_s: f64,
    /// Unloaded: below this fraction of the governed speed ...
    pub unloaded_fraction: f64,
    /// ... with no collective above this commanded over [`EngineWatch::falling_over_s`]
    /// (−1 to 1: the rotor asked for little power), a rotor falling faster than
    /// [`EngineWatch::unloaded_falling_rpm_per_s`] has lost its engine. With the engine, the
    /// rotor falls that fast only under a heavy collective (the rolls' pull-ups and climbs,
    /// 0.65 and more); without it, a quarter of the way round a roll on the roll's falling
    /// collective, it fell at 490 rpm/s 0.1 s after the engine quit, still above 95 %.
    pub unloaded_collective: f64,
    /// See [`EngineWatch::unloaded_collective`] (rpm/s).
    pub unloaded_falling_rpm_per_s: f64,
    /// Below this fraction of it the rotor is failing: the governor holds within a few
    /// percent, and the deepest droop of the demonstration's rolls is 91 %.
    pub failure_fraction: f64,
    /// For at least this long (s).
    pub confirm_s: f64,
    /// An autorotation that has sunk to this height above the take-off point (m) ...
    pub landed_height_m: f64,
    /// ... and stopped sinking (m/s) for [`EngineWatch::landed_after_s`] is on the ground.
    pub landed_sink_mps: f64,
    /// See [`EngineWatch::landed_sink_mps`] (s).
    pub landed_after_s: f64,
}

impl Default for EngineWatch {
    fn default() -> Self {
        Self {
            governed_rpm: 1600.0,
            falling_fraction: 0.95,
            falling_rpm_per_s: 600.0,
            falling_over_s: 0.1,
            unloaded_fraction: 0.99,
            unloaded_collective: 0.5,
            unloaded_falling_rpm_per_s: 400.0,
            failure_fraction: 0.85,
            confirm_s: 0.1,
            landed_height_m: 0.5,
            landed_sink_mps: 0.3,
            landed_after_s: 0.5,
        }
    }
}

/// What the autorotation asks of the sequencer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Autorotate {
    /// The phase to fly.
    pub phase: Phase,
    /// The flight plan is given up (the autorotation began, or ended on the ground).
    pub abandon_plan: bool,
}

/// The engine's watch and the autorotation.
#[derive(Clone, Debug)]
pub struct Engine {
    /// Since when the rotor has been below the watch's threshold in the air.
    low_since_us: Option<u64>,
    /// The rotor speeds of the last control steps (µs, rpm) with the collective last
    /// commanded then, oldest first.
    rotor_history: VecDeque<(u64, f64, f64)>,
    /// The collective last commanded (none before the first command).
    collective: Option<f64>,
    /// The engine failure was raised: autorotation for the rest of the flight.
    pub(super) failed: bool,
    /// The autorotation under way.
    pub(super) autorotation: Option<Autorotation>,
}

impl Default for Engine {
    fn default() -> Self {
        Self {
            low_since_us: None,
            rotor_history: VecDeque::with_capacity(16),
            collective: None,
            failed: false,
            autorotation: None,
        }
    }
}

impl Engine {
    /// Whether the engine failure was raised.
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// The collective this control step commands (the watch at the next step judges the
    /// rotor's fall by it).
    pub fn commanded(&mut self, collective: f64) {
        self.collective = Some(collective);
    }

    /// One control step's rotor speed (`None` without a live uplink): in the air
    /// (`airborne`), a fast fall below the watch's first fraction, or a speed held below the
    /// second for its confirmation time, raises the engine failure (once).
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub fn watch(
        &mut self,
        w: &EngineWatch,
        rotor_rpm: Option<f64>,
        airborne: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        let rpm = match rotor_rpm {
            Some(rpm) if !self.failed => rpm,
            _ => return,
        };
        // The rotor speed over the last `falling_over_s` (a few control steps).
        let history = &mut self.rotor_history;
        while history
            .get(1)
            .is_some_and(|(t, _, _)| seconds_between(*t, now_us) >= w.falling_over_s)
        {
            history.pop_front();
        }
        let fall_rpm_per_s = history
            .front()
            .filter(|(t, _, _)| seconds_between(*t, now_us) >= w.falling_over_s)
            .map(|(t, then, _)| (then - rpm) / seconds_between(*t, now_us).max(1e-3));
        let collective = self.collective.unwrap_or(f64::INFINITY);
        // The heaviest collective over the fall (unknown counts as heavy).
        let heaviest = history
            .iter()
            .map(|(_, _, c)| *c)
            .fold(collective, f64::max);
        if history.len() < 16 {
            history.push_back((now_us, rpm, collective));
        }
        let falling = fall_rpm_per_s.is_some_and(|f| {
            (rpm < w.governed_rpm * w.falling_fraction && f > w.falling_rpm_per_s)
                || (rpm < w.governed_rpm * w.unloaded_fraction
                    && heaviest <= w.unloaded_collective
                    && f > w.unloaded_falling_rpm_per_s)
        });
        let low = rpm < w.governed_rpm * w.failure_fraction;
        if !(airborne && (falling || low)) {
            self.low_since_us = None;
            return;
        }
        let since = *self.low_since_us.get_or_insert(now_us);
        if falling || seconds_between(since, now_us) >= w.confirm_s {
            self.failed = true;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::EngineFailure {
                    rotor_rpm: rpm.round().clamp(0.0, f64::from(u16::MAX)) as u16,
                },
            )));
        }
    }

    /// After the engine failure, what to fly instead of `phase` (`None` before one): the
    /// autorotation in the air, from whatever the phase; on the ground, idle.
    #[allow(clippy::too_many_arguments)]
    pub fn autorotate(
        &mut self,
        w: &EngineWatch,
        gains: AutorotationGains,
        phase: Phase,
        est: &NavState,
        height_m: f64,
        on_ground: bool,
        signal_lost: bool,
        now_us: u64,
    ) -> Option<Autorotate> {
        if !self.failed {
            return None;
        }
        let stay = |phase| Autorotate {
            phase,
            abandon_plan: false,
        };
        match phase {
            Phase::Autorotation { settled_since_us } => {
                let settled =
                    height_m < w.landed_height_m && est.vel_ned_mps.z.abs() < w.landed_sink_mps;
                let since = settled.then(|| settled_since_us.unwrap_or(now_us));
                if since.is_some_and(|t| seconds_between(t, now_us) >= w.landed_after_s) {
                    self.autorotation = None;
                    return Some(Autorotate {
                        phase: Phase::Landed,
                        abandon_plan: true,
                    });
                }
                Some(stay(Phase::Autorotation {
                    settled_since_us: since,
                }))
            }
            // On the ground the engine is never flown on again: no pre-flight check, no
            // take-off, no hold a lost transmitter would ask for. The idle phases stay, a
            // lost transmitter idles, anything else is landed.
            Phase::GroundFailsafe | Phase::TakeoffRefused if on_ground => Some(stay(phase)),
            _ if on_ground && signal_lost => Some(stay(Phase::GroundFailsafe)),
            _ if on_ground => Some(stay(Phase::Landed)),
            // In the air, from whatever the phase (a landed helicopter the estimate sees
            // climbing again included): autorotate.
            _ => {
                self.autorotation = Some(Autorotation::begin(gains, est, height_m));
                Some(Autorotate {
                    phase: Phase::Autorotation {
                        settled_since_us: None,
                    },
                    abandon_plan: true,
                })
            }
        }
    }

    /// The autorotation's servo command for this step (begun here if it was not).
    pub fn controls(
        &mut self,
        gains: AutorotationGains,
        hover: &mut HoverController,
        est: &NavState,
        height_m: f64,
        rotor_rpm: f64,
        dt_s: f64,
    ) -> Controls {
        self.autorotation
            .get_or_insert_with(|| Autorotation::begin(gains, est, height_m))
            .update(hover, est, height_m, rotor_rpm, dt_s)
    }
}
