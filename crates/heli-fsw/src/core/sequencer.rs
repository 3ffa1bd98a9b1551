//! The mission sequencer: which phase comes next, from the pilot's switches, the
//! transmitter's state and the flight plan's legs — and the failsafes that change the plan:
//! transmitter loss, the engine's failure, a mode the safety rule refuses, a degraded
//! estimate, the batteries.
//!
//! Without an estimate it decides in `blind`.
//!
//! A component: it owns the phase, the plan and where it is in it, the stop under way, home
//! and whether the helicopter has flown; each control step the core hands it the estimate
//! and its crew ([`Crew`]: what it consults — the devices, the aids, the filter — and the
//! components whose failsafes it asks — the mode check, the engine, the batteries), and it
//! chooses the phase.

use heli_control::Target;
use heli_nav::{NavState, Navigator, seconds_between};
use heli_types::{Device, FlightMode, Leg};
use nalgebra::Vector3;

use super::aids::Aiding;
use super::brake::{self, Brake};
use super::devices::DeviceWatch;
use super::engine::Engine;
use super::event::CoreEvent;
use super::legs::{self, Begin};
use super::mode_check::{ModeCheck, automatic_verdict, safety_facts};
use super::power::{Failsafe, Power};
use super::preflight::{self, Refusal};
use super::roll::{self, RollEnd, RollStep};
use super::{Action, CoreConfig, CoreStats, FlightParams, Stamped, degraded, weathervane};
use crate::phase::{Phase, RollStage};

/// A GPS fix fused this recently (s) lets the landing judge the horizontal speed too.
const GPS_FRESH_FOR_LANDING_S: f64 = 3.0;

/// What the sequencer consults and asks in a control step.
pub struct Crew<'a> {
    /// The core's configuration.
    pub config: &'a CoreConfig,
    /// The devices and the pilot.
    pub devices: &'a DeviceWatch,
    /// The aids and the last good GPS fix.
    pub aiding: &'a Aiding,
    /// The navigation filter.
    pub nav: &'a Navigator,
    /// The estimate has not been declared invalid.
    pub estimate_valid: bool,
    /// An in-air alignment is under way.
    pub aligning: bool,
    /// This step's body roll rate from a real IMU sample less the gyro bias (`None` when
    /// the watchdog repeated the last sample): what a roll is finished blind on.
    pub roll_rate_rps: Option<f64>,
    /// The hover controller's wind trim (m/s², NED), for the weathervane.
    pub hover_trim_ned_mps2: Vector3<f64>,
    /// The mode check.
    pub modes: &'a mut ModeCheck,
    /// The engine's watch and the autorotation.
    pub engine: &'a mut Engine,
    /// The batteries' watch.
    pub power: &'a mut Power,
    /// The loop's counters (the rolls completed).
    pub stats: &'a mut CoreStats,
}

/// The sequencer's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sequencer {
    /// The phase.
    pub(super) phase: Phase,
    /// The ground's parameters: the mode, and the plan (a battery failsafe replaces it).
    pub(super) params: FlightParams,
    /// Index of the plan leg being flown.
    pub(super) leg: usize,
    /// The last leg is done.
    pub(super) plan_done: bool,
    /// The plan was given up (transmitter lost in the air, a failsafe); it is not resumed.
    pub(super) plan_abandoned: bool,
    /// A hold begun in motion is still braking to a stop.
    pub(super) braking: Option<Brake>,
    /// Where the calibration started the estimate: the take-off point.
    pub(super) home_ned_m: Option<Vector3<f64>>,
    /// The helicopter has been more than a metre up in this flight.
    pub(super) has_flown: bool,
    /// The helicopter has been airborne (above the airborne height) in this flight.
    pub(super) airborne_once: bool,
    /// The operator's Stop came in the air: landing where it is, then the flight ends
    /// (`core::stop`).
    pub(super) operator_stop: bool,
    /// The pilot's request for the autonomous take-off: waiting on the pre-flight check
    /// since it was made, or refused, through whatever interrupts the check on the ground,
    /// until the switch goes off or the check passes (`preflight::Request`).
    pub(super) takeoff: preflight::Request,
}

impl Sequencer {
    /// A sequencer at the start of a flight: calibrating, nothing flown.
    pub fn new(params: FlightParams) -> Self {
        Self {
            phase: Phase::Calibrating,
            params,
            leg: 0,
            plan_done: false,
            plan_abandoned: false,
            braking: None,
            home_ned_m: None,
            has_flown: false,
            airborne_once: false,
            operator_stop: false,
            takeoff: preflight::Request::None,
        }
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// True once the last leg of the plan is done.
    pub fn plan_complete(&self) -> bool {
        self.plan_done
    }

    /// Height above home of `est` (m; 0 before home is known).
    pub fn height_above_home(&self, est: &NavState) -> f64 {
        self.home_ned_m.map_or(0.0, |home| home.z - est.pos_ned_m.z)
    }

    /// Whether the computer holds the helicopter on its skids, never flown: the pre-flight
    /// check, a refused take-off, the ground's failsafe. Home's height follows the ground
    /// then, and the helicopter is not airborne.
    pub(super) fn held_on_skids(&self) -> bool {
        !self.airborne_once
            && matches!(
                self.phase,
                Phase::PreflightCheck { .. } | Phase::TakeoffRefused | Phase::GroundFailsafe
            )
    }

    /// The safety rule's conditions as the core sees them now.
    fn facts(&self, crew: &Crew<'_>) -> heli_control::safety::Facts {
        safety_facts(
            self.phase,
            crew.estimate_valid,
            crew.devices,
            crew.aiding,
            crew.power,
        )
    }

    /// While calibrating: the mode the pilot's switch asks for judged once, so that the
    /// pilot knows before the calibration ends.
    pub(super) fn refuse_while_calibrating(
        &mut self,
        crew: &mut Crew<'_>,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        let asked = crew
            .devices
            .pilot()
            .is_some_and(|p| p.auto_mode && !p.signal_lost() && !p.bypass);
        let facts = self.facts(crew);
        crew.modes
            .while_calibrating(asked, self.params.mode, || facts, now_us, out);
    }

    /// Whether the safety rule refuses the mode the pilot's switch asks for.
    pub(super) fn refuse_mode(
        &mut self,
        crew: &mut Crew<'_>,
        on_ground: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> bool {
        let facts = self.facts(crew);
        crew.modes.refuse(
            self.params.mode,
            self.phase,
            on_ground,
            || facts,
            now_us,
            out,
        )
    }

    /// The pre-flight checks (`preflight`) at `now_us`.
    pub(super) fn preflight(&self, crew: &Crew<'_>, now_us: u64) -> Option<Refusal> {
        preflight::check(
            crew.devices.ok(Device::Imu),
            &crew.nav.stats(),
            crew.aiding.last_good_fix(),
            || automatic_verdict(self.facts(crew)),
            now_us,
        )
    }

    /// A degraded estimate (no GPS fused for [`degraded::GPS_LOSS_LAND_AFTER_S`]) lands an
    /// autonomous flight where it is.
    pub(super) fn land_if_degraded(
        &mut self,
        nav: &Navigator,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Option<Phase> {
        let since_gps_s = degraded::landing_due(self.airborne_once, &self.phase, || {
            nav.health(now_us).since_gps_s
        })?;
        self.plan_abandoned = true;
        self.braking = None;
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::EstimateDegraded { since_gps_s },
        )));
        Some(degraded::land_where_it_is(est))
    }

    /// The battery failsafe the batteries ask for: back to the take-off point at this height
    /// and down (warning), or down here (critical, or no take-off point known).
    pub(super) fn battery_failsafe(
        &mut self,
        crew: &mut Crew<'_>,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Option<Phase> {
        let failsafe = crew.power.failsafe(&self.phase, self.airborne_once)?;
        self.plan_abandoned = true;
        self.braking = None;
        let land_here = degraded::land_where_it_is(est);
        if failsafe == Failsafe::LandHere {
            return Some(land_here);
        }
        // No take-off point known to go back to: down here.
        let Some(home) = self.home_ned_m else {
            return Some(land_here);
        };
        // Warning: back to the take-off point at this height, then down.
        let height_m = home.z - est.pos_ned_m.z;
        match super::power::return_plan(height_m, crew.config.power.return_speed_mps) {
            Ok(plan) => {
                self.params.plan = plan;
                self.leg = 0;
                Some(self.start_leg(est, now_us, out))
            }
            Err(_) => Some(land_here),
        }
    }

    /// One step of the roll maneuver ([`roll::step`]): its next phase, or the next leg.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn maneuver(
        &mut self,
        crew: &mut Crew<'_>,
        est: &NavState,
        now_us: u64,
        dt_s: f64,
        target: Target,
        stage: RollStage,
        rolls_done: u32,
        out: &mut Vec<Action>,
    ) -> Phase {
        let (step, end) = roll::step(
            &crew.config.roll,
            self.plan_leg(),
            est,
            now_us,
            dt_s,
            target,
            stage,
            rolls_done,
        );
        if let Some(end) = end {
            let event = match end {
                RollEnd::Completed => {
                    crew.stats.rolls_completed = crew.stats.rolls_completed.saturating_add(1);
                    CoreEvent::RollCompleted(crew.stats.rolls_completed)
                }
                RollEnd::Abandoned => CoreEvent::RollAbandoned,
            };
            out.push(Action::Event(Stamped::new(now_us, event)));
        }
        match step {
            RollStep::Fly(phase) => phase,
            RollStep::NextLeg(from) => {
                if let Some(phase) = from {
                    self.phase = phase;
                }
                self.next_leg(est, now_us, out)
            }
        }
    }

    /// A hold begun in motion keeps its target on the predicted stopping point until the
    /// helicopter has actually stopped (under 0.3 m/s), then holds that spot.
    pub(super) fn braking_target(&mut self, target: Target, now_us: u64, est: &NavState) -> Target {
        let Some(brake) = self.braking else {
            return target;
        };
        match brake.target(now_us, &target) {
            Some(on_the_way) => on_the_way,
            None => {
                let mut stop = brake.stop_for(&est.pos_ned_m);
                stop.z = target.pos_ned_m.z;
                if est.vel_ned_mps.xy().norm() < brake::BRAKE_SETTLED_MPS {
                    self.braking = None;
                }
                Target::hold(stop, target.yaw_rad)
            }
        }
    }

    /// The phase of this control step, from the pilot's switches, the transmitter, the
    /// estimate (`None` while calibrating, aligning or after the estimate was declared
    /// invalid) and the plan; what it raises goes to `out`.
    pub fn next_phase(
        &mut self,
        crew: &mut Crew<'_>,
        estimate: Option<&NavState>,
        now_us: u64,
        dt_s: f64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let pilot = crew.devices.pilot();
        // The board's line going silent is transmitter loss too.
        let signal_lost = crew.devices.signal_lost();
        let Some(est) = estimate else {
            return self.without_estimate(crew, now_us, dt_s, out);
        };
        let auto_switch = pilot.is_some_and(|p| p.auto_mode);
        let (_, _, yaw) = est.euler_rad();
        // Where the helicopter can stop: ahead by v²/2a at the braking deceleration, so that
        // a hold begun in motion does not fly back to where it began.
        let horizontal_vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        let stop = horizontal_vel * (0.5 * horizontal_vel.norm() / brake::BRAKE_DECEL_MPS2);
        let here = Target::hold(est.pos_ned_m + stop, yaw);
        // Held on its skids by the computer, never flown, the helicopter is on the ground
        // whatever the estimate's noise says of the height.
        let on_ground =
            self.held_on_skids() || self.height_above_home(est) < crew.config.airborne_height_m;
        let bypass = !crew.devices.uplink_lost() && pilot.is_some_and(|p| p.bypass);
        let wants_auto =
            !bypass && (signal_lost || (self.params.mode != FlightMode::Manual && auto_switch));
        // A roll under way is finished, upright, before the pilot's switch or a lost
        // transmitter takes over: handing over an inverted helicopter costs metres of height
        // and seconds of recovery. (The emergency bypass acts at once: the board gives the
        // servos to the pilot in hardware.)
        if !bypass
            && (signal_lost || !wants_auto)
            && let Phase::Maneuver {
                target,
                stage: stage @ RollStage::Rolling { .. },
                rolls_done,
            } = self.phase
        {
            let next = self.maneuver(crew, est, now_us, dt_s, target, stage, rolls_done, out);
            if next.rolling() {
                return next;
            }
            // Upright again: the rules below take over from the maneuver.
        }
        if !wants_auto {
            // The emergency bypass: the board drives the servos from the pilot; the computer
            // still supplies the tail with yaw damping.
            crew.modes.clear();
            self.takeoff = preflight::Request::None;
            return Phase::Manual;
        }
        // The engine failed: the computer autorotates whatever it was flying.
        let height_m = self.height_above_home(est);
        if let Some(a) = crew.engine.autorotate(
            &crew.config.engine,
            crew.config.autorotation,
            self.phase,
            est,
            height_m,
            on_ground,
            signal_lost,
            now_us,
        ) {
            if a.abandon_plan {
                self.plan_abandoned = true;
            }
            return a.phase;
        }
        // The pilot's switch asks for a mode: the safety rule may refuse it (a transmitter
        // loss asks for nothing: its failsafe is never refused).
        if !signal_lost && self.refuse_mode(crew, on_ground, now_us, out) {
            return Phase::Manual;
        }
        if let (FlightMode::Augmented(mode), false) = (self.params.mode, signal_lost) {
            return Phase::Augmented(mode);
        }
        // The operator's Stop in the air: down where it is (a roll under way is finished
        // first), before a lost transmitter's hover: the flight is to end.
        if self.operator_stop
            && !self.phase.rolling()
            && !matches!(
                self.phase,
                Phase::Landing { .. } | Phase::Landed | Phase::Autorotation { .. }
            )
            && (!signal_lost || !on_ground)
        {
            self.plan_abandoned = true;
            self.braking = None;
            return degraded::land_where_it_is(est);
        }
        if signal_lost {
            return match self.phase {
                // The transmitter lost on the ground is no order to take off (nor to finish
                // one): everything idles.
                _ if on_ground && !matches!(self.phase, Phase::Holding { .. }) => {
                    self.skids_without_transmitter(crew, now_us, out);
                    Phase::GroundFailsafe
                }
                // A hold already in place (the plan's, or the loss's) is kept; the plan is
                // given up either way.
                Phase::Holding { target, since_us } => {
                    self.plan_abandoned = true;
                    Phase::Holding {
                        target: self.braking_target(target, now_us, est),
                        since_us,
                    }
                }
                // In the air: the thesis's "all channels zero" is a command to hover here. The
                // plan is abandoned; the pilot takes over again when the signal returns.
                _ => {
                    self.plan_abandoned = true;
                    self.braking = Brake::begin(now_us, est);
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            };
        }
        if let Some(landing) = self.land_if_degraded(crew.nav, est, now_us, out) {
            return landing;
        }
        if let Some(back) = self.battery_failsafe(crew, est, now_us, out) {
            return back;
        }
        match self.phase {
            // Refused stays refused until the pilot takes the auto switch off (above).
            Phase::TakeoffRefused => Phase::TakeoffRefused,
            Phase::PreflightCheck { since_us } => match self.preflight(crew, now_us) {
                None => {
                    self.takeoff = preflight::Request::None;
                    self.leg = 0;
                    self.start_leg(est, now_us, out)
                }
                Some(refusal) if seconds_between(since_us, now_us) >= preflight::CHECK_WAIT_S => {
                    self.refuse(refusal, now_us, out);
                    Phase::TakeoffRefused
                }
                Some(_) => Phase::PreflightCheck { since_us },
            },
            Phase::Calibrating
            | Phase::Manual
            | Phase::GroundFailsafe
            | Phase::BlindDescent
            | Phase::Augmented(_) => {
                if on_ground && !self.plan_done && !self.plan_abandoned {
                    // Pre-flight checks before the helicopter leaves the ground on its own;
                    // a refusal interrupted (a transmitter blip) stands.
                    self.on_the_skids(crew, est, now_us, out)
                } else if on_ground && self.airborne_once {
                    // Nothing left to fly, low after flying (a process started again over
                    // a landing, or the switch put on in a low hover): the height alone,
                    // within the altimeter's error of the ground, is no touchdown. It lands
                    // where it is, and the landing's own judge (stopped for a second) says
                    // when it is down.
                    degraded::land_where_it_is(est)
                } else if on_ground {
                    // Nothing left to fly, never airborne: stay on the skids.
                    Phase::Landed
                } else {
                    // Auto switch on in the air: hover here, once stopped.
                    self.braking = Brake::begin(now_us, est);
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            }
            Phase::Landed => Phase::Landed,
            // Only `autorotate` above leaves it (on the ground).
            Phase::Autorotation { .. } => self.phase,
            Phase::TakingOff { target } => {
                if (est.pos_ned_m.z - target.pos_ned_m.z).abs() < crew.config.takeoff_tolerance_m {
                    self.next_leg(est, now_us, out)
                } else {
                    self.phase
                }
            }
            Phase::Holding { target, since_us } => match self.plan_leg() {
                Some(Leg::Hold { seconds })
                    if !self.plan_done
                        && !self.plan_abandoned
                        && seconds_between(since_us, now_us) >= seconds =>
                {
                    self.next_leg(est, now_us, out)
                }
                _ => {
                    let target = self.braking_target(target, now_us, est);
                    Phase::Holding {
                        target: weathervane::weathervane(target, crew.hover_trim_ned_mps2, dt_s),
                        since_us,
                    }
                }
            },
            Phase::Flying { target, to_ned_m } => {
                let speed = target.vel_ned_mps.norm();
                let remaining = to_ned_m - target.pos_ned_m;
                let step = speed * dt_s;
                let target = if remaining.norm() <= step || speed <= 0.0 {
                    Target {
                        pos_ned_m: to_ned_m,
                        vel_ned_mps: Vector3::zeros(),
                        ..target
                    }
                } else {
                    Target {
                        pos_ned_m: target.pos_ned_m + remaining.normalize() * step,
                        ..target
                    }
                };
                let arrived = target.vel_ned_mps.norm() == 0.0
                    && (est.pos_ned_m - to_ned_m).norm() < 1.5
                    && est.vel_ned_mps.norm() < 1.0;
                if arrived {
                    self.next_leg(est, now_us, out)
                } else {
                    Phase::Flying { target, to_ned_m }
                }
            }
            Phase::Maneuver {
                target,
                stage,
                rolls_done,
            } => self.maneuver(crew, est, now_us, dt_s, target, stage, rolls_done, out),
            Phase::Landing {
                target,
                settled_since_us,
            } => {
                // The target descends at its rate but never more than a metre below the
                // helicopter; when the skids stop the descent the helicopter no longer follows
                // it. Touchdown is judged against the target, not against home: the landing
                // spot need not be at the take-off height, and the altimeter drifts.
                let z =
                    (target.pos_ned_m.z + target.vel_ned_mps.z * dt_s).min(est.pos_ned_m.z + 1.0);
                let target = Target {
                    pos_ned_m: Vector3::new(target.pos_ned_m.x, target.pos_ned_m.y, z),
                    ..target
                };
                // Stopped: the skids hold the helicopter up and it no longer moves. Without
                // GPS (a degraded estimate's landing) the horizontal velocity coasts on the
                // IMU and drifts; only the vertical one, which the altimeter keeps, is judged.
                let gps_fused = crew
                    .nav
                    .health(now_us)
                    .since_gps_s
                    .is_some_and(|s| s < GPS_FRESH_FOR_LANDING_S);
                let speed = if gps_fused {
                    est.vel_ned_mps.norm()
                } else {
                    est.vel_ned_mps.z.abs()
                };
                let stopped = z - est.pos_ned_m.z > 0.5 && speed < 0.3;
                let settled_since_us = if stopped {
                    Some(settled_since_us.unwrap_or(now_us))
                } else {
                    None
                };
                if settled_since_us.is_some_and(|t| seconds_between(t, now_us) >= 1.0) {
                    self.plan_done = true;
                    // A landing the plan did not ask for (a degraded estimate's) lands; it
                    // does not complete the plan.
                    if !self.plan_abandoned {
                        out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
                    }
                    Phase::Landed
                } else {
                    Phase::Landing {
                        target,
                        settled_since_us,
                    }
                }
            }
        }
    }

    /// The leg being flown.
    pub(super) fn plan_leg(&self) -> Option<Leg> {
        self.params.plan.get(self.leg)
    }

    pub(super) fn next_leg(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) -> Phase {
        self.leg = self.leg.saturating_add(1);
        self.start_leg(est, now_us, out)
    }

    /// The phase that flies the current leg, starting from where the helicopter is (or from
    /// the previous phase's target, so that a hold does not jump by the estimate's jitter).
    pub(super) fn start_leg(
        &mut self,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let (_, _, yaw) = est.euler_rad();
        let from = self.phase.target().map_or(est.pos_ned_m, |t| t.pos_ned_m);
        let home = self.home_ned_m.unwrap_or(est.pos_ned_m);
        match legs::begin(self.plan_leg(), from, home, yaw, now_us) {
            Begin::Fly(phase) => roll::run_up_from(phase, self.plan_leg(), est),
            Begin::Hold(hold) => {
                // Begun in motion (after a path or a roll sequence): stop first.
                self.braking = Brake::begin(now_us, est);
                Phase::Holding {
                    target: self.braking_target(hold, now_us, est),
                    since_us: now_us,
                }
            }
            Begin::Done(hold) => {
                if !self.plan_done {
                    self.plan_done = true;
                    out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
                }
                Phase::Holding {
                    target: hold,
                    since_us: now_us,
                }
            }
        }
    }
}
