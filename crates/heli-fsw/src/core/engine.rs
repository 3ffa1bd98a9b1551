//! The engine-failure response: the rotor's speed, read by the servo controller board's
//! tachometer, watched in the air; when it falls fast below a fraction of the governed
//! speed, or stays below a lower one, the engine has failed (the governor would hold it otherwise), the event is raised as
//! fatal, and an autonomous or augmented flight autorotates to the ground
//! (`heli_control::autorotation`), at once, from whatever attitude: a roll under way is
//! not finished (its collective would spend the rotor's speed), the autorotation rights
//! the helicopter by the shortest way first. A pilot
//! flying by hand (auto switch off, or the bypass) is told and keeps flying: autorotating a
//! helicopter is what the thesis's safety pilot trained for.

use super::*;
use heli_control::autorotation::Autorotation;

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
            failure_fraction: 0.85,
            confirm_s: 0.1,
            landed_height_m: 0.5,
            landed_sink_mps: 0.3,
            landed_after_s: 0.5,
        }
    }
}

impl FlightCore {
    /// Watches the rotor speed in the air; raises the engine failure once.
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
    )]
    pub(super) fn watch_engine(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) {
        let w = self.config.engine;
        let rpm = match self.pilot {
            Some(p) if !self.uplink_lost && !self.engine_failed => f64::from(p.rotor_rpm),
            _ => return,
        };
        let airborne =
            self.airborne_once && self.height_above_home(est) > self.config.airborne_height_m;
        // The rotor speed over the last `falling_over_s` (a few control steps).
        let history = &mut self.rotor_history;
        while history
            .get(1)
            .is_some_and(|(t, _)| seconds_between(*t, now_us) >= w.falling_over_s)
        {
            history.pop_front();
        }
        let fall_rpm_per_s = history
            .front()
            .filter(|(t, _)| seconds_between(*t, now_us) >= w.falling_over_s)
            .map(|(t, then)| (then - rpm) / seconds_between(*t, now_us).max(1e-3));
        if history.len() < 16 {
            history.push_back((now_us, rpm));
        }
        let falling = rpm < w.governed_rpm * w.falling_fraction
            && fall_rpm_per_s.is_some_and(|f| f > w.falling_rpm_per_s);
        let low = rpm < w.governed_rpm * w.failure_fraction;
        if !(airborne && (falling || low)) {
            self.engine_low_since_us = None;
            return;
        }
        let since = *self.engine_low_since_us.get_or_insert(now_us);
        if falling || seconds_between(since, now_us) >= w.confirm_s {
            self.engine_failed = true;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::EngineFailure {
                    rotor_rpm: rpm.round().clamp(0.0, f64::from(u16::MAX)) as u16,
                },
            )));
        }
    }

    /// The phase after an engine failure, when the computer flies: `None` when the engine
    /// is fine (the other rules decide); after a failure, an autorotation in the air and
    /// an unpowered phase on the ground.
    pub(super) fn autorotate(
        &mut self,
        est: &NavState,
        on_ground: bool,
        signal_lost: bool,
        now_us: u64,
    ) -> Option<Phase> {
        if !self.engine_failed {
            return None;
        }
        match self.phase {
            Phase::Autorotation { settled_since_us } => {
                let w = self.config.engine;
                let settled = self.height_above_home(est) < w.landed_height_m
                    && est.vel_ned_mps.z.abs() < w.landed_sink_mps;
                let since = settled.then(|| settled_since_us.unwrap_or(now_us));
                if since.is_some_and(|t| seconds_between(t, now_us) >= w.landed_after_s) {
                    self.autorotation = None;
                    self.plan_abandoned = true;
                    return Some(Phase::Landed);
                }
                Some(Phase::Autorotation {
                    settled_since_us: since,
                })
            }
            // On the ground the engine is never flown on again: no pre-flight check, no
            // take-off, no hold a lost transmitter would ask for. The idle phases stay, a
            // lost transmitter idles, anything else is landed.
            Phase::GroundFailsafe | Phase::TakeoffRefused if on_ground => Some(self.phase),
            _ if on_ground && signal_lost => Some(Phase::GroundFailsafe),
            _ if on_ground => Some(Phase::Landed),
            // In the air, from whatever the phase (a landed helicopter the estimate sees
            // climbing again included): autorotate.
            _ => Some(self.begin_autorotation(est)),
        }
    }

    fn begin_autorotation(&mut self, est: &NavState) -> Phase {
        self.plan_abandoned = true;
        let height = self.height_above_home(est);
        self.autorotation = Some(Autorotation::begin(self.config.autorotation, est, height));
        Phase::Autorotation {
            settled_since_us: None,
        }
    }

    /// The autorotation's servo commands.
    pub(super) fn autorotation_controls(&mut self, est: &NavState, dt_s: f64) -> Controls {
        let height = self.height_above_home(est);
        let rpm = self.pilot.map_or(f64::NAN, |p| f64::from(p.rotor_rpm));
        let gains = self.config.autorotation;
        self.autorotation
            .get_or_insert_with(|| Autorotation::begin(gains, est, height))
            .update(&mut self.hover, est, height, rpm, dt_s)
    }
}
