//! Setting up one simulated flight: the helicopter on the ground with its rotor governed, the
//! devices with their error models and noise streams, the flight software configured as the
//! lab configures it before a flight (the compass calibrated, the packs' temperature and
//! cycles told), and the devices' first events scheduled at staggered phases.

use super::*;

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

impl Simulation {
    /// The helicopter, its devices and the flight software, set up but not started.
    pub(super) fn build(mut scenario: Scenario, config: CoreConfig) -> Result<Self, ScenarioError> {
        let fault_clock = fault_clock::FaultClock::hold(&mut scenario.faults);
        let plan =
            Plan::new(&scenario.plan).map_err(|e| ScenarioError::Invalid(format!("plan: {e}")))?;
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
        // The operator tells the flight software the day's temperature (its gauges need
        // it: a cold pack sags more).
        let told_c = scenario
            .power
            .told_temperature_c
            .unwrap_or(scenario.battery.temperature_c);
        // The pack log tells it each pack's charge cycles.
        let mut power = config.power.at_temperature(told_c);
        power.flight.cycles = scenario.battery.cycles;
        power.receiver.cycles = scenario.power.receiver.cycles;
        power.servo.cycles = scenario.power.servo.cycles;
        let core_config = CoreConfig {
            compass: compass_calibration,
            power,
            ..config
        };
        let mut sim = Self {
            actuators,
            hands: HoveringPilot::default(),
            hand_sticks: None,
            script_delay_us: 0,
            live_pilot: None,
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
            power: batteries::SimPower::new(&scenario),
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
            restarts: Vec::new(),
            fault_clock,
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
}
