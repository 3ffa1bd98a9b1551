//! A flight process that starts again in the air: after a brown-out of the flight computer
//! or a crash of the process, the bootstrap starts a new one, which must not calibrate for
//! 80 s on a helicopter that is flying.
//!
//! The design (docs/architecture.md, "restart in the air"): the flight process keeps a
//! [`WarmStart`] record where its runtime persists it (the vehicle writes it to a file on
//! every change). A process started with a record that says the helicopter was airborne
//! skips the ground calibration: it keeps the gyro biases and the navigation frame of the
//! flight before, and aligns in the air — roll and pitch from a second of accelerometer
//! readings (each turned back, by the gyros, into the frame the helicopter had when the window
//! opened, so that a helicopter still turning — after a stall in a roll — is levelled where
//! it is at the end, not at the mean of where it was), heading from the compass, position
//! from the first GPS fix (it waits up to
//! [`ALIGN_GPS_WAIT_S`] for one). While it aligns it flies the blind failsafe (cyclic
//! neutral, collective a little under hover). Aligned, it holds position where it is if the
//! auto switch is on (the flight plan is not resumed: where it stood is not known for
//! sure), or hands the helicopter to the pilot if the switch is off, as ArduPilot does after
//! a watchdog reset in flight.
//!
//! A component: it owns the alignment under way and the trim kept for a successor; the
//! core hands it the real IMU samples while it aligns and each step's command while it
//! flies autonomously, and it starts the filter in the air when the alignment is done.

use heli_control::{HoverGains, YawDamper};
use heli_nav::{Navigator, seconds_between};
use heli_proto::gps::GpsNav;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::Controls;
use nalgebra::{UnitQuaternion, Vector3};

use super::event::CoreEvent;
use super::{Action, BLIND_DESCENT_COLLECTIVE_MARGIN, Stamped};

/// Accelerometer readings averaged for the attitude of an in-air alignment (s).
pub const ALIGN_S: f64 = 1.0;

/// Longest interval between two samples the alignment integrates the gyros over (s): five
/// IMU periods.
pub const MAX_ALIGN_STEP_S: f64 = 0.05;

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
struct Alignment {
    warm: WarmStart,
    /// The IMU came back after a stall (not a restart of the process).
    after_stall: bool,
    since_us: Option<u64>,
    /// The last sample's time.
    last_us: Option<u64>,
    /// From the body frame now to the body frame when the window opened, by the gyros.
    to_start: UnitQuaternion<f64>,
    /// The specific force, in the body frame when the window opened, summed.
    accel_sum_mps2: Vector3<f64>,
    samples: u32,
    gps_seen: bool,
}

/// The restart's side of the core.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Restart {
    /// An in-air alignment after a restart, instead of the ground calibration.
    alignment: Option<Alignment>,
    /// The average servo command of autonomous flight in the air (for a restart).
    pub(super) trim: Option<Controls>,
}

impl Restart {
    /// A restart from `warm`: an alignment in the air to come.
    pub fn aligning_from(warm: WarmStart) -> Self {
        Self {
            alignment: Some(Alignment {
                warm,
                after_stall: false,
                since_us: None,
                last_us: None,
                to_start: UnitQuaternion::identity(),
                accel_sum_mps2: Vector3::zeros(),
                samples: 0,
                gps_seen: false,
            }),
            trim: None,
        }
    }

    /// The IMU is back after a stall long enough to declare the estimate invalid, in the
    /// air: an alignment as after a restart, from `warm` (what the flight knew before, the
    /// trim averaged so far included: `FlightCore::warm_start`).
    pub fn align_after_stall(&mut self, warm: WarmStart) {
        self.alignment = Some(Alignment {
            warm,
            after_stall: true,
            since_us: None,
            last_us: None,
            to_start: UnitQuaternion::identity(),
            accel_sum_mps2: Vector3::zeros(),
            samples: 0,
            gps_seen: false,
        });
    }

    /// The trim kept so far.
    pub fn trim(&self) -> Option<Controls> {
        self.trim
    }

    /// Keeps the average of the servo commands of autonomous flight in the air.
    pub fn average_trim(&mut self, controls: &Controls, dt_s: f64) {
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
    pub fn aligning_controls(
        &self,
        damper: &YawDamper,
        hover: &HoverGains,
        gyro_z_rps: f64,
    ) -> Option<Controls> {
        let a = self.alignment.as_ref()?;
        let yaw_rate = gyro_z_rps - a.warm.gyro_bias_rps[2];
        Some(match a.warm.trim {
            Some(trim) => Controls {
                rudder: trim.rudder - damper.gain * yaw_rate,
                ..trim
            }
            .clamped(),
            None => Controls {
                collective: hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
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

    /// One real IMU sample of the in-air alignment; at its end the filter `nav` starts in
    /// the air, on the GPS velocity of the last good fix when one came.
    pub fn align(
        &mut self,
        nav: &mut Navigator,
        last_good_fix: Option<(u64, GpsNav)>,
        now_us: u64,
        sample: &ImuRepr,
        out: &mut Vec<Action>,
    ) {
        let Some(a) = self.alignment.as_mut() else {
            return;
        };
        let since = match a.since_us {
            Some(since) => since,
            None => {
                a.since_us = Some(now_us);
                let event = if a.after_stall {
                    CoreEvent::ImuBackInAir
                } else {
                    CoreEvent::RestartedInAir
                };
                out.push(Action::Event(Stamped::new(now_us, event)));
                now_us
            }
        };
        // The turn since the last sample, by the gyro less its known bias (a gap longer than
        // a few samples is not integrated: the rate across it is not known).
        if let Some(last) = a.last_us {
            let dt_s = seconds_between(last, now_us).clamp(0.0, MAX_ALIGN_STEP_S);
            let rate = Vector3::from(sample.rate_rps) - Vector3::from(a.warm.gyro_bias_rps);
            a.to_start *= UnitQuaternion::from_scaled_axis(rate * dt_s);
        }
        a.last_us = Some(now_us);
        a.accel_sum_mps2 += a.to_start * Vector3::from(sample.accel_mps2);
        a.samples = a.samples.saturating_add(1);
        // After a stall, a fix from before the window (the last one before the IMU went
        // silent) places the helicopter where it was, not where it is: only a fix that came
        // while aligning counts. A restarted process has only fixes of its own.
        let after_stall = a.after_stall;
        a.gps_seen |= nav.origin().is_some()
            && last_good_fix.is_some_and(|(at_us, _)| !after_stall || at_us >= since);
        let elapsed = seconds_between(since, now_us);
        if elapsed < ALIGN_S || (!a.gps_seen && elapsed < ALIGN_GPS_WAIT_S) {
            return;
        }
        // The mean specific force, turned into the body frame of now.
        let mean_now = a.to_start.inverse() * (a.accel_sum_mps2 / f64::from(a.samples.max(1)));
        let biases = heli_nav::ImuBiases {
            gyro_rps: Vector3::from(a.warm.gyro_bias_rps),
            mean_accel_mps2: mean_now,
            samples: a.samples,
        };
        let gps = a.gps_seen;
        self.alignment = None;
        let gps_vel = last_good_fix
            .filter(|_| gps)
            .map(|(_, fix)| Vector3::from(fix.vel_ned_mps));
        nav.initialise_in_air(now_us, &biases, gps_vel);
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::AlignedInAir { gps },
        )));
    }
}
