//! The core's routes to its components' single steps, for the component tests that drive a
//! whole core into a state and then take one step of one part (the sequencer's failsafes,
//! the engine's autorotation, the restart's controls).

use heli_control::Target;
use heli_nav::NavState;
use heli_proto::scb::Controls;

use super::preflight::Refusal;
use super::sequencer::Crew;
use super::{Action, FlightCore, ModeRefusal};
use crate::phase::{Phase, RollStage};

/// A crew of `core`'s parts for its sequencer.
macro_rules! crew {
    ($core:expr) => {
        Crew {
            config: &$core.config,
            devices: &$core.devices,
            aiding: &$core.aiding,
            nav: &$core.nav,
            estimate_valid: $core.main_loop.estimate_valid(),
            aligning: $core.restart.aligning(),
            roll_rate_rps: $core.gyro_rps.map(|w| w.x),
            hover_trim_ned_mps2: $core.hover.trim_accel_ned_mps2(),
            modes: &mut $core.modes,
            engine: &mut $core.engine,
            power: &mut $core.power,
            stats: &mut $core.stats,
        }
    };
}

impl FlightCore {
    pub(super) fn autorotate(
        &mut self,
        est: &NavState,
        on_ground: bool,
        signal_lost: bool,
        now_us: u64,
    ) -> Option<Phase> {
        let height_m = self.seq.height_above_home(est);
        let a = self.engine.autorotate(
            &self.config.engine,
            self.config.autorotation,
            self.seq.phase,
            est,
            height_m,
            on_ground,
            signal_lost,
            now_us,
        )?;
        if a.abandon_plan {
            self.seq.plan_abandoned = true;
        }
        Some(a.phase)
    }

    pub(super) fn battery_failsafe(
        &mut self,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Option<Phase> {
        let mut crew = crew!(self);
        self.seq.battery_failsafe(&mut crew, est, now_us, out)
    }

    pub(super) fn preflight(&mut self, now_us: u64) -> Option<Refusal> {
        let crew = crew!(self);
        self.seq.preflight(&crew, now_us)
    }

    pub(super) fn refuse_while_calibrating(&mut self, now_us: u64, out: &mut Vec<Action>) {
        let mut crew = crew!(self);
        self.seq.refuse_while_calibrating(&mut crew, now_us, out);
    }

    pub(super) fn raise_refusal(
        &mut self,
        refusal: ModeRefusal,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        self.modes.raise(refusal, now_us, out);
    }

    pub(super) fn land_if_degraded(
        &mut self,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Option<Phase> {
        self.seq.land_if_degraded(&self.nav, est, now_us, out)
    }

    pub(super) fn braking_target(&mut self, target: Target, now_us: u64, est: &NavState) -> Target {
        self.seq.braking_target(target, now_us, est)
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn maneuver(
        &mut self,
        est: &NavState,
        now_us: u64,
        dt_s: f64,
        target: Target,
        stage: RollStage,
        rolls_done: u32,
        out: &mut Vec<Action>,
    ) -> Phase {
        let mut crew = crew!(self);
        self.seq
            .maneuver(&mut crew, est, now_us, dt_s, target, stage, rolls_done, out)
    }

    pub(super) fn aligning_controls(&self, gyro_z_rps: f64) -> Option<Controls> {
        self.restart
            .aligning_controls(&self.config.yaw_damper, &self.config.hover, gyro_z_rps)
    }

    pub(super) fn average_trim(&mut self, controls: &Controls, dt_s: f64) {
        self.restart.average_trim(controls, dt_s);
    }
}
