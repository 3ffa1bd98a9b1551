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

pub mod aids;
mod brake;
mod degraded;
mod dispatch;
pub mod engine;
mod event;
pub mod gps;
mod main_loop;
pub mod mode_check;
pub mod power;
pub mod preflight;
pub mod restart;
mod roll;
mod sequencer;
pub mod watchdog;
mod weathervane;

pub use aids::Aid;
pub use event::{CoreEvent, Severity};
pub use gps::Implausible;
pub use heli_nav::calibration::Motion;
pub use mode_check::ModeRefusal;
pub use preflight::Refusal;
pub use restart::WarmStart;

use heli_control::{
    HoverController, HoverGains, RollGains, StickScales, Target, YawDamper, augmented_controls,
    manual_with_yaw_damping, rolling_controls,
};
use heli_nav::{BiasCalibration, NavConfig, NavState, Navigator, seconds_between};
use heli_proto::compass::{CompassAdc, CompassCalibration, heading_rad};
use heli_proto::gps::GpsNav;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink};
use heli_types::{AugmentedMode, Device, FlightMode, Leg, Plan};
use nalgebra::Vector3;

use crate::health::{Health, HealthState, IMU_FIRES_TO_INVALID};
use crate::phase::{Phase, RollStage};
use crate::streams::{
    BaroRecord, CompassRecord, ImuRecord, Record, ServoRecord, Stamped, StateRecord,
};
use watchdog::{WATCHDOG_PERIOD_US, Watchdog};

/// Longest the roll maneuver waits to settle on its trim speed before giving up (s).
pub const ACCELERATE_TIMEOUT_S: f64 = 20.0;

/// How far under the hover collective the blind failsafe sets the collective: a slow
/// descent (about 1 m/s on the X-Cell 60 model) rather than a climb or a drop.
pub const BLIND_DESCENT_COLLECTIVE_MARGIN: f64 = 0.06;

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
    /// The batteries' gauges and the battery failsafe (`core::power`).
    pub power: power::PowerConfig,
    /// When the rotor speed means an engine failure.
    pub engine: engine::EngineWatch,
    /// The autorotation that answers it.
    pub autorotation: heli_control::autorotation::AutorotationGains,
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
            power: power::PowerConfig::default(),
            engine: engine::EngineWatch::default(),
            autorotation: heli_control::autorotation::AutorotationGains::default(),
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
    /// A driver gave up on its device (the altimeter never answered its handshake, the
    /// port could not be opened or read).
    DeviceFailed(Device),
    /// The flight battery's voltage.
    Battery {
        /// Terminal voltage (V).
        volts: f64,
    },
    /// The hot-swap's digital input: what powers the avionics (sent on each change, and
    /// once at start).
    PowerSource(heli_power::PowerSource),
    /// Whether the bootstrap hears a ground station (a vehicle without a link sends none).
    GroundLink {
        /// A ground heard in the last few seconds.
        fresh: bool,
    },
    /// The watchdog timer (deliver at [`FlightCore::poll_at`]).
    Timer,
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
    /// GPS fixes refused before the filter: off the globe, or a jump no helicopter makes.
    pub gps_implausible: u32,
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
    /// The altimeter and compass as reported refused by the filter's gate.
    refused_aids: aids::RefusedAids,
    /// The helicopter has been more than a metre up in this flight.
    has_flown: bool,
    /// A hold begun in motion is still braking to a stop.
    braking: Option<brake::Brake>,
    health: Health,
    /// Watchdog fires since the last real IMU packet.
    imu_fires_in_row: u32,
    /// False once the IMU stayed silent too long: the estimate is not used again.
    estimate_valid: bool,
    /// The servo board's uplink is silent (or its driver failed): transmitter loss.
    uplink_lost: bool,
    /// The helicopter has been airborne (above `airborne_height_m`) in this flight.
    airborne_once: bool,
    /// The last GPS fix that passed the plausibility check, with its time.
    last_good_fix: Option<(u64, GpsNav)>,
    /// An in-air alignment after a restart, instead of the ground calibration.
    alignment: Option<restart::Alignment>,
    /// The average servo command of autonomous flight in the air (for a restart).
    trim: Option<Controls>,
    /// During the calibration window: the compass heading when it opened, and the
    /// readings' running average (rad).
    calibration_heading: Option<(f64, f64)>,
    /// A refusal standing in the air until the pilot's switch goes off (`mode_check`).
    refused_in_air: Option<ModeRefusal>,
    /// Since when the rotor has been below the engine watch's threshold in the air.
    engine_low_since_us: Option<u64>,
    /// The rotor speeds of the last control steps (µs, rpm), oldest first.
    rotor_history: std::collections::VecDeque<(u64, f64)>,
    /// The engine failure was raised: autorotation for the rest of the flight.
    engine_failed: bool,
    /// The autorotation under way.
    autorotation: Option<heli_control::autorotation::Autorotation>,
    /// What was raised while the switch has been on (the failing conditions so far).
    refusal_raised: Option<ModeRefusal>,
    /// The batteries' gauges and the hot-swap's log.
    power: power::Power,
    /// Whether the bootstrap hears a ground, on a vehicle with a link.
    ground_link: Option<bool>,
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
            refused_aids: aids::RefusedAids::default(),
            has_flown: false,
            braking: None,
            health: Health::default(),
            imu_fires_in_row: 0,
            estimate_valid: true,
            uplink_lost: false,
            airborne_once: false,
            last_good_fix: None,
            alignment: None,
            trim: None,
            calibration_heading: None,
            refused_in_air: None,
            engine_low_since_us: None,
            rotor_history: std::collections::VecDeque::with_capacity(16),
            engine_failed: false,
            autorotation: None,
            refusal_raised: None,
            power: power::Power::new(&config.power),
            ground_link: None,
            stats: CoreStats::default(),
        }
    }

    /// Arms the watchdog at start-up (the thesis sets it up before entering the main loop),
    /// so that an IMU that never sends is noticed too. Without this call it arms on the first
    /// IMU packet.
    ///
    /// Every device's watchdog starts here too: a device that never speaks is reported
    /// silent after its timeout (`crate::health`).
    pub fn start(&mut self, now_us: u64) {
        self.last_input_us = self.last_input_us.max(now_us);
        self.watchdog.kick(now_us);
        for device in Device::ALL {
            self.health.monitor_mut(device).arm(now_us);
        }
    }

    /// The configuration it runs with.
    pub fn config(&self) -> &CoreConfig {
        &self.config
    }

    /// Every device's watchdog.
    pub fn health(&self) -> &Health {
        &self.health
    }

    /// False once the IMU stayed silent for too long and the estimate was declared invalid.
    pub fn estimate_valid(&self) -> bool {
        self.estimate_valid
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

    /// The batteries' gauges and the hot-swap's log.
    pub fn power(&self) -> &power::Power {
        &self.power
    }

    /// The navigation filter (estimate and aiding statistics).
    pub fn navigator(&self) -> &Navigator {
        &self.nav
    }

    /// The loop watchdog's deadline (µs): one period after the last IMU packet or fire, or
    /// `None` before it is armed.
    pub fn watchdog_deadline_us(&self) -> Option<u64> {
        self.watchdog.deadline_us()
    }

    /// When the caller must deliver [`Input::Timer`] next: the loop watchdog's deadline or
    /// a device watchdog's, whichever comes first.
    pub fn poll_at(&self) -> Option<u64> {
        match (self.watchdog.deadline_us(), self.health.deadline_us()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// A device delivered a sample at `now_us`.
    fn heard(&mut self, device: Device, now_us: u64, out: &mut Vec<Action>) {
        let before = self.health.state(device);
        if let Some(state) = self.health.monitor_mut(device).sample(now_us) {
            // A device's first word after start-up is no news; any other change is.
            self.health_changed(device, state, before != HealthState::Waiting, now_us, out);
        }
    }

    /// Raises a device's change of state (when `raise`) and acts on it.
    fn health_changed(
        &mut self,
        device: Device,
        state: HealthState,
        raise: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        if raise {
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::DeviceHealth { device, state },
            )));
        }
        if device == Device::Uplink {
            let lost = matches!(state, HealthState::Silent | HealthState::Failed);
            if lost && !self.uplink_lost {
                out.push(Action::Event(Stamped::new(now_us, CoreEvent::UplinkLost)));
            }
            self.uplink_lost = lost;
        }
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
                self.heard(Device::Imu, now_us, out);
                self.imu_fires_in_row = 0;
                self.watchdog.kick(now_us);
                self.loop_iteration(sample, false, now_us, out);
            }
            Input::DeviceFailed(device) => {
                if let Some(state) = self.health.monitor_mut(device).fail() {
                    self.health_changed(device, state, true, now_us, out);
                }
            }
            Input::Timer => {
                for (device, state) in self.health.check(now_us).into_iter().flatten() {
                    self.health_changed(device, state, true, now_us, out);
                }
                if self.watchdog.expired(now_us) {
                    self.watchdog.kick(now_us);
                    // An IMU that has not spoken yet (a port still opening, a slow boot) has
                    // no estimate to invalidate: only fires after a first sample count.
                    if self.last_imu.is_some() {
                        self.imu_fires_in_row = self.imu_fires_in_row.saturating_add(1);
                    }
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::WatchdogFired,
                    )));
                    if self.imu_fires_in_row >= IMU_FIRES_TO_INVALID && self.estimate_valid {
                        self.estimate_valid = false;
                        out.push(Action::Event(Stamped::new(
                            now_us,
                            CoreEvent::EstimateInvalid,
                        )));
                    }
                    if let Some(last) = self.last_imu {
                        self.loop_iteration(last, true, now_us, out);
                    }
                }
            }
            Input::Uplink(uplink) => {
                self.stats.uplinks = self.stats.uplinks.saturating_add(1);
                self.heard(Device::Uplink, now_us, out);
                let was_lost = self.pilot.is_some_and(|p| p.signal_lost());
                if uplink.signal_lost() && !was_lost {
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::PilotSignalLost,
                    )));
                }
                self.pilot = Some(uplink);
                self.read_battery(
                    power::Battery::Receiver,
                    uplink.receiver_batt_v,
                    now_us,
                    out,
                );
                self.read_battery(power::Battery::Servo, uplink.servo_batt_v, now_us, out);
                out.push(Action::Publish(Record::Uplink(Stamped::new(
                    now_us, uplink,
                ))));
            }
            Input::Gps(fix) => {
                self.stats.gps_fixes = self.stats.gps_fixes.saturating_add(1);
                self.heard(Device::Gps, now_us, out);
                // Checked before the filter sees it: a fix off the globe, or one that
                // jumps faster than any helicopter flies from the last good one, is refused.
                if let Some(why) = gps::implausible(&fix, self.last_good_fix, now_us) {
                    self.stats.gps_implausible = self.stats.gps_implausible.saturating_add(1);
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::GpsImplausible(why),
                    )));
                } else {
                    self.last_good_fix = Some((now_us, fix));
                    let resets = self.nav.stats().gps_resets;
                    self.nav.fuse_gps(now_us, &fix);
                    if self.nav.stats().gps_resets != resets {
                        out.push(Action::Event(Stamped::new(now_us, CoreEvent::GpsReset)));
                    }
                }
                out.push(Action::Publish(Record::Gps(Stamped::new(now_us, fix))));
            }
            Input::Baro { pressure_mbar } => {
                self.stats.baro_readings = self.stats.baro_readings.saturating_add(1);
                self.heard(Device::Baro, now_us, out);
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
                self.heard(Device::Compass, now_us, out);
                let field = self.config.compass.apply(&adc.raw_field());
                self.nav.fuse_compass(&field);
                let (roll, pitch) = self.nav.state().map_or((0.0, 0.0), |s| {
                    let (r, p, _) = s.euler_rad();
                    (r, p)
                });
                let heading = heading_rad(&field, roll, pitch);
                if let Some(h) = heading {
                    self.watch_calibration_heading(now_us, h, out);
                }
                out.push(Action::Publish(Record::Compass(Stamped::new(
                    now_us,
                    CompassRecord {
                        adc,
                        field,
                        heading_rad: heading,
                    },
                ))));
            }
            Input::Battery { volts } => {
                self.read_battery(power::Battery::Flight, volts, now_us, out);
            }
            Input::PowerSource(source) => self.read_power_source(source, now_us, out),
            Input::GroundLink { fresh } => self.ground_link = Some(fresh),
        }
    }
}

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
        Input::Battery { volts } => volts.is_finite(),
        Input::Compass(_)
        | Input::DeviceFailed(_)
        | Input::Timer
        | Input::GroundLink { .. }
        | Input::PowerSource(_) => true,
    }
}

#[cfg(test)]
mod dispatch_tests;
#[cfg(test)]
mod edge_tests;
#[cfg(test)]
mod engine_tests;
#[cfg(test)]
mod mode_check_tests;
#[cfg(test)]
mod parts_tests;
#[cfg(test)]
mod power_tests;
#[cfg(test)]
mod restart_tests;
#[cfg(test)]
mod roll_tests;
#[cfg(test)]
mod sequencer_tests;
#[cfg(test)]
mod tests;
