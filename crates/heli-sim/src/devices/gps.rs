//! Simulated GPS receiver with the thesis's figures for the SuperStar: a navigation solution
//! every second, delivered one second after its epoch; "relative navigation ... gives
//! approximately a 2 m circular error" over a short flight, which we read as: the error of a
//! position *relative to where the flight began* has a 2 m circular error probable after ten
//! minutes — a slowly wandering error (first-order Gauss–Markov, 30 min correlation time) plus
//! a little white noise; horizontal velocity within 0.15 m/s; and a satellite count that now
//! and then drops (below four there is no fix).

use heli_nav::GeoOrigin;
use heli_proto::gps::{FixType, GpsNav};
use nalgebra::Vector3;

use super::{Bytes, Noise};

/// Error model of the simulated receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsErrors {
    /// Stationary spread of the wandering horizontal error (m, 1σ per axis). With the 30 min
    /// correlation time, 2.26 m makes the change over ten minutes 2.26 × √(2(1 − e^(−1/3)))
    /// = 1.70 m per axis: a circular error probable of 1.1774 × 1.70 = 2.0 m.
    pub horizontal_sigma_m: f64,
    /// Stationary spread of the wandering vertical error (m, 1σ).
    pub vertical_sigma_m: f64,
    /// Correlation time of the wandering error (s).
    pub correlation_time_s: f64,
    /// White position noise on top (m, 1σ per axis).
    pub white_noise_m: f64,
    /// Velocity noise (m/s, 1σ per axis): 0.04 keeps the horizontal error within 0.15 m/s
    /// 99.9 % of the time.
    pub velocity_noise_mps: f64,
    /// Satellites used normally.
    pub satellites: u8,
    /// Chance per epoch that the satellite count starts to drop (e.g. a bank shadows the
    /// antenna); it then falls to 3–6 for 3–15 s (at 3 there is no fix).
    pub satellite_drop_chance: f64,
    /// Time from the solution's epoch to the end of its packet (s).
    pub latency_s: f64,
}

impl Default for GpsErrors {
    fn default() -> Self {
        Self {
            horizontal_sigma_m: 2.26,
            vertical_sigma_m: 3.5,
            correlation_time_s: 1800.0,
            white_noise_m: 0.2,
            velocity_noise_mps: 0.04,
            satellites: 8,
            satellite_drop_chance: 1.0 / 600.0,
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
    wander_m: Vector3<f64>,
    last_epoch_s: Option<f64>,
    /// Satellites lost until this time (s), and how many are left.
    dropout: Option<(f64, u8)>,
    /// A glitch: added to the reported position (m, NED) while set (fault injection).
    pub glitch_ned_m: Vector3<f64>,
    /// Forced satellite count (fault injection).
    pub forced_satellites: Option<u8>,
}

impl GpsDevice {
    /// A receiver whose NED origin is at `origin`; the wandering error starts from its
    /// stationary distribution.
    pub fn new(errors: GpsErrors, origin: GeoOrigin, mut noise: Noise) -> Self {
        let wander_m = Vector3::new(
            noise.gaussian(errors.horizontal_sigma_m),
            noise.gaussian(errors.horizontal_sigma_m),
            noise.gaussian(errors.vertical_sigma_m),
        );
        Self {
            errors,
            origin,
            noise,
            wander_m,
            last_epoch_s: None,
            dropout: None,
            glitch_ned_m: Vector3::zeros(),
            forced_satellites: None,
        }
    }

    /// The position error (m, NED) the receiver currently adds, before white noise.
    pub fn wander_m(&self) -> Vector3<f64> {
        self.wander_m
    }

    /// Satellites used at epoch `t_s` (advances the drop-out process).
    fn satellites(&mut self, t_s: f64) -> u8 {
        if let Some((until, left)) = self.dropout {
            if t_s < until {
                return left;
            }
            self.dropout = None;
        }
        if self.noise.uniform() < self.errors.satellite_drop_chance {
            let duration = 3.0 + 12.0 * self.noise.uniform();
            let left = 3 + (self.noise.uniform() * 4.0) as u8;
            self.dropout = Some((t_s + duration, left));
            return left;
        }
        self.errors.satellites
    }

    /// The packet of the solution at epoch `t_us` for true NED position and velocity.
    pub fn packet(
        &mut self,
        t_us: u64,
        pos_ned_m: &Vector3<f64>,
        vel_ned_mps: &Vector3<f64>,
    ) -> Bytes {
        let e = self.errors;
        let t_s = t_us as f64 * 1e-6;
        let dt = self.last_epoch_s.map_or(0.0, |last| (t_s - last).max(0.0));
        self.last_epoch_s = Some(t_s);
        // Exact discretisation of the Gauss–Markov error.
        let a = (-dt / e.correlation_time_s.max(1e-3)).exp();
        let k = (1.0 - a * a).sqrt();
        let sigmas = [
            e.horizontal_sigma_m,
            e.horizontal_sigma_m,
            e.vertical_sigma_m,
        ];
        for (i, sigma) in sigmas.iter().enumerate() {
            self.wander_m[i] = a * self.wander_m[i] + k * self.noise.gaussian(*sigma);
        }
        let pos_ned_m = &(pos_ned_m + self.glitch_ned_m);
        let noisy = [
            pos_ned_m.x + self.wander_m.x + self.noise.gaussian(e.white_noise_m),
            pos_ned_m.y + self.wander_m.y + self.noise.gaussian(e.white_noise_m),
            pos_ned_m.z + self.wander_m.z + self.noise.gaussian(e.white_noise_m),
        ];
        let (lat, lon, alt) = self.origin.to_geodetic(noisy);
        let vel = [
            vel_ned_mps.x + self.noise.gaussian(e.velocity_noise_mps),
            vel_ned_mps.y + self.noise.gaussian(e.velocity_noise_mps),
            vel_ned_mps.z + self.noise.gaussian(2.0 * e.velocity_noise_mps),
        ];
        let satellites = self.satellites(t_s);
        let satellites = self.forced_satellites.unwrap_or(satellites);
        let nav = GpsNav {
            // GPS time of week: the simulation starts Monday 10:00 GPS time.
            tow_ms: ((36_000_000 + t_us / 1000) % 604_800_000) as u32,
            lat_deg: lat,
            lon_deg: lon,
            alt_m: alt,
            vel_ned_mps: vel,
            satellites,
            fix: if satellites >= 4 {
                FixType::Fix3D
            } else {
                FixType::NoFix
            },
        };
        Bytes::encode(|buf| nav.emit(buf))
    }
}
