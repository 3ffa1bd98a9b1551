//! Simulated GPS receiver: a navigation solution every second, delivered after the
//! receiver's latency (the thesis's SuperStar: 1 Hz, 1 s latency).

use heli_nav::GeoOrigin;
use heli_proto::gps::{FixType, GpsNav};
use nalgebra::Vector3;

use super::{Bytes, Noise};

/// Error model of the simulated receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsErrors {
    /// Horizontal position noise (m, 1σ per axis).
    pub horizontal_noise_m: f64,
    /// Vertical position noise (m, 1σ).
    pub vertical_noise_m: f64,
    /// Velocity noise (m/s, 1σ per axis).
    pub velocity_noise_mps: f64,
    /// Satellites in view.
    pub satellites: u8,
    /// Time from the solution's epoch to the end of its packet (s).
    pub latency_s: f64,
}

impl Default for GpsErrors {
    fn default() -> Self {
        Self {
            horizontal_noise_m: 0.3,
            vertical_noise_m: 0.6,
            velocity_noise_mps: 0.05,
            satellites: 8,
            latency_s: 1.0,
        }
    }
}

/// The simulated receiver.
#[derive(Clone, Debug)]
pub struct GpsDevice {
    /// Error model.
    pub errors: GpsErrors,
    origin: GeoOrigin,
    noise: Noise,
}

impl GpsDevice {
    /// A receiver whose NED origin is at `origin`.
    pub fn new(errors: GpsErrors, origin: GeoOrigin, noise: Noise) -> Self {
        Self {
            errors,
            origin,
            noise,
        }
    }

    /// The packet of the solution at epoch `t_us` for true NED position and velocity.
    pub fn packet(
        &mut self,
        t_us: u64,
        pos_ned_m: &Vector3<f64>,
        vel_ned_mps: &Vector3<f64>,
    ) -> Bytes {
        let e = self.errors;
        let noisy = [
            pos_ned_m.x + self.noise.gaussian(e.horizontal_noise_m),
            pos_ned_m.y + self.noise.gaussian(e.horizontal_noise_m),
            pos_ned_m.z + self.noise.gaussian(e.vertical_noise_m),
        ];
        let (lat, lon, alt) = self.origin.to_geodetic(noisy);
        let vel = [
            vel_ned_mps.x + self.noise.gaussian(e.velocity_noise_mps),
            vel_ned_mps.y + self.noise.gaussian(e.velocity_noise_mps),
            vel_ned_mps.z + self.noise.gaussian(e.velocity_noise_mps),
        ];
        let nav = GpsNav {
            // GPS time of week: the simulation starts Monday 10:00 GPS time.
            tow_ms: ((36_000_000 + t_us / 1000) % 604_800_000) as u32,
            lat_deg: lat,
            lon_deg: lon,
            alt_m: alt,
            vel_ned_mps: vel,
            satellites: e.satellites,
            fix: if e.satellites >= 4 {
                FixType::Fix3D
            } else {
                FixType::NoFix
            },
        };
        Bytes::encode(|buf| nav.emit(buf))
    }
}
