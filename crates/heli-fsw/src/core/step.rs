//! The core's routing of the loop: each IMU sample (real, or repeated by the watchdog)
//! through the calibration or the in-air alignment, and every second one as the 50 Hz
//! control step — the estimate propagated, the watches of the aids and the engine, the
//! sequencer's phase, the controller that phase calls for (the dispatch), the trim kept,
//! and the records published.

use heli_control::{augmented_controls, manual_with_yaw_damping, rolling_controls};
use heli_nav::NavState;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::Controls;
use heli_types::AugmentedMode;
use nalgebra::Vector3;

use super::sequencer::Crew;
use super::{Action, BLIND_DESCENT_COLLECTIVE_MARGIN, CoreEvent, FlightCore};
use crate::phase::{Phase, RollStage};
use crate::streams::{ImuRecord, Record, ServoRecord, Stamped, StateRecord};

/// Time constant (s) of home's height following the estimate on the skids: long against
/// the estimate's wander (tenths of a metre from one altimeter or GPS update to the next,
/// and for seconds after the calibration), short against the weather's drift of the
/// altimeter (some 0.3 m in minutes). The campaigns cannot choose it: 10 s and 60 s move a
/// flight or two at their limits either way (docs/robustness.md).
pub(super) const HOME_FOLLOW_S: f64 = 60.0;

/// Home's height `home_z_m` (NED z) after `dt_s` more on the skids with the estimate at
/// `est_z_m`: a first-order low-pass with [`HOME_FOLLOW_S`], in its implicit (backward Euler)
/// form, which moves home part of the way to the estimate for any step, however long. A step
/// that is not a time forward, or an estimate that is not finite, leaves it.
pub(super) fn follow_ground(home_z_m: f64, est_z_m: f64, dt_s: f64) -> f64 {
    if !est_z_m.is_finite() || !(f64::MIN_POSITIVE..=f64::MAX).contains(&dt_s) {
        return home_z_m;
    }
    let gain = dt_s / (HOME_FOLLOW_S + dt_s);
    home_z_m + gain * (est_z_m - home_z_m)
}

/// Control steps between zero-velocity updates on the skids: 10 Hz at the 50 Hz step.
pub const STILL_EVERY_STEPS: u32 = 5;

/// A rotor below this fraction of its governed speed lifts nothing: with the pilot's sticks,
/// before the first lift-off, the helicopter stands.
pub const ROTOR_IDLE_FRACTION: f64 = 0.5;

impl FlightCore {
    /// One iteration of the main loop on an IMU sample (real, or repeated by the watchdog).
    pub(super) fn loop_iteration(
        &mut self,
        sample: ImuRepr,
        repeated: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        out.push(Action::Publish(Record::Imu(Stamped::new(
            now_us,
            ImuRecord {
                imu: sample,
                repeated,
            },
        ))));
        if !repeated && self.restart.aligning() {
            self.restart.align(
                &mut self.nav,
                self.aiding.last_good_fix(),
                now_us,
                &sample,
                out,
            );
            if !self.restart.aligning() {
                // Aligned: an estimate declared invalid by a stall is good again.
                self.main_loop.revalidate();
            }
        } else if !repeated && self.nav.state().is_none() {
            let biases = self.calibration.push(&sample, &mut |event| {
                out.push(Action::Event(Stamped::new(now_us, event)));
            });
            if let Some(biases) = biases {
                self.nav.initialise(now_us, &biases);
                self.seq.home_ned_m = self.nav.state().map(|s| s.pos_ned_m);
                let b = biases.gyro_rps;
                out.push(Action::Event(Stamped::new(
                    now_us,
                    CoreEvent::CalibrationDone {
                        gyro_bias_rps: [b.x, b.y, b.z],
                    },
                )));
            }
        }
        if let Some((previous, current)) = self.main_loop.iterate(sample) {
            self.control_step(previous, current, repeated, now_us, out);
        }
    }

    /// The 50 Hz step: propagate, choose the phase, control, publish.
    pub(super) fn control_step(
        &mut self,
        previous: ImuRepr,
        current: ImuRepr,
        repeated: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        self.stats.control_steps = self.stats.control_steps.saturating_add(1);
        let bias = self
            .nav
            .state()
            .map_or(Vector3::zeros(), |s| s.gyro_bias_rps);
        self.gyro_rps = (!repeated).then(|| Vector3::from(current.rate_rps) - bias);
        let dt_s = self.main_loop.step_dt(now_us);
        self.nav.propagate(now_us, &previous, &current);
        if self.on_skids() && self.stats.control_steps.is_multiple_of(STILL_EVERY_STEPS) {
            self.nav.fuse_still();
        }
        self.power.watch_channel(now_us, out);

        // An estimate declared invalid (the IMU went silent) is never flown on again.
        let estimate = self
            .nav
            .state()
            .copied()
            .filter(|_| self.main_loop.estimate_valid());
        if estimate.is_some() {
            self.aiding.gps_outage(&self.nav, now_us, out);
        }
        if let Some(est) = estimate.as_ref() {
            self.aiding.watch(&self.nav, now_us, out);
            self.watch_engine(est, now_us, out);
        }
        if let Some(est) = estimate.as_ref() {
            // Held on the skids by the computer, never flown, the helicopter is down whatever
            // the estimate says: it is not "airborne" (the engine watch, a hover to lift into
            // when the transmitter is lost), and home's height follows the ground, as
            // autopilots take the ground's pressure again while disarmed. It follows the
            // estimate's average (`follow_ground`), not its reading of the moment: the
            // altimeter's drift through a long wait (the weather: some 0.3 m in minutes) is
            // taken up, the estimate's wander from one altimeter or GPS update to the next
            // (tenths of a metre) is not, since home's height is the reference of every
            // height in the flight (the autorotation's flare among them). Not in the pilot's
            // phases: there only the rotor's speed says the helicopter is down, and a wrong
            // reading must not carry home up with it.
            if self.seq.held_on_skids() {
                if let Some(home) = self.seq.home_ned_m.as_mut() {
                    home.z = follow_ground(home.z, est.pos_ned_m.z, dt_s);
                }
            } else {
                self.seq.airborne_once |=
                    self.height_above_home(est) > self.config.airborne_height_m;
            }
        }
        let previous_phase = self.seq.phase;
        let next_phase = self.next_phase(estimate.as_ref(), now_us, dt_s, out);
        self.seq.phase = next_phase;
        if !next_phase.same_kind(&previous_phase) {
            // The trim-trajectory controller keeps its integrators through a climb, a path
            // and a maneuver; it starts afresh after the pilot or the ground had control.
            if matches!(
                previous_phase,
                Phase::Calibrating
                    | Phase::Manual
                    | Phase::GroundFailsafe
                    | Phase::BlindDescent
                    | Phase::TakeoffRefused
                    | Phase::PreflightCheck { .. }
                    | Phase::Landed
                    | Phase::Augmented(_)
            ) {
                self.hover.reset();
            }
            // A hold after flight unlearns that flight's drag (`HoverController::enter_hold`).
            if next_phase.is_hold_after_flight(&previous_phase) {
                self.hover.enter_hold();
            }
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::PhaseChanged(next_phase),
            )));
        }
        if self.seq.operator_stop
            && let Some(outcome) = super::stop::landing_outcome(next_phase)
        {
            self.seq.operator_stop = false;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::Stop(outcome),
            )));
        }

        let controls = self.phase_controls(estimate, &current, dt_s);
        self.engine.commanded(controls.collective);
        if self.averages_trim() {
            self.restart.average_trim(&controls, dt_s);
        }
        let rotor_rpm = self.devices.pilot().map_or(0, |p| p.rotor_rpm);
        out.push(Action::Servo(Stamped::new(now_us, controls)));
        out.push(Action::Publish(Record::Servo(Stamped::new(
            now_us,
            ServoRecord {
                controls,
                rotor_rpm,
            },
        ))));
        if let Some(nav) = estimate {
            out.push(Action::Publish(Record::State(Stamped::new(
                now_us,
                StateRecord {
                    nav,
                    phase: self.seq.phase,
                    target: self.seq.phase.target(),
                },
            ))));
        }
    }

    /// The servo command the phase calls for: the dispatch from phase to controller.
    pub(super) fn phase_controls(
        &mut self,
        estimate: Option<NavState>,
        current: &ImuRepr,
        dt_s: f64,
    ) -> Controls {
        // A silent uplink's last sticks are stale: they count as no sticks at all.
        let pilot_sticks = self.devices.sticks();
        // Without a valid estimate the last IMU sample is a stale copy: no yaw damping.
        let yaw_rate = match (estimate, self.main_loop.estimate_valid()) {
            (Some(s), _) => s.rate_body_rps.z,
            (None, true) => current.rate_rps[2],
            (None, false) => 0.0,
        };
        match (self.seq.phase, estimate) {
            (
                Phase::Maneuver {
                    stage: RollStage::Rolling { angle_rad, .. },
                    ..
                },
                Some(est),
            ) => rolling_controls(&est.rate_body_rps, angle_rad, &self.config.roll),
            // Finished blind (`roll::blind_step`): on the gyro's rates when a real sample
            // came, on the feedforward alone while the IMU is silent.
            (
                Phase::Maneuver {
                    stage: RollStage::Rolling { angle_rad, .. },
                    ..
                },
                None,
            ) => {
                let commanded = Vector3::new(self.config.roll.rate_cmd_rps, 0.0, 0.0);
                rolling_controls(
                    &self.gyro_rps.unwrap_or(commanded),
                    angle_rad,
                    &self.config.roll,
                )
            }
            (
                Phase::TakingOff { target }
                | Phase::Holding { target, .. }
                | Phase::Flying { target, .. }
                | Phase::Maneuver { target, .. }
                | Phase::Landing { target, .. },
                Some(est),
            ) => {
                let airborne = self.height_above_home(&est) > self.config.airborne_height_m;
                self.hover.update(&est, &target, dt_s, airborne)
            }
            (Phase::Autorotation { .. }, Some(est)) => {
                let height = self.height_above_home(&est);
                let rpm = self
                    .devices
                    .pilot()
                    .map_or(f64::NAN, |p| f64::from(p.rotor_rpm));
                self.engine.controls(
                    self.config.autorotation,
                    &mut self.hover,
                    &est,
                    height,
                    rpm,
                    dt_s,
                )
            }
            (Phase::Augmented(mode), Some(est)) => {
                let airborne = self.height_above_home(&est) > self.config.airborne_height_m;
                // Once it has flown, a low pass near the ground is flight, not ground idle.
                self.seq.has_flown |= self.height_above_home(&est) > 1.0;
                if !self.seq.has_flown
                    && mode == AugmentedMode::Velocity
                    && pilot_sticks.collective <= 0.1
                {
                    // On the skids with the climb stick centred: ground idle, rotor governed.
                    Controls {
                        throttle: heli_control::GOVERNED_THROTTLE,
                        ..Controls::default()
                    }
                } else {
                    augmented_controls(
                        mode,
                        &pilot_sticks,
                        &est,
                        &self.config.sticks,
                        &mut self.hover,
                        dt_s,
                        airborne,
                    )
                }
            }
            (Phase::Landed | Phase::TakeoffRefused | Phase::PreflightCheck { .. }, _) => Controls {
                collective: -0.1,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            },
            (Phase::GroundFailsafe, _) => Controls::default(),
            (Phase::BlindDescent, _) if self.restart.aligning() => self
                .restart
                .aligning_controls(
                    &self.config.yaw_damper,
                    &self.config.hover,
                    current.rate_rps[2],
                )
                .unwrap_or_default(),
            (Phase::BlindDescent, _) => Controls {
                collective: self.config.hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
                rudder: self.config.yaw_damper.trim,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            },
            _ => manual_with_yaw_damping(&pilot_sticks, yaw_rate, &self.config.yaw_damper),
        }
    }

    /// Whether this step's command goes into the trim a restarted process aligns on: in
    /// autonomous flight that holds or flies a target, once the helicopter has been up.
    pub(super) fn averages_trim(&self) -> bool {
        self.seq.airborne_once
            && matches!(
                self.seq.phase,
                Phase::Holding { .. } | Phase::Flying { .. } | Phase::TakingOff { .. }
            )
    }

    /// Standing on its skids, as the flight software knows it: never yet off the ground
    /// and no lift asked for — an autonomous phase on the ground (the pre-flight check, a
    /// refused take-off, the ground failsafe), or the pilot's or the augmented mode with the
    /// rotor below half its governed speed — or landed. The estimator is then told it is not
    /// moving (`Navigator::fuse_still`).
    pub(super) fn on_skids(&self) -> bool {
        match self.seq.phase {
            Phase::Landed => true,
            Phase::PreflightCheck { .. } | Phase::TakeoffRefused | Phase::GroundFailsafe => {
                self.seq.held_on_skids()
            }
            Phase::Manual | Phase::Augmented(_) => {
                !self.seq.airborne_once
                    && self.devices.rotor_rpm().is_some_and(|rpm| {
                        rpm < self.config.engine.governed_rpm * ROTOR_IDLE_FRACTION
                    })
            }
            _ => false,
        }
    }

    pub(super) fn height_above_home(&self, est: &NavState) -> f64 {
        self.seq.height_above_home(est)
    }

    /// The engine's watch at a control step with an estimate: the rotor's speed, airborne
    /// when the helicopter has been up and is above the airborne height.
    pub(super) fn watch_engine(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) {
        let airborne =
            self.seq.airborne_once && self.height_above_home(est) > self.config.airborne_height_m;
        self.engine.watch(
            &self.config.engine,
            self.devices.rotor_rpm(),
            airborne,
            now_us,
            out,
        );
    }

    /// The sequencer's phase for this step, with its crew.
    pub(super) fn next_phase(
        &mut self,
        estimate: Option<&NavState>,
        now_us: u64,
        dt_s: f64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let mut crew = Crew {
            config: &self.config,
            devices: &self.devices,
            aiding: &self.aiding,
            nav: &self.nav,
            estimate_valid: self.main_loop.estimate_valid(),
            aligning: self.restart.aligning(),
            roll_rate_rps: self.gyro_rps.map(|w| w.x),
            hover_trim_ned_mps2: self.hover.trim_accel_ned_mps2(),
            modes: &mut self.modes,
            engine: &mut self.engine,
            power: &mut self.power,
            stats: &mut self.stats,
        };
        self.seq.next_phase(&mut crew, estimate, now_us, dt_s, out)
    }
}
