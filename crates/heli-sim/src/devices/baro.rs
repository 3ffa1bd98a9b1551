//! Simulated barometric altimeter: answers the reset and rate commands the way the real
//! device does, and once told to, sends ASCII pressure readings continuously at the set rate.

use heli_proto::baro::{self, BaroCommand, BaroReply, CommandFramer};

use super::{Bytes, Noise};

/// How long the device takes to come back after a reset (µs).
pub const RESET_TIME_US: u64 = 50_000;

/// Error model of the simulated altimeter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroErrors {
    /// Altitude noise (m, 1σ).
    pub noise_m: f64,
}

impl Default for BaroErrors {
    fn default() -> Self {
        Self { noise_m: 0.15 }
    }
}

/// The simulated altimeter.
#[derive(Clone, Debug)]
pub struct BaroDevice {
    errors: BaroErrors,
    noise: Noise,
    framer: CommandFramer,
    rate_hz: u8,
    /// Replies waiting to be sent, with the time they are due.
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

    /// What the device sends at `now_us` (call at [`BaroDevice::next_at`]) given the true
    /// pressure (mbar) and how many mbar one metre is here.
    pub fn transmit(&mut self, now_us: u64, pressure_mbar: f64, mbar_per_m: f64) -> Option<Bytes> {
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
        let noisy = pressure_mbar + self.noise.gaussian(self.errors.noise_m) * mbar_per_m;
        Some(Bytes::encode(|buf| {
            BaroReply::Pressure {
                pressure_mbar: noisy,
            }
            .emit(buf)
        }))
    }
}
