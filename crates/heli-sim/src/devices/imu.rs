//! Simulated IMU: body rates and specific force at 100 Hz in 16-byte packets, with the
//! thesis's error figures: white noise; a turn-on gyro bias (what the 80 s calibration
//! removes) that then wanders as a random walk (drift below 0.02 °/s over 10 minutes);
//! sensitivity to temperature as the unit warms up; and the main rotor's once-per-revolution
//! vibration (about 27 Hz at 1600 rpm) as it gets through the elastomeric isolators.

use heli_proto::imu::ImuRepr;
use nalgebra::Vector3;

use super::{Bytes, Noise};

/// Error model of the simulated IMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuErrors {
    /// Gyro white noise per sample (rad/s, 1σ).
    pub gyro_noise_rps: f64,
    /// Accelerometer white noise per sample (m/s², 1σ).
    pub accel_noise_mps2: f64,
    /// Spread of the turn-on gyro bias (rad/s, 1σ per axis).
    pub gyro_turn_on_bias_rps: f64,
    /// Gyro bias random walk (rad/s per √s). 3.6e-6 gives 1σ = 0.005 °/s after 10 minutes,
    /// so that drift stays below the thesis's 0.02 °/s (four sigma).
    pub gyro_bias_walk_rps_per_sqrt_s: f64,
    /// Gyro bias change per °C of IMU temperature (rad/s/°C).
    pub gyro_temp_coeff_rps_per_c: f64,
    /// Spread of the accelerometer bias (m/s², 1σ per axis).
    pub accel_bias_mps2: f64,
    /// How much the IMU warms above ambient once powered (°C).
    pub warm_up_rise_c: f64,
    /// Thermal time constant of the warm-up (s).
    pub warm_up_time_constant_s: f64,
    /// Once-per-revolution vibration reaching the accelerometers at nominal rotor speed,
    /// amplitude per axis (m/s²).
    pub vibration_accel_mps2: [f64; 3],
    /// Once-per-revolution vibration reaching the gyros, amplitude per axis (rad/s).
    pub vibration_gyro_rps: [f64; 3],
}

impl Default for ImuErrors {
    fn default() -> Self {
        Self {
            gyro_noise_rps: 0.003,
            accel_noise_mps2: 0.03,
            gyro_turn_on_bias_rps: 0.005,
            gyro_bias_walk_rps_per_sqrt_s: 3.6e-6,
            gyro_temp_coeff_rps_per_c: 5e-5,
            accel_bias_mps2: 0.02,
            warm_up_rise_c: 8.0,
            warm_up_time_constant_s: 20.0,
            vibration_accel_mps2: [0.3, 0.3, 0.6],
            vibration_gyro_rps: [0.01, 0.01, 0.005],
        }
    }
}

impl ImuErrors {
    /// No errors at all (for tests of other parts).
    pub fn none() -> Self {
        Self {
            gyro_noise_rps: 0.0,
            accel_noise_mps2: 0.0,
            gyro_turn_on_bias_rps: 0.0,
            gyro_bias_walk_rps_per_sqrt_s: 0.0,
            gyro_temp_coeff_rps_per_c: 0.0,
            accel_bias_mps2: 0.0,
            warm_up_rise_c: 0.0,
            warm_up_time_constant_s: 1.0,
            vibration_accel_mps2: [0.0; 3],
            vibration_gyro_rps: [0.0; 3],
        }
    }
}

/// What the rotor is doing, for the vibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotorPhase {
    /// Blade azimuth (rad).
    pub azimuth_rad: f64,
    /// Rotor speed over nominal.
    pub speed_ratio: f64,
}

/// The simulated IMU.
#[derive(Clone, Debug)]
pub struct ImuDevice {
    errors: ImuErrors,
    noise: Noise,
    gyro_walk_rps: Vector3<f64>,
    gyro_turn_on_rps: Vector3<f64>,
    accel_bias_mps2: Vector3<f64>,
    last_t_s: Option<f64>,
}

impl ImuDevice {
    /// An IMU with the given errors; its turn-on biases are drawn from `noise`.
    pub fn new(errors: ImuErrors, mut noise: Noise) -> Self {
        let mut draw = |sigma: f64| {
            Vector3::new(
                noise.gaussian(sigma),
                noise.gaussian(sigma),
                noise.gaussian(sigma),
            )
        };
        let gyro_turn_on_rps = draw(errors.gyro_turn_on_bias_rps);
        let accel_bias_mps2 = draw(errors.accel_bias_mps2);
        Self {
            errors,
            noise,
            gyro_walk_rps: Vector3::zeros(),
            gyro_turn_on_rps,
            accel_bias_mps2,
            last_t_s: None,
        }
    }

    /// IMU temperature at `t_s` after power-on in `ambient_c`.
    pub fn temperature_c(&self, t_s: f64, ambient_c: f64) -> f64 {
        let e = &self.errors;
        ambient_c + e.warm_up_rise_c * (1.0 - (-t_s / e.warm_up_time_constant_s.max(1e-3)).exp())
    }

    /// The gyro bias at `t_s` (turn-on + walk so far + temperature), rad/s.
    pub fn gyro_bias_rps(&self, t_s: f64, ambient_c: f64) -> Vector3<f64> {
        let warming = self.temperature_c(t_s, ambient_c) - ambient_c;
        self.gyro_turn_on_rps
            + self.gyro_walk_rps
            + Vector3::repeat(self.errors.gyro_temp_coeff_rps_per_c * warming)
    }

    /// The packet at `t_s` for true body rate and specific force.
    pub fn packet(
        &mut self,
        t_s: f64,
        rate_rps: &Vector3<f64>,
        specific_force_mps2: &Vector3<f64>,
        rotor: RotorPhase,
        ambient_c: f64,
    ) -> Bytes {
        let e = self.errors;
        let dt = self.last_t_s.map_or(0.0, |last| (t_s - last).max(0.0));
        self.last_t_s = Some(t_s);
        let step = e.gyro_bias_walk_rps_per_sqrt_s * dt.sqrt();
        self.gyro_walk_rps += Vector3::new(
            self.noise.gaussian(step),
            self.noise.gaussian(step),
            self.noise.gaussian(step),
        );
        let bias = self.gyro_bias_rps(t_s, ambient_c);
        // Vibration scales with the rotor's centrifugal loads, (Ω/Ω_nom)²; each axis sees it
        // with its own phase through the isolators.
        let vib = rotor.speed_ratio * rotor.speed_ratio;
        let mut rate = [0.0; 3];
        let mut accel = [0.0; 3];
        for i in 0..3 {
            let phase = rotor.azimuth_rad + i as f64 * 2.1;
            rate[i] = rate_rps[i]
                + bias[i]
                + vib * e.vibration_gyro_rps[i] * phase.sin()
                + self.noise.gaussian(e.gyro_noise_rps);
            accel[i] = specific_force_mps2[i]
                + self.accel_bias_mps2[i]
                + vib * e.vibration_accel_mps2[i] * (phase + 0.7).sin()
                + self.noise.gaussian(e.accel_noise_mps2);
        }
        let repr = ImuRepr {
            rate_rps: rate,
            accel_mps2: accel,
            temp_c: self.temperature_c(t_s, ambient_c),
        };
        Bytes::encode(|buf| repr.emit(buf))
    }
}
