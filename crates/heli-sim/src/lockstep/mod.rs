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

mod criteria;
mod hil;
mod inject;
mod metrics;

use hil::Hil;
pub use hil::{HIL_BATTERY_CHANNEL, HilOut};
use inject::Injector;
use metrics::Metrics;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::{Duration, Instant};

use heli_fsw::computer::{DeviceInput, FlightComputer, Port, RecordedInput};
use heli_fsw::core::{Action, CoreConfig, CoreEvent, FlightCore, FlightMode, FlightParams, Phase};
use heli_fsw::streams::{Record, StateRecord, Streams};
use heli_nav::GeoOrigin;
use heli_nav::compass_cal::fit_hard_iron;
use heli_proto::baro::pressure_at_altitude_mbar;
use heli_proto::battery::BatteryAdc;
use heli_proto::compass::{CompassAdc, CompassCalibration, MagField};
use heli_proto::scb::Controls;
use nalgebra::{UnitQuaternion, Vector3};

use crate::actuators::{Actuators, ServoParams, control_inputs};
use crate::devices::baro::{BaroDevice, BaroErrors, ground_effect_mbar};
use crate::devices::battery::BatteryDevice;
use crate::devices::compass::{CompassDevice, CompassErrors};
use crate::devices::gps::{GpsDevice, GpsErrors};
use crate::devices::imu::{ImuDevice, ImuErrors, RotorPhase};
use crate::devices::scb::{PilotCommand, ScbDevice};
use crate::devices::{Bytes, Noise, transmit_time_us};
use crate::model::{Environment, Helicopter};
use crate::pilot::{HoveringPilot, seen_by_pilot};
use crate::scenario::{Scenario, ScenarioError};
use crate::summary::{
    Criterion, DeviceSummary, EstimatorSummary, HoldSummary, LinkSummary, LoopSummary,
    ManeuverSummary, Outcome, Rms, Summary,
};
use crate::turbulence::Turbulence;
use heli_control::AugmentedMode;
use heli_fsw::core::mission::{Plan, RollStage};

/// Physics integration step (µs): 500 Hz RK4.
pub const PHYSICS_STEP_US: u64 = 2_000;
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

/// The geodetic origin of the simulated field (MIT's Briggs Field).
pub const FIELD_ORIGIN: GeoOrigin = GeoOrigin {
    lat_deg: 42.3581,
    lon_deg: -71.0966,
    alt_m: 5.0,
};

/// Earth's magnetic field at the field, NED (gauss).
pub fn field_earth_field_gauss() -> Vector3<f64> {
    Vector3::new(0.19, 0.0, 0.48)
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
    battery: BatteryDevice,
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
}

impl Simulation {
    /// Sets up the scenario's flight: helicopter on the ground with the rotor governed at
    /// 1600 rpm, devices powered, flight software started with the scenario's parameters.
    pub fn new(scenario: Scenario) -> Result<Self, ScenarioError> {
        Self::with_flight_software(scenario, CoreConfig::default())
    }

    /// The helicopter, its devices and the flight software, set up but not started.
    fn build(scenario: Scenario, config: CoreConfig) -> Result<Self, ScenarioError> {
        let legs: Vec<_> = scenario.plan.iter().map(|l| l.to_leg()).collect();
        let plan = Plan::new(&legs).map_err(|e| ScenarioError::Invalid(format!("plan: {e}")))?;
        let seed = scenario.seed;
        let env = Environment {
            wind_ned_mps: Vector3::from(scenario.wind_ned_mps),
            atmosphere: scenario.atmosphere,
        };
        let airframe = scenario.airframe.clone();
        let rotor_rps = scenario.pilot.scripted(0.0).throttle
            * airframe.governor_full_scale_rpm
            * std::f64::consts::PI
            / 30.0;
        let mut heli = Helicopter::on_ground(airframe, rotor_rps);
        let pilot_col = scenario.pilot.scripted(0.0).collective * heli.airframe.collective_max_rad;
        heli.trim_governor(pilot_col, &env);
        let params = FlightParams {
            mode: scenario.mode,
            plan,
        };
        let actuators =
            Actuators::settled(ServoParams::default(), &Self::pilot_of(&scenario).sticks);
        let compass_errors = CompassErrors::default();
        // The lab calibrated the compass before the flight; the flight software keeps the
        // result in its configuration (the thesis: stored in flash).
        let compass_calibration = calibrate_compass(compass_errors, Noise::new(seed, 7));
        let core_config = CoreConfig {
            compass: compass_calibration,
            ..config
        };
        let mut sim = Self {
            actuators,
            hands: HoveringPilot::default(),
            hand_sticks: None,
            turbulence: Turbulence::new(scenario.turbulence_sigma_mps, Noise::new(seed, 6)),
            gust_ned_mps: Vector3::zeros(),
            rotor_azimuth_rad: 0.0,
            imu: ImuDevice::new(ImuErrors::default(), Noise::new(seed, 1)),
            scb: ScbDevice::default(),
            gps: GpsDevice::new(GpsErrors::default(), FIELD_ORIGIN, Noise::new(seed, 2)),
            baro: BaroDevice::new(BaroErrors::default(), Noise::new(seed, 3)),
            compass: CompassDevice::new(
                field_earth_field_gauss(),
                compass_errors,
                Noise::new(seed, 4),
            ),
            battery: BatteryDevice {
                temperature_c: scenario.atmosphere.temperature_c,
                capacity_ah: scenario.battery.capacity_ah,
                initial_charge: scenario.battery.charge,
                load_a: scenario.battery.load_a,
                ..BatteryDevice::default()
            },
            drop_noise: Noise::new(seed, 5),
            loss_noise: Noise::new(seed, 8),
            last_imu_bytes: None,
            injector: Injector::new(seed),
            computer: FlightComputer::new(core_config, params, heli_proto::baro::DEFAULT_RATE_HZ),
            browned_out: None,
            cold_restarts: false,
            core_setup: (core_config, params),
            recorded: None,
            step_times: None,
            streams: Streams::with_history_s(10.0),
            queue: BinaryHeap::new(),
            seq: 0,
            now_us: 0,
            tick_at: None,
            actions: Vec::with_capacity(16),
            to_devices: Vec::with_capacity(4),
            metrics: Metrics {
                battery_min_v: f64::INFINITY,
                ..Metrics::default()
            },
            crash: None,
            hil: None,
            core_events: Vec::new(),
            input_log: None,
            scenario,
            heli,
            env,
        };
        // Devices start at staggered phases, as independent clocks would.
        sim.schedule(0, Kind::Physics);
        sim.schedule(3_000, Kind::ImuSample);
        sim.schedule(7_000, Kind::UplinkSample);
        sim.schedule(500_000, Kind::GpsEpoch);
        sim.schedule(11_000, Kind::CompassRead);
        sim.schedule(0, Kind::BatteryRead);
        Ok(sim)
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

    /// The flight software arms its watchdogs, checks the servo board and starts its
    /// altimeter handshake.
    fn start_flight_computer(&mut self) {
        let now = self.now_us;
        let mut sent = Vec::new();
        self.computer.start(now, &mut |port, b: &[u8]| {
            sent.push((port, Bytes::from_slice(b)))
        });
        for (port, b) in sent {
            self.send_to_device(port, b, now);
        }
        self.reschedule_tick();
    }

    /// Flight processes started after a brown-out calibrate from scratch, as if nothing was
    /// persisted (to show what the warm start is worth).
    pub fn forget_warm_start(&mut self) {
        self.cold_restarts = true;
    }

    /// A brown-out begins or ends: the flight computer loses its power (and its flight
    /// process, all but the record it persisted), or boots and starts a new flight process
    /// from that record.
    fn power_flight_computer(&mut self) {
        if self.hil.is_some() {
            return; // the flight computer is outside: its power is its own
        }
        let off = self.scenario.faults.browned_out(self.t_s());
        match (off, self.browned_out) {
            (true, None) => {
                let warm = self.computer.core().warm_start();
                self.browned_out = Some(warm.filter(|_| !self.cold_restarts));
                self.metrics.brownouts += 1;
            }
            (false, Some(warm)) => {
                self.browned_out = None;
                let (config, params) = self.core_setup;
                let rate = heli_proto::baro::DEFAULT_RATE_HZ;
                self.computer = match warm {
                    Some(warm) => FlightComputer::restarted(config, params, rate, warm),
                    None => FlightComputer::new(config, params, rate),
                };
                self.tick_at = None;
                self.start_flight_computer();
            }
            _ => {}
        }
    }

    fn schedule(&mut self, t_us: u64, kind: Kind) {
        self.seq += 1;
        self.queue.push(Reverse(Event {
            t_us,
            class: kind.class(),
            seq: self.seq,
            kind,
        }));
    }

    fn baud(port: Port) -> u32 {
        match port {
            Port::Imu => heli_proto::imu::BAUD,
            Port::Scb => heli_proto::scb::BAUD,
            Port::Gps => heli_proto::gps::BAUD,
            Port::Baro => heli_proto::baro::BAUD,
        }
    }

    fn send_to_device(&mut self, port: Port, bytes: Bytes, now_us: u64) {
        let at = now_us + transmit_time_us(bytes.as_slice().len(), Self::baud(port));
        self.schedule(at, Kind::ToDevice(port, bytes));
    }

    fn send_to_computer(&mut self, port: Port, bytes: Bytes, sent_us: u64) {
        let Some((bytes, delay_us)) = self.faulted_transmission(inject::device_of(port), bytes)
        else {
            return;
        };
        let at = sent_us + delay_us + transmit_time_us(bytes.as_slice().len(), Self::baud(port));
        let bytes = self.lose_bytes(port, bytes);
        self.schedule(at, Kind::ToComputer(port, bytes));
    }

    /// Serial bytes lost on the way (the scenario's `byte_loss`), each at random.
    fn lose_bytes(&mut self, port: Port, bytes: Bytes) -> Bytes {
        let t_s = self.now_us as f64 * 1e-6;
        let rate = self
            .scenario
            .faults
            .byte_loss
            .iter()
            .filter(|b| b.port == port.name() && t_s >= b.start_s && t_s < b.end_s)
            .map(|b| b.rate)
            .fold(0.0, f64::max);
        if rate <= 0.0 {
            return bytes;
        }
        let kept: Vec<u8> = bytes
            .as_slice()
            .iter()
            .copied()
            .filter(|_| self.loss_noise.uniform() >= rate)
            .collect();
        self.metrics.bytes_lost += (bytes.as_slice().len() - kept.len()) as u64;
        Bytes::from_slice(&kept)
    }

    /// True while the scenario's fault `windows` are active.
    fn fault(&self, windows: impl Fn(&crate::scenario::Faults) -> &Vec<[f64; 2]>) -> bool {
        crate::scenario::Faults::active(windows(&self.scenario.faults), self.now_us as f64 * 1e-6)
    }

    fn pilot(&self) -> PilotCommand {
        let t_s = self.now_us as f64 * 1e-6;
        let lost = self
            .scenario
            .faults
            .transmitter_lost
            .iter()
            .any(|[start, end]| t_s >= *start && t_s < *end);
        let p = &self.scenario.pilot;
        let scripted = p.scripted(t_s);
        let sticks = match self.hand_sticks {
            // The pilot hovers by hand; the scripted inputs ride on top.
            Some(hands) => Controls {
                aileron: hands.aileron + scripted.aileron - p.aileron,
                elevator: hands.elevator + scripted.elevator - p.elevator,
                rudder: hands.rudder + scripted.rudder - p.rudder,
                collective: hands.collective + scripted.collective - p.collective,
                throttle: scripted.throttle,
            }
            .clamped(),
            None => scripted,
        };
        PilotCommand {
            sticks,
            auto_mode: p.auto_at(t_s),
            bypass: p.bypass_at(t_s),
            signal_lost: lost,
        }
    }

    fn pilot_of(scenario: &Scenario) -> PilotCommand {
        let p = &scenario.pilot;
        PilotCommand {
            sticks: p.scripted(0.0),
            auto_mode: p.auto_at(0.0),
            bypass: false,
            signal_lost: false,
        }
    }

    /// The hovering pilot's hands, at the uplink rate, while the auto switch is off.
    fn move_hands(&mut self) {
        let t_s = self.now_us as f64 * 1e-6;
        let p = &self.scenario.pilot;
        if !p.hovers_in_manual || p.auto_at(t_s) {
            self.hand_sticks = None;
            self.hands.release();
            return;
        }
        let s = self.heli.state;
        let truth = seen_by_pilot(
            self.now_us,
            s.att,
            s.vel_ned_mps(),
            s.pos_ned_m,
            s.rate_body_rps,
        );
        self.hand_sticks = Some(self.hands.sticks(&truth, UPLINK_PERIOD_US as f64 * 1e-6));
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

    fn plan_complete(&self) -> bool {
        self.computer.core().plan_complete()
    }

    fn dispatch(&mut self, kind: Kind) {
        let now = self.now_us;
        match kind {
            Kind::Physics => {
                self.physics_step();
                if self.hil.is_some() {
                    self.measure_hil_truth();
                }
                self.schedule(now + PHYSICS_STEP_US, Kind::Physics);
            }
            Kind::ImuSample => {
                let s = self.heli.state;
                let f = self.heli.outputs.specific_force_body_mps2;
                let rate_rps = self.wrong_vector(crate::faults::Device::Imu, s.rate_body_rps);
                let rotor = RotorPhase {
                    azimuth_rad: self.rotor_azimuth_rad,
                    speed_ratio: s.rotor_rps / self.heli.airframe.omega_nom_rps,
                };
                let bytes = self.imu.packet(
                    now as f64 * 1e-6,
                    &rate_rps,
                    &f,
                    rotor,
                    self.env.atmosphere.temperature_c,
                );
                // A stuck IMU repeats its last packet, byte for byte.
                let bytes = match (self.fault(|f| &f.imu_stuck), self.last_imu_bytes) {
                    (true, Some(last)) => last,
                    _ => bytes,
                };
                self.last_imu_bytes = Some(bytes);
                // A silent IMU sends nothing (and draws no random drop).
                if self.fault(|f| &f.imu_silent)
                    || self.drop_noise.uniform() < self.scenario.faults.imu_drop_rate
                {
                    self.metrics.imu_dropped += 1;
                } else {
                    self.send_to_computer(Port::Imu, bytes, now);
                }
                self.schedule(now + IMU_PERIOD_US, Kind::ImuSample);
            }
            Kind::UplinkSample => {
                self.move_hands();
                let bytes = self.uplink_packet();
                if !self.fault(|f| &f.uplink_silent) {
                    self.send_to_computer(Port::Scb, bytes, now);
                }
                self.schedule(now + UPLINK_PERIOD_US, Kind::UplinkSample);
            }
            Kind::GpsEpoch => {
                let t_s = now as f64 * 1e-6;
                let in_outage = self
                    .scenario
                    .faults
                    .gps_outages
                    .iter()
                    .any(|[start, end]| t_s >= *start && t_s < *end);
                let s = self.heli.state;
                let faults = &self.scenario.faults;
                let glitch = faults
                    .gps_glitches
                    .iter()
                    .filter(|g| t_s >= g.start_s && t_s < g.end_s)
                    .fold(Vector3::zeros(), |acc, g| {
                        acc + Vector3::new(g.north_m, g.east_m, 0.0)
                    });
                self.gps.glitch_ned_m = glitch;
                self.gps.forced_satellites = faults
                    .gps_satellites
                    .iter()
                    .find(|g| t_s >= g.start_s && t_s < g.end_s)
                    .map(|g| g.satellites);
                let gps = crate::faults::Device::Gps;
                let pos_ned_m = Vector3::new(
                    self.wrong_reading(gps, s.pos_ned_m.x),
                    self.wrong_reading(gps, s.pos_ned_m.y),
                    s.pos_ned_m.z,
                );
                let bytes = self.gps.packet(now, &pos_ned_m, &s.vel_ned_mps());
                // The packet's last byte arrives `latency` after the epoch.
                let tx = transmit_time_us(bytes.as_slice().len(), heli_proto::gps::BAUD);
                let latency_us = (self.gps.errors.latency_s * 1e6) as u64;
                if in_outage {
                    self.metrics.gps_lost += 1;
                } else {
                    self.send_to_computer(Port::Gps, bytes, now + latency_us.saturating_sub(tx));
                }
                self.schedule(now + GPS_PERIOD_US, Kind::GpsEpoch);
            }
            Kind::BaroTransmit => {
                let alt_m = -self.heli.state.pos_ned_m.z + FIELD_ORIGIN.alt_m;
                let p0 = self.env.atmosphere.ground_pressure_mbar;
                let p = pressure_at_altitude_mbar(alt_m, p0);
                let mbar_per_m = p - pressure_at_altitude_mbar(alt_m + 1.0, p0);
                let seen_alt_m = alt_m - self.baro_ground_effect_mbar() / mbar_per_m;
                let seen_alt_m = self.wrong_reading(crate::faults::Device::Baro, seen_alt_m);
                if let Some(bytes) = self.baro.transmit(now, seen_alt_m, p0)
                    && !self.fault(|f| &f.baro_silent)
                {
                    self.send_to_computer(Port::Baro, bytes, now);
                }
                self.reschedule_baro_device();
            }
            Kind::CompassRead => {
                let adc = self.compass.read(&self.heli.state.att);
                let silent = self.fault(|f| &f.compass_silent);
                let adc = self.faulted_compass(adc);
                match (self.hil.as_mut(), adc) {
                    _ if silent => {}
                    (_, None) => {}
                    (Some(hil), Some(adc)) => {
                        for (channel, counts) in (0u8..).zip(adc.counts) {
                            hil.outbox.push((now, HilOut::Adc { channel, counts }));
                        }
                    }
                    (None, Some(adc)) => self.deliver(DeviceInput::Compass(adc)),
                }
                self.schedule(now + COMPASS_PERIOD_US, Kind::CompassRead);
            }
            Kind::BatteryRead => {
                let volts = self.battery.volts(now as f64 * 1e-6);
                if let Some(battery) = self.faulted_battery(volts) {
                    self.read_battery(battery);
                }
                self.schedule(now + BATTERY_PERIOD_US, Kind::BatteryRead);
            }
            Kind::ToDevice(port, bytes) => self.reach_device(port, bytes),
            Kind::ToComputer(port, bytes) => match self.hil.as_mut() {
                Some(hil) => hil.outbox.push((now, HilOut::Bytes(port, bytes))),
                None => self.deliver(DeviceInput::Bytes {
                    port,
                    bytes: bytes.as_slice(),
                }),
            },
            Kind::Tick => {
                // Only the latest scheduled deadline is live; earlier ones were superseded.
                if self.tick_at == Some(now) {
                    self.tick_at = None;
                    self.deliver(DeviceInput::Tick);
                }
            }
        }
    }

    /// The servo board's uplink packet now: the pilot's command as the receiver reports it,
    /// and the rotor speed.
    fn uplink_packet(&mut self) -> Bytes {
        let rpm = self.heli.state.rotor_rps * 30.0 / std::f64::consts::PI;
        let rpm = self.wrong_reading(crate::faults::Device::Uplink, rpm);
        let pilot = self.receiver();
        self.scb.uplink(&pilot, rpm)
    }

    /// A battery reading: the lowest is kept; hardware in the loop gets it on its ADC.
    fn read_battery(&mut self, battery: BatteryAdc) {
        let now = self.now_us;
        self.metrics.battery_min_v = self.metrics.battery_min_v.min(battery.volts());
        if let Some(hil) = self.hil.as_mut() {
            hil.outbox.push((
                now,
                HilOut::Adc {
                    channel: HIL_BATTERY_CHANNEL,
                    counts: battery.counts,
                },
            ));
        }
    }

    /// Bytes from the flight computer reach a device.
    fn reach_device(&mut self, port: Port, bytes: Bytes) {
        let now = self.now_us;
        match port {
            Port::Scb => {
                self.scb.receive(bytes.as_slice(), now);
                if self.scb.take_check() {
                    // The board answers the computer's start-up check with an uplink now.
                    let bytes = self.uplink_packet();
                    self.send_to_computer(Port::Scb, bytes, now);
                }
            }
            // A dead altimeter hears nothing either.
            Port::Baro if self.fault(|f| &f.baro_silent) => {}
            Port::Baro => {
                self.baro.receive(bytes.as_slice(), now);
                self.reschedule_baro_device();
            }
            Port::Imu | Port::Gps => {}
        }
    }

    fn reschedule_baro_device(&mut self) {
        // The device's next transmission is scheduled once; a stale event just finds nothing due.
        if let Some(at) = self.baro.next_at() {
            let at = at.max(self.now_us);
            if !self
                .queue
                .iter()
                .any(|e| matches!(e.0.kind, Kind::BaroTransmit) && e.0.t_us == at)
            {
                self.schedule(at, Kind::BaroTransmit);
            }
        }
    }

    fn reschedule_tick(&mut self) {
        if let Some(at) = self.computer.poll_at()
            && self.tick_at != Some(at)
        {
            self.tick_at = Some(at);
            self.schedule(at.max(self.now_us), Kind::Tick);
        }
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

/// The compass calibration routine as the lab runs it before a flight: the helicopter is
/// turned through 24 headings at three tilts on the ground, and the hard-iron field is fitted
/// to the readings (`heli_nav::compass_cal`).
pub fn calibrate_compass(errors: CompassErrors, noise: Noise) -> CompassCalibration {
    let mut compass = CompassDevice::new(field_earth_field_gauss(), errors, noise);
    let mut readings = Vec::new();
    for tilt in [-0.4_f64, 0.0, 0.4] {
        for k in 0..24 {
            let yaw = f64::from(k) * std::f64::consts::TAU / 24.0;
            let att = UnitQuaternion::from_euler_angles(tilt, -0.5 * tilt, yaw);
            readings.push(compass.read(&att).raw_field());
        }
    }
    fit_hard_iron(&readings).unwrap_or_default()
}

/// Runs a scenario to completion with default options and no progress output.
pub fn run(scenario: Scenario) -> Result<Summary, ScenarioError> {
    Ok(Simulation::new(scenario)?.run(RunOptions::default(), |_, _| {}))
}
