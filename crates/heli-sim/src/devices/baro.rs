//! Simulated barometric altimeter (Honeywell HPB200A in the thesis): answers the reset and
//! rate commands the way the real device does and, once told to, sends ASCII pressure
//! readings continuously at the set rate. Its errors: 2 ft resolution, a little noise, and
//! the ground effect the thesis describes — near the ground the rotor's downwash raises the
//! pressure the sensor sees, so it reads low.

use heli_proto::baro::{self, BaroCommand, BaroReply, CommandFramer};

use super::{Bytes, Noise};

/// How long the device takes to come back after a reset (µs).
pub const RESET_TIME_US: u64 = 50_000;

/// Error model of the simulated altimeter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroErrors {
    /// Altitude noise before quantisation (m, 1σ).
    pub noise_m: f64,
    /// Altitude resolution (m): 2 ft.
    pub resolution_m: f64,
    /// Fraction of the downwash's dynamic pressure the static port picks up in ground effect.
    pub ground_effect_fraction: f64,
}

impl Default for BaroErrors {
    fn default() -> Self {
        Self {
            noise_m: 0.15,
            resolution_m: 2.0 * 0.3048,
            ground_effect_fraction: 0.5,
        }
    }
}

/// Extra pressure (mbar) at the static port from the rotor downwash in ground effect: a
/// fraction of the downwash's dynamic pressure ½ρV_i², fading as the rotor climbs out of
/// ground effect (one rotor radius of height per e-fold).
pub fn ground_effect_mbar(
    errors: &BaroErrors,
    density: f64,
    induced_mps: f64,
    rotor_height_m: f64,
    rotor_radius_m: f64,
) -> f64 {
    if induced_mps <= 0.0 || rotor_height_m.is_nan() {
        return 0.0;
    }
    let dynamic_pa = 0.5 * density * induced_mps * induced_mps;
    errors.ground_effect_fraction * dynamic_pa * (-rotor_height_m.max(0.0) / rotor_radius_m).exp()
        / 100.0
}

/// The simulated altimeter.
#[derive(Clone, Debug)]
pub struct BaroDevice {
    /// Error model.
    pub errors: BaroErrors,
    noise: Noise,
    framer: CommandFramer,
    rate_hz: u8,
    /// Reply waiting to be sent, with the time it is due.
    pending: Option<(u64, BaroReply)>,
    next_reading_us: Option<u64>,
    /// Commands received that it understood.
    pub commands: u32,
}

impl BaroDevice {
    /// An altimeter at its power-up defaults (5 readings a second, not streaming).
    pub fn new(errors: BaroErrors, noise: Noise) -> Self {
        Self {
            errors,
            noise,
            framer: baro::command_framer(),
            rate_hz: baro::DEFAULT_RATE_HZ,
            pending: None,
            next_reading_us: None,
            commands: 0,
        }
    }

    /// Command bytes from the flight computer, received at `now_us`.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) {
        for &b in bytes {
            let Some(line) = self.framer.push(b) else {
                continue;
            };
            let Ok(command) = BaroCommand::parse(line) else {
                continue;
            };
            self.commands += 1;
            match command {
                BaroCommand::Reset => {
                    self.next_reading_us = None;
                    self.rate_hz = baro::DEFAULT_RATE_HZ;
                    self.pending = Some((now_us + RESET_TIME_US, BaroReply::ResetDone));
                }
                BaroCommand::SetRate(n) => {
                    self.rate_hz = n;
                    self.pending = Some((now_us, BaroReply::RateSet(n)));
                }
                BaroCommand::StartContinuous => {
                    self.next_reading_us = Some(now_us + self.period_us())
                }
            }
        }
    }

    fn period_us(&self) -> u64 {
        1_000_000 / u64::from(self.rate_hz.max(1))
    }

    /// When the device will next transmit.
    pub fn next_at(&self) -> Option<u64> {
        match (self.pending.map(|p| p.0), self.next_reading_us) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The altitude the sensor reports for a true pressure altitude `alt_m` (noise, then
    /// quantised to its resolution).
    pub fn measured_altitude_m(&mut self, alt_m: f64) -> f64 {
        let noisy = alt_m + self.noise.gaussian(self.errors.noise_m);
        let r = self.errors.resolution_m;
        if r > 0.0 {
            (noisy / r).round() * r
        } else {
            noisy
        }
    }

    /// What the device sends at `now_us` (call at [`BaroDevice::next_at`]): `alt_m` is the
    /// pressure altitude of the static pressure the sensor sees (ground effect included),
    /// `reference_mbar` the pressure at altitude 0.
    pub fn transmit(&mut self, now_us: u64, alt_m: f64, reference_mbar: f64) -> Option<Bytes> {
        if let Some((due, reply)) = self.pending
            && now_us >= due
        {
            self.pending = None;
            return Some(Bytes::encode(|buf| reply.emit(buf)));
        }
        let due = self.next_reading_us?;
        if now_us < due {
            return None;
        }
        self.next_reading_us = Some(due + self.period_us());
        let measured = self.measured_altitude_m(alt_m);
        let pressure_mbar = baro::pressure_at_altitude_mbar(measured, reference_mbar);
        Some(Bytes::encode(|buf| {
            BaroReply::Pressure { pressure_mbar }.emit(buf)
        }))
    }
}
