//! A flight process that starts again in the air: after a brown-out of the flight computer
//! or a crash of the process, the bootstrap starts a new one, which must not calibrate for
//! 80 s on a helicopter that is flying.
//!
//! The design (docs/architecture.md, "restart in the air"): the flight process keeps a
//! [`WarmStart`] record where its runtime persists it (the vehicle writes it to a file on
//! every change). A process started with a record that says the helicopter was airborne
//! skips the ground calibration: it keeps the gyro biases and the navigation frame of the
//! flight before, and aligns in the air — roll and pitch from a second of accelerometer
//! readings, heading from the compass, position from the first GPS fix (it waits up to
//! [`ALIGN_GPS_WAIT_S`] for one). While it aligns it flies the blind failsafe (cyclic
//! neutral, collective a little under hover). Aligned, it holds position where it is if the
//! auto switch is on (the flight plan is not resumed: where it stood is not known for
//! sure), or hands the helicopter to the pilot if the switch is off, as ArduPilot does after
//! a watchdog reset in flight.

use super::*;

/// Accelerometer readings averaged for the attitude of an in-air alignment (s).
pub const ALIGN_S: f64 = 1.0;

/// Longest an in-air alignment waits for a GPS fix before starting the estimate without
/// one (s).
pub const ALIGN_GPS_WAIT_S: f64 = 3.0;

/// What a flight process leaves behind for the one that may follow it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarmStart {
    /// The gyro biases the filter had refined (rad/s).
    pub gyro_bias_rps: [f64; 3],
    /// The navigation frame's origin (the first GPS fix of the flight).
    pub origin: Option<heli_nav::GeoOrigin>,
    /// Home, where the calibration started the estimate (m, NED, in that frame).
    pub home_ned_m: Option<[f64; 3]>,
    /// The helicopter had been airborne in this flight.
    pub airborne: bool,
    /// The servo commands that held it, averaged over the last seconds of autonomous flight:
    /// what a restarted process flies while it aligns.
    pub trim: Option<Controls>,
}

/// Time constant of the average of the servo commands kept as the trim (s).
pub const TRIM_AVERAGE_S: f64 = 2.0;

/// An in-air alignment under way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Alignment {
    warm: WarmStart,
    since_us: Option<u64>,
    accel_sum_mps2: Vector3<f64>,
    samples: u32,
    gps_seen: bool,
}

impl FlightCore {
    /// A core started again in the air from what the process before it left. A record
    /// from a helicopter that never flew gives an ordinary start, calibration included.
    pub fn restarted(config: CoreConfig, params: FlightParams, warm: WarmStart) -> Self {
        let mut core = Self::new(config, params);
        if !warm.airborne {
            return core;
        }
        if let Some(origin) = warm.origin {
            core.nav.set_origin(origin);
        }
        core.home_ned_m = warm.home_ned_m.map(Vector3::from);
        core.airborne_once = true;
        core.has_flown = true;
        core.plan_abandoned = true;
        core.alignment = Some(Alignment {
            warm,
            since_us: None,
            accel_sum_mps2: Vector3::zeros(),
            samples: 0,
            gps_seen: false,
        });
        core.phase = Phase::BlindDescent;
        core
    }

    /// What this process would leave its successor now (`None` before the calibration).
    pub fn warm_start(&self) -> Option<WarmStart> {
        let state = self.nav.state()?;
        let b = state.gyro_bias_rps;
        Some(WarmStart {
            gyro_bias_rps: [b.x, b.y, b.z],
            origin: self.nav.origin(),
            home_ned_m: self.home_ned_m.map(|h| [h.x, h.y, h.z]),
            airborne: self.airborne_once,
            trim: self.trim,
        })
    }

    /// Keeps the average of the servo commands of autonomous flight in the air.
    pub(super) fn average_trim(&mut self, controls: &Controls, dt_s: f64) {
        let k = (dt_s / TRIM_AVERAGE_S).clamp(0.0, 1.0);
        let avg = |a: f64, b: f64| a + k * (b - a);
        self.trim = Some(match self.trim {
            None => *controls,
            Some(t) => Controls {
                aileron: avg(t.aileron, controls.aileron),
                elevator: avg(t.elevator, controls.elevator),
                rudder: avg(t.rudder, controls.rudder),
                collective: avg(t.collective, controls.collective),
                throttle: controls.throttle,
            },
        });
    }

    /// What a restarted process flies while it aligns: the trim its predecessor left, with
    /// the tail damping the yaw rate the gyro measures less its known bias; without a trim,
    /// the blind failsafe with yaw damping.
    pub(super) fn aligning_controls(&self, gyro_z_rps: f64) -> Option<Controls> {
        let a = self.alignment.as_ref()?;
        let yaw_rate = gyro_z_rps - a.warm.gyro_bias_rps[2];
        let damper = &self.config.yaw_damper;
        Some(match a.warm.trim {
            Some(trim) => Controls {
                rudder: trim.rudder - damper.gain * yaw_rate,
                ..trim
            }
            .clamped(),
            None => Controls {
                collective: self.config.hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
                rudder: damper.trim - damper.gain * yaw_rate,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            }
            .clamped(),
        })
    }

    /// True while an in-air alignment is under way.
    pub fn aligning(&self) -> bool {
        self.alignment.is_some()
    }

    /// One real IMU sample of the in-air alignment; at its end the estimate starts.
    pub(super) fn align(&mut self, now_us: u64, sample: &ImuRepr, out: &mut Vec<Action>) {
        let Some(a) = self.alignment.as_mut() else {
            return;
        };
        let since = match a.since_us {
            Some(since) => since,
            None => {
                a.since_us = Some(now_us);
                out.push(Action::Event(Stamped::new(
                    now_us,
                    CoreEvent::RestartedInAir,
                )));
                now_us
            }
        };
        a.accel_sum_mps2 += Vector3::from(sample.accel_mps2);
        a.samples = a.samples.saturating_add(1);
        a.gps_seen |= self.nav.origin().is_some() && self.last_good_fix.is_some();
        let elapsed = seconds_between(since, now_us);
        if elapsed < ALIGN_S || (!a.gps_seen && elapsed < ALIGN_GPS_WAIT_S) {
            return;
        }
        let biases = heli_nav::ImuBiases {
            gyro_rps: Vector3::from(a.warm.gyro_bias_rps),
            mean_accel_mps2: a.accel_sum_mps2 / f64::from(a.samples.max(1)),
            samples: a.samples,
        };
        let gps = a.gps_seen;
        self.alignment = None;
        let gps_vel = self
            .last_good_fix
            .filter(|_| gps)
            .map(|(_, fix)| Vector3::from(fix.vel_ned_mps));
        self.nav.initialise_in_air(now_us, &biases, gps_vel);
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::AlignedInAir { gps },
        )));
    }
}
