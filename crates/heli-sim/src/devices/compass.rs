//! Simulated magnetic compass: the earth's field seen in body axes on three ADC channels.

use heli_proto::compass::{CompassAdc, MagField};
use nalgebra::{UnitQuaternion, Vector3};

use super::Noise;

/// The simulated compass.
#[derive(Clone, Debug)]
pub struct CompassDevice {
    /// Earth's field, NED (gauss).
    pub earth_field_ned_gauss: Vector3<f64>,
    /// Noise per reading (gauss, 1σ).
    pub noise_gauss: f64,
    noise: Noise,
}

impl CompassDevice {
    /// A compass in `earth_field_ned_gauss`.
    pub fn new(earth_field_ned_gauss: Vector3<f64>, noise: Noise) -> Self {
        Self {
            earth_field_ned_gauss,
            noise_gauss: 0.002,
            noise,
        }
    }

    /// The ADC counts at attitude `att` (body to NED).
    pub fn read(&mut self, att: &UnitQuaternion<f64>) -> CompassAdc {
        let b = att.inverse() * self.earth_field_ned_gauss;
        let field = MagField {
            field_gauss: [
                b.x + self.noise.gaussian(self.noise_gauss),
                b.y + self.noise.gaussian(self.noise_gauss),
                b.z + self.noise.gaussian(self.noise_gauss),
            ],
        };
        CompassAdc::from_field(&field)
    }
}
