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
//!
//! F´-style components, each owning its state, each in one file with its tests, and a thin
//! core ([`FlightCore`] here, the loop's routing in `step`) that routes between them:
//!
//! | component | owns | takes | gives |
//! |---|---|---|---|
//! | [`main_loop::MainLoop`] | the watchdog, the last sample, the step clock | IMU samples, the timer | the loop's iterations, the watchdog's fires, the estimate declared invalid |
//! | [`calibration::GroundCalibration`] | the 80 s bias calibration, the heading watch | real samples, compass headings | the biases, restarts |
//! | [`devices::DeviceWatch`] | every device's watchdog, the pilot, the link | samples heard, failures, the timer | health events, transmitter loss, the sticks |
//! | [`aids::Aiding`] | the aids refused, the GPS outage, the last good fix | GPS fixes, the filter's health | refused fixes, aid and GPS events |
//! | [`sequencer::Sequencer`] | the phase, the plan and its leg, home, the stop | the estimate and its crew | the phase, plan events |
//! | [`roll`] | (the stage travels in the phase) | the stage, the estimate | the next stage or leg, the roll's end |
//! | [`mode_check::ModeCheck`] | the refusal standing | the safety facts, the switch | refusals |
//! | [`engine::Engine`] | the rotor's speeds, the failure, the autorotation | the rotor speed, the phase | the failure, the autorotation's phase and commands |
//! | [`power::Power`] | the gauges, the levels raised and acted on, the hot-swap's log | voltages, the hot-swap | battery events, the failsafe due |
//! | [`restart::Restart`] | the in-air alignment, the trim | samples while aligning, commands | the estimate started in the air, the trim |

pub mod aids;
pub mod battery_channel;
mod blind;
mod brake;
pub mod calibration;
mod degraded;
pub mod devices;
pub mod engine;
mod event;
pub mod gps;
pub mod legs;
pub mod main_loop;
pub mod mode_check;
pub mod power;
pub mod preflight;
mod request;
pub mod restart;
mod resume;
pub mod roll;
pub mod sequencer;
mod step;
pub mod stop;
pub mod watchdog;
mod weathervane;

pub use aids::Aid;
pub use event::{CoreEvent, ReadingFault, Severity};
pub use gps::Implausible;
pub use heli_nav::calibration::{LeftOut, Motion};
pub use mode_check::ModeRefusal;
pub use preflight::Refusal;
pub use restart::{RollRecord, WarmStart};
pub use stop::{StopAnswer, StopRefusal};

use heli_control::{HoverController, HoverGains, RollGains, StickScales, YawDamper};
use heli_nav::{NavConfig, Navigator};
use heli_proto::compass::{CompassAdc, CompassCalibration, heading_rad};
use heli_proto::gps::GpsNav;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink};
use heli_types::{Device, FlightMode, Plan};
use nalgebra::Vector3;

use crate::health::Health;
use crate::phase::Phase;
use crate::streams::Stamped;
use crate::streams::{BaroRecord, CompassRecord, Record};
use aids::Aiding;
use calibration::GroundCalibration;
use devices::DeviceWatch;
use engine::Engine;
use main_loop::MainLoop;
use mode_check::ModeCheck;
use power::Power;
use restart::Restart;
use sequencer::Sequencer;
use watchdog::WATCHDOG_PERIOD_US;

// What the core's component tests name through `use super::*`.
#[cfg(test)]
use {
    crate::health::HealthState,
    crate::phase::RollStage,
    heli_control::{Target, augmented_controls, manual_with_yaw_damping, rolling_controls},
    heli_nav::NavState,
    heli_types::{AugmentedMode, Leg},
};

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
    /// The operator asked to stop the flight (`stop`): answered with
    /// [`CoreEvent::Stop`].
    StopRequested,
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

/// The main control process: a thin core that routes each input to the components that own
/// the state it concerns, and each control step through them in order. Each component
/// lives in a file of its own, with its tests.
#[derive(Clone, Debug)]
pub struct FlightCore {
    config: CoreConfig,
    /// The loop's timing: the watchdog, the last sample, the step clock (`main_loop`).
    main_loop: MainLoop,
    /// The ground calibration of the IMU biases (`calibration`).
    calibration: GroundCalibration,
    /// The navigation filter (`heli_nav`).
    nav: Navigator,
    /// The aids' and the GPS fixes' watch (`aids`).
    aiding: Aiding,
    /// The devices' watchdogs and the pilot (`devices`).
    devices: DeviceWatch,
    /// The phase, the plan and where it is in it (`sequencer`).
    seq: Sequencer,
    /// The safety rule at the pilot's switch (`mode_check`).
    modes: ModeCheck,
    /// The engine's watch and the autorotation (`engine`).
    engine: Engine,
    /// The batteries' gauges and the hot-swap's log (`power`).
    power: Power,
    /// The alignment after a restart in the air, and the trim kept for one (`restart`).
    restart: Restart,
    /// The hover controller's state (its integrators), kept across phases that fly it.
    hover: HoverController,
    /// This control step's body rates from a real IMU sample, less the known gyro bias;
    /// `None` when the watchdog repeated the last sample (what a roll the estimate is gone
    /// from is finished on: `roll::blind_step`).
    gyro_rps: Option<Vector3<f64>>,
    stats: CoreStats,
    last_input_us: u64,
}

impl FlightCore {
    /// A core that has just been started by the bootstrap with the ground's parameters.
    pub fn new(config: CoreConfig, params: FlightParams) -> Self {
        Self {
            config,
            main_loop: MainLoop::new(config.watchdog_us),
            calibration: GroundCalibration::new(config.imu_warm_up_s, config.calibration_s),
            nav: Navigator::new(config.nav),
            aiding: Aiding::default(),
            devices: DeviceWatch::default(),
            seq: Sequencer::new(params),
            modes: ModeCheck::default(),
            engine: Engine::default(),
            power: power::Power::new(&config.power),
            restart: Restart::default(),
            hover: HoverController::new(config.hover),
            gyro_rps: None,
            stats: CoreStats::default(),
            last_input_us: 0,
        }
    }

    /// A core started again in the air from what the process before it left. A record
    /// from a helicopter that never flew gives an ordinary start, calibration included,
    /// except that the auto switch must be seen off before it takes off on its own
    /// (`preflight::Request::AfterRestart`): the switch the process before was refused on,
    /// or was waiting on, is no new request.
    pub fn restarted(config: CoreConfig, params: FlightParams, warm: WarmStart) -> Self {
        let mut core = Self::new(config, params);
        if !warm.airborne {
            core.seq.takeoff = preflight::Request::AfterRestart;
            return core;
        }
        if let Some(origin) = warm.origin {
            core.nav.set_origin(origin);
        }
        core.nav.restore_ground_references(warm.references);
        core.seq.home_ned_m = warm.home_ned_m.map(Vector3::from);
        core.seq.airborne_once = true;
        core.seq.has_flown = true;
        core.seq.plan_abandoned = true;
        match warm.roll {
            Some(roll) => core.restart_in_roll(warm, roll),
            None => {
                core.restart = Restart::aligning_from(warm);
                core.seq.phase = Phase::BlindDescent;
            }
        }
        core
    }

    /// Arms the watchdog at start-up (the thesis sets it up before entering the main loop),
    /// so that an IMU that never sends is noticed too. Without this call it arms on the first
    /// IMU packet.
    ///
    /// Every device's watchdog starts here too: a device that never speaks is reported
    /// silent after its timeout (`crate::health`).
    pub fn start(&mut self, now_us: u64) {
        self.last_input_us = self.last_input_us.max(now_us);
        self.main_loop.start(now_us);
        self.devices.start(now_us);
    }

    /// The configuration it runs with.
    pub fn config(&self) -> &CoreConfig {
        &self.config
    }

    /// Every device's watchdog.
    pub fn health(&self) -> &Health {
        self.devices.health()
    }

    /// False once the IMU stayed silent for too long and the estimate was declared invalid.
    pub fn estimate_valid(&self) -> bool {
        self.main_loop.estimate_valid()
    }

    /// Loop counters.
    pub fn stats(&self) -> CoreStats {
        CoreStats {
            watchdog_fires: self.main_loop.fires(),
            ..self.stats
        }
    }

    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.seq.phase()
    }

    /// True once the last leg of the flight plan is done.
    pub fn plan_complete(&self) -> bool {
        self.seq.plan_complete()
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
        self.main_loop.deadline_us()
    }

    /// When the caller must deliver [`Input::Timer`] next: the loop watchdog's deadline or
    /// a device watchdog's, whichever comes first.
    pub fn poll_at(&self) -> Option<u64> {
        match (
            self.main_loop.deadline_us(),
            self.devices.health().deadline_us(),
        ) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The safety rule's conditions as the core observes them now (the same rule the
    /// ground display shows).
    pub fn safety_facts(&self) -> heli_control::safety::Facts {
        mode_check::safety_facts(
            self.seq.phase,
            self.main_loop.estimate_valid(),
            &self.devices,
            &self.aiding,
            &self.power,
        )
    }

    /// A refusal of the safety rule standing in the air, if any.
    pub fn mode_refusal(&self) -> Option<ModeRefusal> {
        self.modes.refused_in_air()
    }

    /// True while an in-air alignment is under way.
    pub fn aligning(&self) -> bool {
        self.restart.aligning()
    }

    /// What this process would leave its successor now (`None` before the calibration).
    pub fn warm_start(&self) -> Option<WarmStart> {
        let state = self.nav.state()?;
        let b = state.gyro_bias_rps;
        Some(WarmStart {
            gyro_bias_rps: [b.x, b.y, b.z],
            origin: self.nav.origin(),
            home_ned_m: self.seq.home_ned_m.map(|h| [h.x, h.y, h.z]),
            airborne: self.seq.airborne_once,
            trim: self.restart.trim(),
            references: self.nav.ground_references(),
            roll: self.roll_record(&state.pos_ned_m),
        })
    }

    /// A real IMU sample after the estimate was declared invalid: in the air, the estimate
    /// starts again by an alignment as after a restart (the gyro biases, the origin and
    /// home kept), and is used again when it is done (`step`); on the ground it is not.
    fn resume_after_stall(&mut self) {
        // Restarted in a roll: the alignment from the record once the roll is over.
        if !self.seq.phase.rolling() && self.restart.align_after_roll() {
            return;
        }
        if self.main_loop.estimate_valid() || self.restart.aligning() || !self.seq.airborne_once {
            return;
        }
        // A roll under way is finished first: the accelerometers of a rolling helicopter
        // say nothing of which way is up.
        if self.seq.phase.rolling() {
            return;
        }
        if let Some(warm) = self.warm_start() {
            self.restart.align_after_stall(warm);
            self.seq.plan_abandoned = true;
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
                self.devices.heard(Device::Imu, now_us, out);
                self.main_loop.imu(now_us);
                self.carry_through_roll(&sample, now_us);
                self.resume_unseen_roll(&sample, now_us, out);
                self.resume_after_stall();
                self.loop_iteration(sample, false, now_us, out);
            }
            Input::DeviceFailed(device) => self.devices.failed(device, now_us, out),
            Input::Timer => {
                self.devices.check(now_us, out);
                let fires_to_invalid = if self.seq.phase.rolling() {
                    crate::health::IMU_FIRES_TO_INVALID_IN_ROLL
                } else {
                    crate::health::IMU_FIRES_TO_INVALID
                };
                if let Some(fire) = self.main_loop.timer_within(now_us, fires_to_invalid) {
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::WatchdogFired,
                    )));
                    if fire.estimate_invalidated {
                        out.push(Action::Event(Stamped::new(
                            now_us,
                            CoreEvent::EstimateInvalid,
                        )));
                    }
                    if let Some(last) = fire.repeat {
                        self.loop_iteration(last, true, now_us, out);
                    }
                }
            }
            Input::Uplink(uplink) => {
                self.stats.uplinks = self.stats.uplinks.saturating_add(1);
                self.devices.heard(Device::Uplink, now_us, out);
                self.devices.uplink(uplink, now_us, out);
                self.power.read_battery(
                    power::Battery::Receiver,
                    uplink.receiver_batt_v,
                    now_us,
                    out,
                );
                self.power
                    .read_battery(power::Battery::Servo, uplink.servo_batt_v, now_us, out);
                out.push(Action::Publish(Record::Uplink(Stamped::new(
                    now_us, uplink,
                ))));
            }
            Input::Gps(fix) => {
                self.stats.gps_fixes = self.stats.gps_fixes.saturating_add(1);
                self.devices.heard(Device::Gps, now_us, out);
                if self.aiding.gps(&mut self.nav, &fix, now_us, out) {
                    self.stats.gps_implausible = self.stats.gps_implausible.saturating_add(1);
                }
                out.push(Action::Publish(Record::Gps(Stamped::new(now_us, fix))));
            }
            Input::Baro { pressure_mbar } => {
                self.stats.baro_readings = self.stats.baro_readings.saturating_add(1);
                self.devices.heard(Device::Baro, now_us, out);
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
                self.devices.heard(Device::Compass, now_us, out);
                let field = self.config.compass.apply(&adc.raw_field());
                self.nav.fuse_compass(&field);
                let (roll, pitch) = self.nav.state().map_or((0.0, 0.0), |s| {
                    let (r, p, _) = s.euler_rad();
                    (r, p)
                });
                let heading = heading_rad(&field, roll, pitch);
                if let Some(h) = heading {
                    self.watch_calibration_heading(h);
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
                self.power
                    .read_battery(power::Battery::Flight, volts, now_us, out);
            }
            Input::PowerSource(source) => self.power.read_power_source(source, now_us, out),
            Input::GroundLink { fresh } => self.devices.ground_link(fresh),
            Input::StopRequested => self.stop_requested(now_us, out),
        }
    }

    /// The operator's Stop: answered at once ([`stop::answer`]); a landing first is flown
    /// by the sequencer and its end said from the control step.
    fn stop_requested(&mut self, now_us: u64, out: &mut Vec<Action>) {
        let est = self
            .nav
            .state()
            .copied()
            .filter(|_| self.main_loop.estimate_valid());
        let settled = est
            .as_ref()
            .is_some_and(|e| stop::settled(self.seq.height_above_home(e), e.vel_ned_mps.norm()));
        let answer = stop::answer(self.seq.phase, self.seq.airborne_once, settled);
        self.seq.operator_stop = answer == StopAnswer::Landing;
        out.push(Action::Event(Stamped::new(now_us, CoreEvent::Stop(answer))));
    }

    /// A compass heading, for the calibration's watch of a heading that moves while the
    /// gyros see the helicopter still.
    pub(super) fn watch_calibration_heading(&mut self, heading_rad: f64) {
        self.calibration.heading(heading_rad);
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
        | Input::StopRequested
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
mod engine_watch_tests;
#[cfg(test)]
mod mode_check_tests;
#[cfg(test)]
mod parts_tests;
#[cfg(test)]
mod power_tests;
#[cfg(test)]
mod preflight_tests;
#[cfg(test)]
mod restart_tests;
#[cfg(test)]
mod resume_tests;
#[cfg(test)]
mod roll_tests;
#[cfg(test)]
mod sequencer_tests;
#[cfg(test)]
mod skids_tests;
#[cfg(test)]
mod stall_tests;
#[cfg(test)]
mod stop_tests;
#[cfg(test)]
mod test_routes;
#[cfg(test)]
mod tests;
