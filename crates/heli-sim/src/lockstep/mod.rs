//! Lockstep simulation: the helicopter, its simulated devices and the flight software in one
//! process on one virtual clock, as fast as the CPU allows (or paced to the wall clock).
//!
//! Everything the flight software learns crosses a device wire: the simulator encodes bytes,
//! the flight software's drivers frame and parse them, and the servo commands go back as
//! bytes that the simulated servo controller board parses. Bytes arrive when their last byte
//! would have arrived at the device's baud rate.
//!
//! Events are ordered by (time, class, sequence), so a run is a pure function of the scenario
//! and seed: same inputs, same outputs, bit for bit.

mod batteries;
mod criteria;
mod fault_clock;
mod hil;
mod inject;
mod metrics;
mod power;
mod setup;
mod transmitter;
mod truth;
mod wires;

use hil::Hil;
pub use hil::{HIL_BATTERY_CHANNEL, HilOut};
use inject::Injector;
use metrics::Metrics;
pub use power::Restarted;
pub use setup::{FIELD_ORIGIN, calibrate_compass, field_earth_field_gauss};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::{Duration, Instant};
pub use truth::TruthFrame;

use heli_fsw::computer::{DeviceInput, FlightComputer, RecordedInput};
use heli_fsw::core::{Action, CoreConfig, CoreEvent, FlightCore, FlightParams};
use heli_fsw::phase::Phase;
use heli_fsw::streams::{Record, StateRecord, Streams};
use heli_nav::GeoOrigin;
use heli_nav::compass_cal::fit_hard_iron;
use heli_proto::baro::pressure_at_altitude_mbar;
use heli_proto::battery::BatteryAdc;
use heli_proto::compass::{CompassAdc, CompassCalibration, MagField};
use heli_proto::scb::Controls;
use heli_types::FlightMode;
use heli_types::Port;
use nalgebra::{UnitQuaternion, Vector3};

use crate::devices::baro::{BaroDevice, BaroErrors, ground_effect_mbar};
use crate::devices::compass::{CompassDevice, CompassErrors};
use crate::devices::gps::{GpsDevice, GpsErrors};
use crate::devices::imu::{ImuDevice, ImuErrors, RotorPhase};
use crate::devices::scb::{PilotCommand, ScbDevice};
use crate::devices::{Bytes, Noise, transmit_time_us};
use crate::summary::{
    Criterion, DeviceSummary, EstimatorSummary, HoldSummary, InvariantSummary, LinkSummary,
    LoopSummary, ManeuverSummary, Outcome, Rms, Summary,
};
use heli_fsw::phase::RollStage;
use heli_model::actuators::{Actuators, ServoParams, control_inputs};
use heli_model::model::{Environment, Helicopter};
use heli_model::turbulence::Turbulence;
use heli_scenario::pilot::{HoveringPilot, seen_by_pilot};
use heli_scenario::{Scenario, ScenarioError};
use heli_types::AugmentedMode;
use heli_types::Plan;

/// Physics integration step (µs): 200 Hz RK4, twice the rate H15 integrated at, and a
/// divisor of the IMU's 10 ms so every IMU sample reads a state of its own instant. The
/// stiffest modes are the skids on the ground (|λ| ≈ 130 /s with four points touching:
/// |λ dt| ≈ 0.65, well inside RK4's stability limit of 2.8); docs/model.md.
pub const PHYSICS_STEP_US: u64 = 5_000;
/// IMU period (µs).
pub const IMU_PERIOD_US: u64 = 10_000;
/// Servo board uplink period (µs).
pub const UPLINK_PERIOD_US: u64 = 20_000;
/// GPS epoch period (µs).
pub const GPS_PERIOD_US: u64 = 1_000_000;
/// Compass read period (µs).
pub const COMPASS_PERIOD_US: u64 = 50_000;
/// Battery read period (µs).
pub const BATTERY_PERIOD_US: u64 = 1_000_000;
/// Touching down faster than this is a crash (m/s).
pub const CRASH_SINK_MPS: f64 = 3.0;
/// Tilting beyond this with a skid on the ground is a roll-over (rad).
pub const CRASH_TILT_RAD: f64 = 1.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    /// Bytes from the flight computer reach a device.
    ToDevice(Port, Bytes),
    /// A device samples or transmits.
    ImuSample,
    UplinkSample,
    GpsEpoch,
    BaroTransmit,
    CompassRead,
    BatteryRead,
    /// Bytes from a device reach the flight computer.
    ToComputer(Port, Bytes),
    /// The flight computer's next deadline (its watchdogs, the altimeter's reply timeout).
    Tick,
    /// Advance the physics one step.
    Physics,
}

impl Kind {
    /// Order of events at the same instant: actuators take commands, devices sample the
    /// state, the computer reads, timers fire, and only then does physics move on.
    fn class(&self) -> u8 {
        match self {
            Kind::ToDevice(..) => 0,
            Kind::ImuSample
            | Kind::UplinkSample
            | Kind::GpsEpoch
            | Kind::BaroTransmit
            | Kind::CompassRead
            | Kind::BatteryRead => 1,
            Kind::ToComputer(..) => 2,
            Kind::Tick => 3,
            Kind::Physics => 9,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Event {
    t_us: u64,
    class: u8,
    seq: u64,
    kind: Kind,
}

impl PartialOrd for Bytes {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Bytes {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.as_slice().cmp(other.as_slice())
    }
}

/// How to run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Pace the run to the wall clock (otherwise as fast as possible).
    pub realtime: bool,
    /// Stop at this simulated time instead of the scenario's duration (s).
    pub duration_s: Option<f64>,
}

/// Everything that went into the flight software and everything that came out, in order.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// Each device input with the time it reached the flight computer (µs).
    pub inputs: Vec<(u64, RecordedInput)>,
    /// Each action, in the order the core produced them.
    pub actions: Vec<Action>,
}

/// One simulated flight. Cloning it forks the run: both copies continue identically.
#[derive(Clone)]
pub struct Simulation {
    scenario: Scenario,
    heli: Helicopter,
    actuators: Actuators,
    hands: HoveringPilot,
    hand_sticks: Option<Controls>,
    /// How long the scripted pilot of an augmented flight has held its script back,
    /// waiting on the skids for the mode to engage (µs).
    script_delay_us: u64,
    /// A live transmitter (a person at `heli hilsim --pilot`): replaces the scripted pilot.
    live_pilot: Option<PilotCommand>,
    core_setup: (CoreConfig, FlightParams),
    recorded: Option<Recording>,
    step_times: Option<Vec<Duration>>,
    turbulence: Turbulence,
    gust_ned_mps: Vector3<f64>,
    rotor_azimuth_rad: f64,
    env: Environment,
    imu: ImuDevice,
    scb: ScbDevice,
    gps: GpsDevice,
    baro: BaroDevice,
    compass: CompassDevice,
    power: batteries::SimPower,
    drop_noise: Noise,
    /// Random byte loss (a stream of its own, so other noise is unchanged by it).
    loss_noise: Noise,
    /// The last IMU packet sent, repeated while the IMU is stuck.
    last_imu_bytes: Option<Bytes>,
    /// The fault catalog's state.
    injector: Injector,
    computer: FlightComputer,
    /// While the flight computer has no power (a brown-out): the record its flight process
    /// left for the next one.
    browned_out: Option<Option<heli_fsw::core::WarmStart>>,
    /// Restarted flight processes get no warm start ([`Simulation::forget_warm_start`]).
    cold_restarts: bool,
    streams: Streams,
    queue: BinaryHeap<Reverse<Event>>,
    seq: u64,
    now_us: u64,
    tick_at: Option<u64>,
    actions: Vec<Action>,
    to_devices: Vec<(Port, Bytes)>,
    metrics: Metrics,
    crash: Option<String>,
    /// Set when the flight software runs elsewhere (hardware in the loop).
    hil: Option<Hil>,
    /// The flight software's events, as it raised them.
    core_events: Vec<heli_fsw::Stamped<CoreEvent>>,
    /// Every device input, kept for the flight log when asked for.
    input_log: Option<Vec<(u64, RecordedInput)>>,
    /// The flight computers started again while the inputs were kept.
    restarts: Vec<Restarted>,
    /// Faults timed from a phase of the flight, waiting for it.
    fault_clock: fault_clock::FaultClock,
}

impl Simulation {
    /// Sets up the scenario's flight: helicopter on the ground with the rotor governed at
    /// 1600 rpm, devices powered, flight software started with the scenario's parameters.
    pub fn new(scenario: Scenario) -> Result<Self, ScenarioError> {
        Self::with_flight_software(scenario, CoreConfig::default())
    }

    /// Sets up the scenario's flight with the flight software configured as `config` (its
    /// compass calibration is replaced by the one the lab measures before the flight).
    pub fn with_flight_software(
        scenario: Scenario,
        config: CoreConfig,
    ) -> Result<Self, ScenarioError> {
        let mut sim = Self::build(scenario, config)?;
        sim.start_flight_computer();
        Ok(sim)
    }

    /// Runs to the end of the flight plan, the duration, or a crash.
    pub fn run(self, options: RunOptions, progress: impl FnMut(f64, f64)) -> Summary {
        self.run_observed(options, progress, |_| {})
    }

    /// Runs like [`Simulation::run`], calling `observe` after every physics step — the place
    /// for an observer such as the flight logger, which reads the streams and never writes.
    pub fn run_observed(
        mut self,
        options: RunOptions,
        mut progress: impl FnMut(f64, f64),
        mut observe: impl FnMut(&Simulation),
    ) -> Summary {
        let wall_start = Instant::now();
        let duration_s = options.duration_s.unwrap_or(self.scenario.duration_s);
        let end_us = (duration_s * 1e6) as u64;
        let mut next_progress_us = 0;
        while self.advance(end_us) {
            observe(&self);
            if self.now_us >= next_progress_us {
                progress(self.now_us as f64 * 1e-6, duration_s);
                next_progress_us += 1_000_000;
            }
            if options.realtime {
                let due = wall_start + Duration::from_micros(self.now_us);
                if let Some(wait) = due.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
            }
        }
        observe(&self);
        let wall = wall_start.elapsed().as_secs_f64();
        self.summarise(wall)
    }

    /// Ends the run here and judges it; `wall_s` is how long it took.
    pub fn finish(self, wall_s: f64) -> Summary {
        self.summarise(wall_s)
    }

    /// Serial bytes the scenario's `byte_loss` took so far.
    pub fn bytes_lost(&self) -> u64 {
        self.metrics.bytes_lost
    }

    /// Keeps every device input from now on, for the flight log (`heli log replay` feeds
    /// them back). The flight computer was started at 0 s.
    pub fn log_device_inputs(&mut self) {
        self.input_log.get_or_insert_with(Vec::new);
    }

    /// The device inputs kept since [`Simulation::log_device_inputs`].
    pub fn device_inputs(&self) -> &[(u64, RecordedInput)] {
        self.input_log.as_deref().unwrap_or_default()
    }

    /// The flight computers started in place of the one before (brown-outs' ends) since
    /// [`Simulation::log_device_inputs`], in order, each placed among the device inputs.
    pub fn restarts(&self) -> &[Restarted] {
        &self.restarts
    }

    /// The flight software's events so far, with their times.
    pub fn core_events(&self) -> &[heli_fsw::Stamped<CoreEvent>] {
        &self.core_events
    }

    /// Events the flight software reported so far, as text.
    pub fn events(&self) -> &[String] {
        &self.metrics.events
    }

    /// Processes events up to and including the next physics step, unless the run is over
    /// (past `end_us`, crashed, or the flight plan is complete). Returns whether it went on.
    pub fn advance(&mut self, end_us: u64) -> bool {
        while let Some(Reverse(event)) = self.queue.peek().copied() {
            if event.t_us > end_us || self.crash.is_some() || self.plan_complete() {
                return false;
            }
            self.queue.pop();
            self.now_us = event.t_us;
            self.dispatch(event.kind);
            if matches!(event.kind, Kind::Physics) {
                return true;
            }
        }
        false
    }

    /// Starts recording every input the flight software handles and every action it takes
    /// (for replay tests: a fresh core fed the same inputs must take the same actions).
    pub fn record_flight_software(&mut self) {
        self.recorded = Some(Recording::default());
    }

    /// Starts keeping the wall-clock time of every control step once the estimator runs
    /// (for `heli bench`).
    pub fn time_control_steps(&mut self) {
        self.step_times = Some(Vec::new());
    }

    /// Wall-clock times of the control steps since [`Simulation::time_control_steps`].
    pub fn control_step_times(&self) -> &[Duration] {
        self.step_times.as_deref().unwrap_or(&[])
    }

    /// What was recorded since [`Simulation::record_flight_software`].
    pub fn recording(&self) -> Option<&Recording> {
        self.recorded.as_ref()
    }

    /// The configuration and flight parameters the flight software was started with (it was
    /// started, watchdog armed, at time 0).
    pub fn flight_software_setup(&self) -> (CoreConfig, FlightParams) {
        self.core_setup
    }

    /// Current simulated time (µs).
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The simulated helicopter (truth).
    pub fn helicopter(&self) -> &Helicopter {
        &self.heli
    }

    /// The simulated helicopter, to change (fault injection, initial conditions in tests).
    pub fn helicopter_mut(&mut self) -> &mut Helicopter {
        &mut self.heli
    }

    /// Where the servos are now (normalised), after any servo fault.
    pub fn servo_positions(&self) -> Controls {
        self.actuators.positions()
    }

    /// Why the run crashed, if it did.
    pub fn crash(&self) -> Option<&str> {
        self.crash.as_deref()
    }

    /// The flight software's main control process.
    pub fn core(&self) -> &FlightCore {
        self.computer.core()
    }

    /// The flight software: drivers and main control process.
    pub fn computer(&self) -> &FlightComputer {
        &self.computer
    }

    /// The flight software's seven streams.
    pub fn streams(&self) -> &Streams {
        &self.streams
    }

    /// The flight computer has no power (a brown-out): no flight process runs.
    pub fn browned_out(&self) -> bool {
        self.browned_out.is_some()
    }

    fn plan_complete(&self) -> bool {
        self.computer.core().plan_complete()
    }

    /// Hands one input to the flight computer and carries out what it does.
    fn deliver(&mut self, input: DeviceInput<'_>) {
        let now = self.now_us;
        if self.browned_out.is_some() {
            // Nobody there to read it.
            return;
        }
        if let Some(recorded) = self.recorded.as_mut() {
            recorded.inputs.push((now, RecordedInput::from(input)));
        }
        if let Some(log) = self.input_log.as_mut() {
            log.push((now, RecordedInput::from(input)));
        }
        let mut actions = std::mem::take(&mut self.actions);
        let mut to_devices = std::mem::take(&mut self.to_devices);
        let started = Instant::now();
        self.computer.receive(
            now,
            input,
            &mut |port, b: &[u8]| to_devices.push((port, Bytes::from_slice(b))),
            &mut actions,
        );
        let took = started.elapsed();
        if let Some(recorded) = self.recorded.as_mut() {
            recorded.actions.extend(actions.iter().copied());
        }
        if actions.iter().any(|a| matches!(a, Action::Servo(_))) {
            self.metrics.step_time_max = self.metrics.step_time_max.max(took);
            // Timed once the estimator runs: during calibration the step is pass-through.
            if let (Some(times), true) = (
                self.step_times.as_mut(),
                self.computer.core().navigator().state().is_some(),
            ) {
                times.push(took);
            }
        }
        for (port, bytes) in to_devices.drain(..) {
            self.send_to_device(port, bytes, now);
        }
        self.to_devices = to_devices;
        for action in actions.drain(..) {
            match action {
                // The computer already wrote the packet to the board's port.
                Action::Servo(_) => {}
                Action::Publish(record) => {
                    if let Record::State(s) = &record {
                        self.measure(&s.value);
                    }
                    self.streams.publish(record);
                }
                Action::Event(e) => {
                    self.metrics
                        .events
                        .push(heli_log::events::event_text(e.t_us, &e.value));
                    self.core_events.push(e);
                }
            }
        }
        self.actions = actions;
        self.time_faults_from_phase();
        self.reschedule_tick();
    }

    /// Pressure the downwash adds at the altimeter's port near the ground (mbar).
    fn baro_ground_effect_mbar(&self) -> f64 {
        let a = &self.heli.airframe;
        let hub = self.heli.state.pos_ned_m
            + self.heli.state.att * Vector3::new(0.0, 0.0, -a.mr_hub_height_m);
        let induced_mps =
            self.heli.outputs.inflow_ratio * self.heli.state.rotor_rps * a.mr_radius_m;
        ground_effect_mbar(
            &self.baro.errors,
            self.env.atmosphere.density_kgpm3,
            induced_mps,
            -hub.z,
            a.mr_radius_m,
        )
    }

    fn physics_step(&mut self) {
        let dt_s = PHYSICS_STEP_US as f64 * 1e-6;
        self.power_flight_computer();
        // Turbulence rides on the wind of the moment and height (steady, shear, changes).
        let s = self.heli.state;
        let height_m = -s.pos_ned_m.z - self.metrics.start_alt_m.unwrap_or(-s.pos_ned_m.z);
        let wind = self.scenario.wind_at(self.t_s(), height_m);
        let airspeed = (s.vel_ned_mps() - wind).norm();
        self.gust_ned_mps = self
            .turbulence
            .step(dt_s, -s.pos_ned_m.z, airspeed.max(wind.norm()));
        self.env.wind_ned_mps = wind + self.gust_ned_mps;
        self.env.atmosphere.density_kgpm3 = self.scenario.atmosphere.density_at(height_m);
        self.rotor_azimuth_rad =
            (self.rotor_azimuth_rad + s.rotor_rps * dt_s) % std::f64::consts::TAU;
        let pilot = self.receiver();
        let servo = self.scb.servo_commands(&pilot, self.now_us);
        // The physics sees where the servos are at the start of the step, held over it.
        let u = control_inputs(&self.heli.airframe, &self.actuators.positions());
        self.heli.engine_power_available = self.scenario.faults.engine_power(self.t_s());
        self.heli.step(dt_s, &u, &self.env);
        if !self.heli.state.to_array().iter().all(|x| x.is_finite()) {
            // The model left every range it has meaning in (an airframe or a scenario value
            // that drove it there): the flight ends here, said, rather than computing on.
            if self.crash.is_none() {
                self.crash = Some(format!(
                    "t={:.2} s: the model's state is no longer finite (the airframe or the \
                     scenario drove it out of its range)",
                    self.now_us as f64 * 1e-6
                ));
            }
            return;
        }
        self.actuators
            .step_at_speed(dt_s, &servo, self.servo_speeds());
        self.measure_truth();
        let out = self.heli.outputs;
        if out.contact_points > 0 && self.crash.is_none() {
            let up = self.heli.state.att * Vector3::new(0.0, 0.0, -1.0);
            let tilt = (-up.z).clamp(-1.0, 1.0).acos();
            if out.contact_sink_mps > CRASH_SINK_MPS {
                self.crash = Some(format!(
                    "t={:.2} s: hit the ground at {:.1} m/s",
                    self.now_us as f64 * 1e-6,
                    out.contact_sink_mps
                ));
            } else if tilt > CRASH_TILT_RAD {
                self.crash = Some(format!(
                    "t={:.2} s: rolled over on the ground ({:.0} deg)",
                    self.now_us as f64 * 1e-6,
                    tilt.to_degrees()
                ));
            }
        }
    }
}

/// Runs a scenario to completion with default options and no progress output.
pub fn run(scenario: Scenario) -> Result<Summary, ScenarioError> {
    Ok(Simulation::new(scenario)?.run(RunOptions::default(), |_, _| {}))
}
