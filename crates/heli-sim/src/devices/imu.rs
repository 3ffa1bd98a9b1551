//! Simulated IMU: body rates and specific force at 100 Hz in 16-byte packets.

use heli_proto::imu::ImuRepr;
use nalgebra::Vector3;

use super::{Bytes, Noise};

/// White-noise levels of the simulated IMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuErrors {
    /// Gyro noise per sample (rad/s, 1σ).
    pub gyro_noise_rps: f64,
    /// Accelerometer noise per sample (m/s², 1σ).
    pub accel_noise_mps2: f64,
    /// Constant gyro bias (rad/s), what the calibration must remove.
    pub gyro_bias_rps: [f64; 3],
}

impl Default for ImuErrors {
    fn default() -> Self {
        Self {
            gyro_noise_rps: 0.002,
            accel_noise_mps2: 0.02,
            gyro_bias_rps: [0.004, -0.003, 0.002],
        }
    }
}

/// The simulated IMU.
#[derive(Clone, Debug)]
pub struct ImuDevice {
    errors: ImuErrors,
    noise: Noise,
}

impl ImuDevice {
    /// An IMU with the given errors and noise stream.
    pub fn new(errors: ImuErrors, noise: Noise) -> Self {
        Self { errors, noise }
    }

    /// The packet for true body rate and specific force.
    pub fn packet(
        &mut self,
        rate_rps: &Vector3<f64>,
        specific_force_mps2: &Vector3<f64>,
        temp_c: f64,
    ) -> Bytes {
        let e = self.errors;
        let mut rate = [0.0; 3];
        let mut accel = [0.0; 3];
        for i in 0..3 {
            rate[i] = rate_rps[i] + e.gyro_bias_rps[i] + self.noise.gaussian(e.gyro_noise_rps);
            accel[i] = specific_force_mps2[i] + self.noise.gaussian(e.accel_noise_mps2);
        }
        let repr = ImuRepr {
            rate_rps: rate,
            accel_mps2: accel,
            temp_c,
        };
        Bytes::encode(|buf| repr.emit(buf))
    }
}
