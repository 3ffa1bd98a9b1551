//! The main control process, sans-I/O.
//!
//! Timing is derived from the IMU, as in the thesis: every IMU sample (or, when none came
//! for 12 ms, a copy of the last one made by the watchdog) is one loop iteration; every other
//! iteration (50 Hz) propagates the estimate with the two most recent samples, runs the
//! selected controller and emits a servo command. The other devices' samples update the
//! estimate (GPS, altimeter, compass) or the pilot's commands (servo controller board).
//!
//! The caller feeds [`Input`]s with the time they arrived and collects [`Action`]s; it must
//! also deliver [`Input::Timer`] at [`FlightCore::poll_at`] so the watchdog can fire. The
//! core's whole state is a plain value: clone it to snapshot, compare to check replay.

pub mod mission;
pub mod watchdog;

use heli_control::{
    AugmentedMode, HoverController, HoverGains, RollGains, StickScales, Target, YawDamper,
    augmented_controls, manual_with_yaw_damping, rolling_controls,
};
use heli_nav::{BiasCalibration, NavConfig, NavState, Navigator, seconds_between};
use heli_proto::compass::{CompassAdc, CompassCalibration, heading_rad};
use heli_proto::gps::GpsNav;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink};
use nalgebra::Vector3;

use crate::streams::{
    BaroRecord, CompassRecord, ImuRecord, Record, ServoRecord, Stamped, StateRecord,
};
use mission::{Leg, Plan, RollStage};
use watchdog::{WATCHDOG_PERIOD_US, Watchdog};

/// Longest the roll maneuver waits to settle on its trim speed before giving up (s).
pub const ACCELERATE_TIMEOUT_S: f64 = 20.0;

/// Configuration of the main control process.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoreConfig {
    /// IMU warm-up before the calibration window opens (s).
    pub imu_warm_up_s: f64,
    /// Length of the bias calibration window (s); 80 in the thesis.
    pub calibration_s: f64,
    /// Watchdog period (µs); 12 ms in the thesis.
    pub watchdog_us: u64,
    /// Navigation filter.
    pub nav: NavConfig,
    /// Autonomous hover controller.
    pub hover: HoverGains,
    /// Manual-mode yaw damping.
    pub yaw_damper: YawDamper,
    /// The aileron roll.
    pub roll: RollGains,
    /// What full stick means in the augmented modes.
    pub sticks: StickScales,
    /// Compass biases from its calibration routine (stored in flash on the vehicle).
    pub compass: CompassCalibration,
    /// Take-off ends when the altitude is within this of the target (m).
    pub takeoff_tolerance_m: f64,
    /// Height above the take-off point at which the helicopter counts as airborne (m).
    pub airborne_height_m: f64,
}

impl Default for CoreConfig {
    fn default() -> Self {
        Self {
            imu_warm_up_s: 5.0,
            calibration_s: 80.0,
            watchdog_us: WATCHDOG_PERIOD_US,
            nav: NavConfig::default(),
            hover: HoverGains::default(),
            yaw_damper: YawDamper::default(),
            roll: RollGains::default(),
            sticks: StickScales::default(),
            compass: CompassCalibration::default(),
            takeoff_tolerance_m: 0.3,
            airborne_height_m: 0.3,
        }
    }
}

/// The control system the ground operator chose at "Start Logging".
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlightMode {
    /// Pilot flies; the computer only damps yaw.
    Manual,
    /// With the pilot's auto switch on, the computer flies the flight plan.
    Autonomous,
    /// With the pilot's auto switch on, the pilot flies through an augmentation system.
    Augmented(AugmentedMode),
}

impl FlightMode {
    /// What the ground display writes over the pilot-uplink columns (aileron, elevator,
    /// rudder, collective, throttle) when the auto switch is on.
    pub fn uplink_labels(self) -> [&'static str; 5] {
        match self {
            FlightMode::Augmented(mode) => mode.uplink_labels(),
            FlightMode::Manual | FlightMode::Autonomous => ["Aile", "Elev", "Rudd", "Coll", "Thro"],
        }
    }
}

/// The flight parameters sent by the ground at "Start Logging".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightParams {
    /// Control system for this flight.
    pub mode: FlightMode,
    /// What to fly when the pilot's auto switch is on.
    pub plan: Plan,
}

impl Default for FlightParams {
    fn default() -> Self {
        Self {
            mode: FlightMode::Manual,
            plan: Plan::hover(10.0, f64::INFINITY),
        }
    }
}

/// What the flight software is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Warming up and calibrating the IMU biases; servos follow the pilot.
    Calibrating,
    /// The pilot flies (auto switch off, or manual mode), with computer yaw damping.
    Manual,
    /// The transmitter was lost while the helicopter was on the ground: cyclic neutral,
    /// collective flat, throttle closed, until the pilot's signal returns.
    GroundFailsafe,
    /// Autonomous climb to the target.
    TakingOff {
        /// Where the climb ends.
        target: Target,
    },
    /// Autonomous position hold.
    Holding {
        /// Where the helicopter is held.
        target: Target,
        /// When the hold began (µs).
        since_us: u64,
    },
    /// Velocity tracking along a straight path: the target moves toward `to_ned_m`.
    Flying {
        /// The moving target.
        target: Target,
        /// The end of the path (m, NED).
        to_ned_m: Vector3<f64>,
    },
    /// The aileron-roll maneuver.
    Maneuver {
        /// The trim trajectory (moving target) used outside the rolls themselves.
        target: Target,
        /// Where in the maneuver.
        stage: RollStage,
        /// Rolls completed in this maneuver.
        rolls_done: u32,
    },
    /// Vertical descent to the ground.
    Landing {
        /// The descending target.
        target: Target,
        /// Since when the helicopter has stopped following the target down (µs).
        settled_since_us: Option<u64>,
    },
    /// On the skids after an autonomous landing.
    Landed,
    /// The pilot flies through an augmentation system.
    Augmented(AugmentedMode),
}

impl Phase {
    /// The target of an autonomous phase.
    pub fn target(&self) -> Option<Target> {
        match self {
            Phase::TakingOff { target }
            | Phase::Holding { target, .. }
            | Phase::Flying { target, .. }
            | Phase::Maneuver { target, .. }
            | Phase::Landing { target, .. } => Some(*target),
            Phase::Calibrating
            | Phase::Manual
            | Phase::GroundFailsafe
            | Phase::Landed
            | Phase::Augmented(_) => None,
        }
    }

    /// Short name for displays and logs.
    pub fn name(&self) -> &'static str {
        match self {
            Phase::Calibrating => "calibrating",
            Phase::Manual => "manual",
            Phase::GroundFailsafe => "ground-failsafe",
            Phase::TakingOff { .. } => "takeoff",
            Phase::Holding { .. } => "hold",
            Phase::Flying { .. } => "fly",
            Phase::Maneuver { stage, .. } => stage.name(),
            Phase::Landing { .. } => "land",
            Phase::Landed => "landed",
            Phase::Augmented(AugmentedMode::Rate) => "augmented-rate",
            Phase::Augmented(AugmentedMode::Attitude) => "augmented-attitude",
            Phase::Augmented(AugmentedMode::Velocity) => "augmented-velocity",
        }
    }

    /// Same kind of phase (a moving target or a turning roll does not count as a change).
    fn same_kind(&self, other: &Phase) -> bool {
        match (self, other) {
            (Phase::Maneuver { stage: a, .. }, Phase::Maneuver { stage: b, .. }) => {
                core::mem::discriminant(a) == core::mem::discriminant(b)
            }
            _ => core::mem::discriminant(self) == core::mem::discriminant(other),
        }
    }
}

/// One input to the main control process.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// A verified IMU packet.
    Imu(ImuRepr),
    /// A verified pilot uplink packet from the servo controller board.
    Uplink(PilotUplink),
    /// A verified GPS navigation solution.
    Gps(GpsNav),
    /// An altimeter reading.
    Baro {
        /// Static pressure (mbar).
        pressure_mbar: f64,
    },
    /// The compass's three ADC channels.
    Compass(CompassAdc),
    /// The watchdog timer (deliver at [`FlightCore::poll_at`]).
    Timer,
}

/// Notable things that happened, for the ground's message area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CoreEvent {
    /// The 80 s calibration finished.
    CalibrationDone {
        /// Gyro biases found (rad/s).
        gyro_bias_rps: [f64; 3],
    },
    /// The phase changed.
    PhaseChanged(Phase),
    /// The watchdog fired: an IMU packet was late or lost and the last one was repeated.
    WatchdogFired,
    /// The pilot's receiver signal was lost (all channels zero): hovering.
    PilotSignalLost,
    /// An aileron roll was completed (the count so far in this flight).
    RollCompleted(u32),
    /// A roll took more than twice its nominal time and was given up.
    RollAbandoned,
    /// No GPS fix has been fused for the outage time: the estimate is coasting on the IMU.
    GpsLost,
    /// GPS fixes are fused again.
    GpsRegained,
    /// The last leg of the flight plan is done.
    PlanComplete,
}

/// One output of the main control process.
// Records travel by value: no allocation in the control step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Write this command to the servo controller board.
    Servo(Stamped<Controls>),
    /// Append this record to its stream.
    Publish(Record),
    /// Report this event.
    Event(Stamped<CoreEvent>),
}

/// Counters of the main loop.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoreStats {
    /// IMU packets received.
    pub imu_samples: u32,
    /// Times the watchdog repeated the last IMU packet.
    pub watchdog_fires: u32,
    /// 50 Hz estimation and control steps.
    pub control_steps: u32,
    /// Pilot uplink packets received.
    pub uplinks: u32,
    /// GPS solutions received.
    pub gps_fixes: u32,
    /// Altimeter readings received.
    pub baro_readings: u32,
    /// Compass readings received.
    pub compass_readings: u32,
    /// Inputs refused: time going backwards, or values that are not finite.
    pub rejected_inputs: u32,
    /// Aileron rolls completed.
    pub rolls_completed: u32,
}

/// The main control process.
#[derive(Clone, Debug)]
pub struct FlightCore {
    config: CoreConfig,
    params: FlightParams,
    watchdog: Watchdog,
    calibration: BiasCalibration,
    nav: Navigator,
    hover: HoverController,
    phase: Phase,
    home_ned_m: Option<Vector3<f64>>,
    pilot: Option<PilotUplink>,
    last_imu: Option<ImuRepr>,
    odd_sample: bool,
    last_control_us: Option<u64>,
    last_input_us: u64,
    /// Index of the plan leg being flown.
    leg: usize,
    plan_done: bool,
    /// The plan was given up (transmitter lost in the air); it is not resumed.
    plan_abandoned: bool,
    gps_lost: bool,
    /// The helicopter has been more than a metre up in this flight.
    has_flown: bool,
    /// A hold begun in motion is still braking to a stop.
    braking: bool,
    stats: CoreStats,
}

impl FlightCore {
    /// A core that has just been started by the bootstrap with the ground's parameters.
    pub fn new(config: CoreConfig, params: FlightParams) -> Self {
        Self {
            config,
            params,
            watchdog: Watchdog::new(config.watchdog_us),
            calibration: BiasCalibration::new(config.imu_warm_up_s, config.calibration_s),
            nav: Navigator::new(config.nav),
            hover: HoverController::new(config.hover),
            phase: Phase::Calibrating,
            home_ned_m: None,
            pilot: None,
            last_imu: None,
            odd_sample: false,
            last_control_us: None,
            last_input_us: 0,
            leg: 0,
            plan_done: false,
            plan_abandoned: false,
            gps_lost: false,
            has_flown: false,
            braking: false,
            stats: CoreStats::default(),
        }
    }

    /// Arms the watchdog at start-up (the thesis sets it up before entering the main loop),
    /// so that an IMU that never sends is noticed too. Without this call it arms on the first
    /// IMU packet.
    pub fn start(&mut self, now_us: u64) {
        self.last_input_us = self.last_input_us.max(now_us);
        self.watchdog.kick(now_us);
    }

    /// Loop counters.
    pub fn stats(&self) -> CoreStats {
        CoreStats {
            watchdog_fires: self.watchdog.fires(),
            ..self.stats
        }
    }

    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// True once the last leg of the flight plan is done.
    pub fn plan_complete(&self) -> bool {
        self.plan_done
    }

    /// The navigation filter (estimate and aiding statistics).
    pub fn navigator(&self) -> &Navigator {
        &self.nav
    }

    /// When the caller must deliver [`Input::Timer`] next (the watchdog deadline).
    pub fn poll_at(&self) -> Option<u64> {
        self.watchdog.deadline_us()
    }

    /// Handles one input that arrived at `now_us`, appending what to do to `out`.
    pub fn handle(&mut self, input: Input, now_us: u64, out: &mut Vec<Action>) {
        if now_us < self.last_input_us || !input_is_finite(&input) {
            self.stats.rejected_inputs = self.stats.rejected_inputs.saturating_add(1);
            return;
        }
        self.last_input_us = now_us;
        match input {
            Input::Imu(sample) => {
                self.stats.imu_samples = self.stats.imu_samples.saturating_add(1);
                self.watchdog.kick(now_us);
                self.loop_iteration(sample, false, now_us, out);
            }
            Input::Timer => {
                if self.watchdog.expired(now_us) {
                    self.watchdog.kick(now_us);
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::WatchdogFired,
                    )));
                    if let Some(last) = self.last_imu {
                        self.loop_iteration(last, true, now_us, out);
                    }
                }
            }
            Input::Uplink(uplink) => {
                self.stats.uplinks = self.stats.uplinks.saturating_add(1);
                let was_lost = self.pilot.is_some_and(|p| p.signal_lost());
                if uplink.signal_lost() && !was_lost {
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::PilotSignalLost,
                    )));
                }
                self.pilot = Some(uplink);
                out.push(Action::Publish(Record::Uplink(Stamped::new(
                    now_us, uplink,
                ))));
            }
            Input::Gps(fix) => {
                self.stats.gps_fixes = self.stats.gps_fixes.saturating_add(1);
                self.nav.fuse_gps(now_us, &fix);
                out.push(Action::Publish(Record::Gps(Stamped::new(now_us, fix))));
            }
            Input::Baro { pressure_mbar } => {
                self.stats.baro_readings = self.stats.baro_readings.saturating_add(1);
                self.nav.fuse_baro(pressure_mbar);
                let alt_m = self
                    .nav
                    .baro_reference_mbar()
                    .map(|p0| heli_proto::baro::pressure_altitude_m(pressure_mbar, p0));
                out.push(Action::Publish(Record::Baro(Stamped::new(
                    now_us,
                    BaroRecord {
                        pressure_mbar,
                        alt_m,
                    },
                ))));
            }
            Input::Compass(adc) => {
                self.stats.compass_readings = self.stats.compass_readings.saturating_add(1);
                let field = self.config.compass.apply(&adc.raw_field());
                self.nav.fuse_compass(&field);
                let (roll, pitch) = self.nav.state().map_or((0.0, 0.0), |s| {
                    let (r, p, _) = s.euler_rad();
                    (r, p)
                });
                let heading = heading_rad(&field, roll, pitch);
                out.push(Action::Publish(Record::Compass(Stamped::new(
                    now_us,
                    CompassRecord {
                        adc,
                        field,
                        heading_rad: heading,
                    },
                ))));
            }
        }
    }

    /// One iteration of the main loop on an IMU sample (real, or repeated by the watchdog).
    fn loop_iteration(
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
        if !repeated && let Some(biases) = self.calibration.push(now_us, &sample) {
            self.nav.initialise(now_us, &biases);
            self.home_ned_m = self.nav.state().map(|s| s.pos_ned_m);
            let b = biases.gyro_rps;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::CalibrationDone {
                    gyro_bias_rps: [b.x, b.y, b.z],
                },
            )));
        }
        let previous = self.last_imu.replace(sample);
        self.odd_sample = !self.odd_sample;
        if self.odd_sample {
            return;
        }
        self.control_step(previous.unwrap_or(sample), sample, now_us, out);
    }

    /// The 50 Hz step: propagate, choose the phase, control, publish.
    fn control_step(
        &mut self,
        previous: ImuRepr,
        current: ImuRepr,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        self.stats.control_steps = self.stats.control_steps.saturating_add(1);
        let dt_s = self
            .last_control_us
            .map_or(0.02, |t| seconds_between(t, now_us));
        self.last_control_us = Some(now_us);
        self.nav.propagate(now_us, &previous, &current);

        let estimate = self.nav.state().copied();
        let gps_lost = self.nav.gps_outage(now_us);
        if gps_lost != self.gps_lost && estimate.is_some() {
            self.gps_lost = gps_lost;
            let event = if gps_lost {
                CoreEvent::GpsLost
            } else {
                CoreEvent::GpsRegained
            };
            out.push(Action::Event(Stamped::new(now_us, event)));
        }
        let previous_phase = self.phase;
        let next_phase = self.next_phase(estimate.as_ref(), now_us, dt_s, out);
        self.phase = next_phase;
        if !next_phase.same_kind(&previous_phase) {
            // The trim-trajectory controller keeps its integrators through a climb, a path
            // and a maneuver; it starts afresh after the pilot or the ground had control.
            if matches!(
                previous_phase,
                Phase::Calibrating
                    | Phase::Manual
                    | Phase::GroundFailsafe
                    | Phase::Landed
                    | Phase::Augmented(_)
            ) {
                self.hover.reset();
            }
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::PhaseChanged(next_phase),
            )));
        }

        let pilot_sticks = self.pilot.and_then(|p| p.sticks()).unwrap_or_default();
        let yaw_rate = estimate.map_or(current.rate_rps[2], |s| s.rate_body_rps.z);
        let controls = match (self.phase, estimate) {
            (
                Phase::Maneuver {
                    stage: RollStage::Rolling { angle_rad, .. },
                    ..
                },
                Some(est),
            ) => rolling_controls(&est, angle_rad, &self.config.roll),
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
            (Phase::Augmented(mode), Some(est)) => {
                let airborne = self.height_above_home(&est) > self.config.airborne_height_m;
                // Once it has flown, a low pass near the ground is flight, not ground idle.
                self.has_flown |= self.height_above_home(&est) > 1.0;
                if !self.has_flown
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
            (Phase::Landed, _) => Controls {
                collective: -0.1,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            },
            (Phase::GroundFailsafe, _) => Controls::default(),
            _ => manual_with_yaw_damping(&pilot_sticks, yaw_rate, &self.config.yaw_damper),
        };
        let rotor_rpm = self.pilot.map_or(0, |p| p.rotor_rpm);
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
                    phase: self.phase,
                    target: self.phase.target(),
                },
            ))));
        }
    }

    fn height_above_home(&self, est: &NavState) -> f64 {
        self.home_ned_m.map_or(0.0, |home| home.z - est.pos_ned_m.z)
    }

    fn next_phase(
        &mut self,
        estimate: Option<&NavState>,
        now_us: u64,
        dt_s: f64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let Some(est) = estimate else {
            return Phase::Calibrating;
        };
        let pilot = self.pilot;
        let signal_lost = pilot.is_some_and(|p| p.signal_lost());
        let auto_switch = pilot.is_some_and(|p| p.auto_mode);
        let (_, _, yaw) = est.euler_rad();
        // Where the helicopter can stop: ahead by v²/2a at the controller's braking
        // acceleration, so that a hold begun in motion does not fly back to where it began.
        let horizontal_vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        let braking = self.config.hover.max_accel_mps2.max(0.5);
        let stop = horizontal_vel * (horizontal_vel.norm() / (2.0 * braking));
        let here = Target::hold(est.pos_ned_m + stop, yaw);
        let on_ground = self.height_above_home(est) < self.config.airborne_height_m;
        let bypass = pilot.is_some_and(|p| p.bypass);
        let wants_auto =
            !bypass && (signal_lost || (self.params.mode != FlightMode::Manual && auto_switch));
        if !wants_auto {
            // The emergency bypass: the board drives the servos from the pilot; the computer
            // still supplies the tail with yaw damping.
            return Phase::Manual;
        }
        if let (FlightMode::Augmented(mode), false) = (self.params.mode, signal_lost) {
            return Phase::Augmented(mode);
        }
        if signal_lost {
            return match self.phase {
                // The transmitter lost on the ground is no order to take off (nor to finish
                // one): everything idles.
                _ if on_ground && !matches!(self.phase, Phase::Holding { .. }) => {
                    Phase::GroundFailsafe
                }
                // A hold already in place (the plan's, or the loss's) is kept; the plan is
                // given up either way.
                Phase::Holding { target, since_us } => {
                    self.plan_abandoned = true;
                    Phase::Holding {
                        target: self.braking_target(target, here, est),
                        since_us,
                    }
                }
                // In the air: the thesis's "all channels zero" is a command to hover here. The
                // plan is abandoned; the pilot takes over again when the signal returns.
                _ => {
                    self.plan_abandoned = true;
                    self.braking = true;
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            };
        }
        match self.phase {
            Phase::Calibrating | Phase::Manual | Phase::GroundFailsafe | Phase::Augmented(_) => {
                if on_ground && !self.plan_done && !self.plan_abandoned {
                    self.leg = 0;
                    self.start_leg(est, now_us, out)
                } else if on_ground {
                    // Nothing left to fly: stay on the skids.
                    Phase::Landed
                } else {
                    // Auto switch on in the air: hover here, once stopped.
                    self.braking = true;
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            }
            Phase::Landed => Phase::Landed,
            Phase::TakingOff { target } => {
                if (est.pos_ned_m.z - target.pos_ned_m.z).abs() < self.config.takeoff_tolerance_m {
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
                _ => Phase::Holding {
                    target: self.braking_target(target, here, est),
                    since_us,
                },
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
            } => self.maneuver(est, now_us, dt_s, target, stage, rolls_done, out),
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
                let stopped = z - est.pos_ned_m.z > 0.5 && est.vel_ned_mps.norm() < 0.3;
                let settled_since_us = if stopped {
                    Some(settled_since_us.unwrap_or(now_us))
                } else {
                    None
                };
                if settled_since_us.is_some_and(|t| seconds_between(t, now_us) >= 1.0) {
                    self.plan_done = true;
                    out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
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

    /// A hold begun in motion keeps its target on the predicted stopping point until the
    /// helicopter has actually stopped (under 0.3 m/s), then holds that spot.
    fn braking_target(&mut self, target: Target, stopping_point: Target, est: &NavState) -> Target {
        if !self.braking {
            return target;
        }
        if est.vel_ned_mps.xy().norm() < 0.3 {
            self.braking = false;
            return target;
        }
        Target {
            yaw_rad: target.yaw_rad,
            ..stopping_point
        }
    }

    fn plan_leg(&self) -> Option<Leg> {
        self.params.plan.get(self.leg)
    }

    fn next_leg(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) -> Phase {
        self.leg = self.leg.saturating_add(1);
        self.start_leg(est, now_us, out)
    }

    /// The phase that flies the current leg, starting from where the helicopter is (or from
    /// the previous phase's target, so that a hold does not jump by the estimate's jitter).
    fn start_leg(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) -> Phase {
        let (_, _, yaw) = est.euler_rad();
        let from = self.phase.target().map_or(est.pos_ned_m, |t| t.pos_ned_m);
        let home = self.home_ned_m.unwrap_or(est.pos_ned_m);
        match self.plan_leg() {
            Some(Leg::Takeoff { alt_m }) => Phase::TakingOff {
                target: Target::hold(home + Vector3::new(0.0, 0.0, -alt_m), yaw),
            },
            Some(Leg::Hold { .. }) => Phase::Holding {
                target: Target::hold(from, yaw),
                since_us: now_us,
            },
            Some(Leg::Fly {
                north_m,
                east_m,
                alt_m,
                speed_mps,
            }) => {
                let to_ned_m = home + Vector3::new(north_m, east_m, -alt_m);
                let path = to_ned_m - from;
                let horizontal = Vector3::new(path.x, path.y, 0.0);
                let heading = if horizontal.norm() > 5.0 {
                    path.y.atan2(path.x)
                } else {
                    yaw
                };
                let vel = if path.norm() > 1e-6 {
                    path.normalize() * speed_mps
                } else {
                    Vector3::zeros()
                };
                Phase::Flying {
                    target: Target {
                        pos_ned_m: from,
                        vel_ned_mps: vel,
                        yaw_rad: heading,
                    },
                    to_ned_m,
                }
            }
            Some(Leg::Rolls { speed_mps, .. }) => {
                let dir = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
                Phase::Maneuver {
                    target: Target {
                        pos_ned_m: from,
                        vel_ned_mps: dir * speed_mps,
                        yaw_rad: yaw,
                    },
                    stage: RollStage::Accelerate { since_us: now_us },
                    rolls_done: 0,
                }
            }
            Some(Leg::Land) => Phase::Landing {
                settled_since_us: None,
                target: Target {
                    pos_ned_m: from,
                    vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
                    yaw_rad: yaw,
                },
            },
            None => {
                if !self.plan_done {
                    self.plan_done = true;
                    out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
                }
                Phase::Holding {
                    target: Target::hold(from, yaw),
                    since_us: now_us,
                }
            }
        }
    }

    /// One step of the roll maneuver's stage machine.
    #[allow(clippy::too_many_arguments)]
    fn maneuver(
        &mut self,
        est: &NavState,
        now_us: u64,
        dt_s: f64,
        target: Target,
        stage: RollStage,
        rolls_done: u32,
        out: &mut Vec<Action>,
    ) -> Phase {
        let g = self.config.roll;
        let Some(Leg::Rolls { count, speed_mps }) = self.plan_leg() else {
            return self.next_leg(est, now_us, out);
        };
        let dir = Vector3::new(target.yaw_rad.cos(), target.yaw_rad.sin(), 0.0);
        let trim_vel = dir * speed_mps;
        // The trim trajectory: straight and level at the trim speed, carried along.
        let carried = Target {
            pos_ned_m: target.pos_ned_m + target.vel_ned_mps * dt_s,
            ..target
        };
        let stage = match stage {
            RollStage::Accelerate { since_us } => {
                let settled = (est.vel_ned_mps - trim_vel).norm() < 1.0;
                let elapsed = seconds_between(since_us, now_us);
                if settled && elapsed > 6.0 {
                    RollStage::PullUp { since_us: now_us }
                } else if elapsed > ACCELERATE_TIMEOUT_S {
                    // Never settled on the trim (a headwind, a weak rotor): no rolls today.
                    self.phase = Phase::Maneuver {
                        target: carried,
                        stage,
                        rolls_done,
                    };
                    return self.next_leg(est, now_us, out);
                } else {
                    stage
                }
            }
            RollStage::PullUp { since_us } => {
                if seconds_between(since_us, now_us) >= g.pull_up_s {
                    RollStage::Rolling {
                        angle_rad: 0.0,
                        since_us: now_us,
                    }
                } else {
                    stage
                }
            }
            RollStage::Rolling {
                angle_rad,
                since_us,
            } => {
                // Turned in the commanded direction; a roll that takes more than twice its
                // nominal time is given up and the trim controller takes over.
                let angle_rad = angle_rad + est.rate_body_rps.x * g.rate_cmd_rps.signum() * dt_s;
                let nominal_s = 2.0 * core::f64::consts::PI / g.rate_cmd_rps.abs().max(0.5);
                let turned = angle_rad >= 2.0 * core::f64::consts::PI - g.exit_lead_rad;
                if turned || seconds_between(since_us, now_us) > 2.0 * nominal_s {
                    let event = if turned {
                        self.stats.rolls_completed = self.stats.rolls_completed.saturating_add(1);
                        CoreEvent::RollCompleted(self.stats.rolls_completed)
                    } else {
                        CoreEvent::RollAbandoned
                    };
                    out.push(Action::Event(Stamped::new(now_us, event)));
                    // Back on the trim trajectory from here, at this height.
                    let target = Target {
                        pos_ned_m: est.pos_ned_m,
                        vel_ned_mps: trim_vel,
                        ..target
                    };
                    return Phase::Maneuver {
                        target,
                        stage: RollStage::Recover { since_us: now_us },
                        rolls_done: rolls_done.saturating_add(1),
                    };
                }
                RollStage::Rolling {
                    angle_rad,
                    since_us,
                }
            }
            RollStage::Recover { since_us } => {
                if seconds_between(since_us, now_us) < g.recover_s {
                    stage
                } else if rolls_done < count {
                    RollStage::PullUp { since_us: now_us }
                } else {
                    self.phase = Phase::Maneuver {
                        target: carried,
                        stage,
                        rolls_done,
                    };
                    return self.next_leg(est, now_us, out);
                }
            }
        };
        let vel_ned_mps = match stage {
            RollStage::PullUp { .. } => trim_vel + Vector3::new(0.0, 0.0, -g.pull_up_climb_mps),
            _ => trim_vel,
        };
        let mut target = Target {
            vel_ned_mps,
            ..carried
        };
        if let RollStage::Rolling { .. } = stage {
            // While rolling the trajectory only keeps up with the helicopter.
            target.pos_ned_m = est.pos_ned_m;
        }
        Phase::Maneuver {
            target,
            stage,
            rolls_done,
        }
    }
}

/// True when every number the input carries is finite (the wire formats cannot carry a NaN,
/// but an input may come from elsewhere, e.g. replay).
fn input_is_finite(input: &Input) -> bool {
    match input {
        Input::Imu(s) => s
            .rate_rps
            .iter()
            .chain(&s.accel_mps2)
            .all(|x| x.is_finite()),
        Input::Baro { pressure_mbar } => pressure_mbar.is_finite() && *pressure_mbar > 0.0,
        Input::Gps(f) => {
            f.lat_deg.is_finite()
                && f.lon_deg.is_finite()
                && f.alt_m.is_finite()
                && f.vel_ned_mps.iter().all(|x| x.is_finite())
        }
        Input::Uplink(u) => u.receiver_batt_v.is_finite() && u.servo_batt_v.is_finite(),
        Input::Compass(_) | Input::Timer => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn still() -> ImuRepr {
        ImuRepr {
            rate_rps: [0.001, 0.0, -0.002],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 30.0,
        }
    }

    /// A core with a short calibration, flying `mode` with a 10 m hover plan.
    fn core_with(mode: FlightMode) -> FlightCore {
        FlightCore::new(
            CoreConfig {
                imu_warm_up_s: 0.1,
                calibration_s: 1.0,
                ..CoreConfig::default()
            },
            FlightParams {
                mode,
                plan: Plan::hover(10.0, 60.0),
            },
        )
    }

    fn short_core() -> FlightCore {
        FlightCore::new(
            CoreConfig {
                imu_warm_up_s: 0.1,
                calibration_s: 1.0,
                ..CoreConfig::default()
            },
            FlightParams::default(),
        )
    }

    #[test]
    fn every_other_imu_sample_is_a_control_step_with_a_servo_command() {
        let mut core = short_core();
        let mut out = Vec::new();
        for k in 0..10u64 {
            core.handle(Input::Imu(still()), k * 10_000, &mut out);
        }
        let servos = out.iter().filter(|a| matches!(a, Action::Servo(_))).count();
        assert_eq!(servos, 5);
        assert_eq!(core.stats().control_steps, 5);
        assert_eq!(core.stats().imu_samples, 10);
    }

    #[test]
    fn watchdog_repeats_the_last_sample_after_12_ms_and_counts_it() {
        let mut core = short_core();
        let mut out = Vec::new();
        core.handle(Input::Imu(still()), 0, &mut out);
        assert_eq!(core.poll_at(), Some(12_000));
        core.handle(Input::Timer, 11_000, &mut out);
        assert_eq!(core.stats().watchdog_fires, 0, "not yet due");
        out.clear();
        core.handle(Input::Timer, 12_000, &mut out);
        assert_eq!(core.stats().watchdog_fires, 1);
        let repeated: Vec<_> = out
            .iter()
            .filter_map(|a| match a {
                Action::Publish(Record::Imu(r)) => Some(r),
                _ => None,
            })
            .collect();
        assert_eq!(repeated.len(), 1);
        assert!(repeated[0].value.repeated);
        assert_eq!(repeated[0].value.imu, still());
        assert_eq!(repeated[0].t_us, 12_000);
        assert_eq!(core.poll_at(), Some(24_000));
    }

    #[test]
    fn calibration_then_auto_switch_starts_a_takeoff() {
        let mut core = core_with(FlightMode::Autonomous);
        let mut out = Vec::new();
        let pilot = PilotUplink {
            rotor_rpm: 1600,
            pulses: heli_proto::scb::Pulses::from_controls(&Controls {
                throttle: 0.8,
                ..Default::default()
            }),
            auto_mode: true,
            bypass: false,
            receiver_batt_v: 4.8,
            servo_batt_v: 4.8,
        };
        core.handle(Input::Uplink(pilot), 0, &mut out);
        for k in 0..200u64 {
            core.handle(Input::Imu(still()), k * 10_000, &mut out);
        }
        match core.phase() {
            Phase::TakingOff { target } => assert!((target.pos_ned_m.z + 10.0).abs() < 1e-6),
            other => panic!("expected take-off, got {other:?}"),
        }
        assert!(out.iter().any(|a| matches!(a, Action::Event(e) if matches!(e.value, CoreEvent::CalibrationDone { .. }))));
    }

    fn uplink(auto_mode: bool, lost: bool) -> PilotUplink {
        let sticks = Controls {
            collective: 0.0,
            throttle: 0.8,
            ..Default::default()
        };
        PilotUplink {
            rotor_rpm: 1600,
            pulses: if lost {
                heli_proto::scb::Pulses::default()
            } else {
                heli_proto::scb::Pulses::from_controls(&sticks)
            },
            auto_mode,
            bypass: false,
            receiver_batt_v: 4.8,
            servo_batt_v: 4.8,
        }
    }

    /// The pilot packet 10 ms after `t`, then four IMU samples 10 ms apart (two control
    /// steps); returns the time of the last.
    fn pilot_then_imu(
        core: &mut FlightCore,
        out: &mut Vec<Action>,
        mut t: u64,
        pilot: PilotUplink,
    ) -> u64 {
        t += 10_000;
        core.handle(Input::Uplink(pilot), t, out);
        for _ in 0..4 {
            t += 10_000;
            core.handle(Input::Imu(still()), t, out);
        }
        t
    }

    /// A calibrated core in manual mode; with `height_m` > 0 the altimeter has told it it is
    /// that high (the IMU says it is still, as in a steady hover).
    fn calibrated_manual_core(height_m: f64) -> (FlightCore, Vec<Action>, u64) {
        let mut core = short_core();
        let mut out = Vec::new();
        core.handle(Input::Uplink(uplink(false, false)), 0, &mut out);
        let mut t = 0u64;
        let p0 = 1013.25;
        for k in 0..4000u64 {
            t = k * 10_000;
            core.handle(Input::Imu(still()), t, &mut out);
            if k % 20 == 0 {
                let calibrated = core.navigator().state().is_some();
                let alt = if calibrated && k > 200 { height_m } else { 0.0 };
                let pressure_mbar = heli_proto::baro::pressure_at_altitude_mbar(alt, p0);
                core.handle(Input::Baro { pressure_mbar }, t, &mut out);
            }
        }
        (core, out, t)
    }

    fn last_servo(out: &[Action]) -> Controls {
        out.iter()
            .rev()
            .find_map(|a| match a {
                Action::Servo(s) => Some(s.value),
                _ => None,
            })
            .unwrap_or_default()
    }

    #[test]
    fn transmitter_lost_on_the_ground_idles_instead_of_taking_off() {
        let (mut core, mut out, mut t) = calibrated_manual_core(0.0);
        assert_eq!(core.phase(), Phase::Manual);
        t = pilot_then_imu(&mut core, &mut out, t, uplink(false, true));
        assert_eq!(core.phase(), Phase::GroundFailsafe);
        let servo = last_servo(&out);
        assert_eq!(servo.collective, 0.0);
        assert_eq!(servo.throttle, 0.0);
        assert!(
            out.iter()
                .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::PilotSignalLost))
        );
        // The signal comes back: the pilot has the helicopter again.
        pilot_then_imu(&mut core, &mut out, t, uplink(false, false));
        assert_eq!(core.phase(), Phase::Manual);
    }

    #[test]
    fn transmitter_lost_in_the_air_is_a_command_to_hover_where_it_is() {
        let (mut core, mut out, t) = calibrated_manual_core(8.0);
        let z = core.navigator().state().map_or(0.0, |s| s.pos_ned_m.z);
        assert!(
            z < -5.0,
            "the altimeter should have lifted the estimate: z = {z}"
        );
        assert_eq!(core.phase(), Phase::Manual);
        pilot_then_imu(&mut core, &mut out, t, uplink(false, true));
        match core.phase() {
            Phase::Holding { target, .. } => assert!((target.pos_ned_m.z - z).abs() < 0.5),
            other => panic!("expected a hover hold, got {other:?}"),
        }
        let servo = last_servo(&out);
        assert!(servo.collective > 0.3 && servo.throttle > 0.7, "{servo:?}");
    }

    #[test]
    fn watchdog_armed_at_start_notices_an_imu_that_never_speaks() {
        let mut core = short_core();
        let mut out = Vec::new();
        core.start(0);
        assert_eq!(core.poll_at(), Some(12_000));
        core.handle(Input::Timer, 12_000, &mut out);
        assert_eq!(core.stats().watchdog_fires, 1);
        assert_eq!(core.stats().control_steps, 0, "nothing to repeat yet");
        assert!(
            out.iter()
                .any(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::WatchdogFired))
        );
    }

    #[test]
    fn inputs_from_the_past_or_not_finite_are_refused_and_counted() {
        let mut core = short_core();
        let mut out = Vec::new();
        core.handle(Input::Imu(still()), 50_000, &mut out);
        out.clear();
        core.handle(Input::Imu(still()), 40_000, &mut out);
        let mut nan = still();
        nan.rate_rps[1] = f64::NAN;
        core.handle(Input::Imu(nan), 60_000, &mut out);
        core.handle(
            Input::Baro {
                pressure_mbar: f64::INFINITY,
            },
            60_000,
            &mut out,
        );
        assert_eq!(core.stats().rejected_inputs, 3);
        assert_eq!(core.stats().imu_samples, 1);
        assert!(out.is_empty(), "a refused input changes nothing");
    }

    #[test]
    fn emergency_bypass_hands_the_pilot_the_helicopter_with_yaw_damping() {
        let mut core = core_with(FlightMode::Autonomous);
        let mut out = Vec::new();
        let mut bypassed = uplink(true, false);
        bypassed.bypass = true;
        core.handle(Input::Uplink(bypassed), 0, &mut out);
        let spinning = ImuRepr {
            rate_rps: [0.0, 0.0, 0.5],
            ..still()
        };
        for k in 0..200u64 {
            let sample = if k < 150 { still() } else { spinning };
            core.handle(Input::Imu(sample), k * 10_000, &mut out);
        }
        assert_eq!(core.phase(), Phase::Manual, "auto switch on, but bypassed");
        let rudder = last_servo(&out).rudder;
        let damper = YawDamper::default();
        assert!(
            rudder < damper.trim,
            "yaw damping opposes the turn: {rudder}"
        );
    }

    #[test]
    fn augmented_mode_follows_the_auto_switch() {
        let mut core = core_with(FlightMode::Augmented(AugmentedMode::Rate));
        let mut out = Vec::new();
        core.handle(Input::Uplink(uplink(true, false)), 0, &mut out);
        for k in 0..200u64 {
            core.handle(Input::Imu(still()), k * 10_000, &mut out);
        }
        assert_eq!(core.phase(), Phase::Augmented(AugmentedMode::Rate));
        assert_eq!(
            FlightMode::Augmented(AugmentedMode::Rate).uplink_labels()[0],
            "RollRate"
        );
        core.handle(Input::Uplink(uplink(false, false)), 2_000_000, &mut out);
        core.handle(Input::Imu(still()), 2_000_000, &mut out);
        core.handle(Input::Imu(still()), 2_010_000, &mut out);
        assert_eq!(core.phase(), Phase::Manual);
    }
}
