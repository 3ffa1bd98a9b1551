//! Simulated magnetic compass (Honeywell HMC2003): the earth's field seen in body axes, plus
//! the field the avionics themselves make (a constant "hard-iron" field in body axes — the
//! thesis: the sensor "requires an additional reset circuit to compensate for the magnetic
//! field induced by the helicopter avionics"), on three ADC channels.

use heli_proto::compass::{CompassAdc, MagField};
use nalgebra::{UnitQuaternion, Vector3};

use super::Noise;

/// Error model of the simulated compass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompassErrors {
    /// Field of the avionics, body axes (gauss).
    pub avionics_field_gauss: [f64; 3],
    /// Noise per reading (gauss, 1σ per axis).
    pub noise_gauss: f64,
}

impl Default for CompassErrors {
    fn default() -> Self {
        Self {
            avionics_field_gauss: [0.06, -0.04, 0.09],
            noise_gauss: 0.002,
        }
    }
}

/// The simulated compass.
#[derive(Clone, Debug)]
pub struct CompassDevice {
    /// Earth's field, NED (gauss).
    pub earth_field_ned_gauss: Vector3<f64>,
    /// Error model.
    pub errors: CompassErrors,
    noise: Noise,
}

impl CompassDevice {
    /// A compass in `earth_field_ned_gauss`.
    pub fn new(earth_field_ned_gauss: Vector3<f64>, errors: CompassErrors, noise: Noise) -> Self {
        Self {
            earth_field_ned_gauss,
            errors,
            noise,
        }
    }

    /// The ADC counts at attitude `att` (body to NED).
    pub fn read(&mut self, att: &UnitQuaternion<f64>) -> CompassAdc {
        let b = att.inverse() * self.earth_field_ned_gauss
            + Vector3::from(self.errors.avionics_field_gauss);
        let s = self.errors.noise_gauss;
        let field = MagField {
            field_gauss: [
                b.x + self.noise.gaussian(s),
                b.y + self.noise.gaussian(s),
                b.z + self.noise.gaussian(s),
            ],
        };
        CompassAdc::from_field(&field)
    }
}
