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
    /// The earth's field and the altimeter's reference learned on the ground: a successor
    /// keeps them rather than learning them again from a levelling in the air.
    pub references: heli_nav::GroundReferences,
    /// A roll under way when the record was made: a process started again within the servo
    /// board's hold finishes it rather than aligning on a rolling helicopter.
    pub roll: Option<RollRecord>,
}

/// A roll under way: what a process started again in it needs to go on with it (the board
/// held the last command meanwhile, so the helicopter kept rolling unseen).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollRecord {
    /// When (µs) on the clock of the core that holds the record: its own, or for a record a
    /// process before left, the new clock its runtime rebased it onto (negative: before the
    /// new clock began).
    pub at_us: i64,
    /// The angle turned by then, in the commanded direction (rad).
    pub angle_rad: f64,
    /// The body rates then, less the gyro bias (rad/s).
    pub rate_rps: [f64; 3],
    /// The estimated attitude then (body to NED, quaternion `[w, x, y, z]`).
    pub att: [f64; 4],
    /// Time in the roll by then (s).
    pub elapsed_s: f64,
    /// Rolls finished before this one.
    pub rolls_done: u32,
    /// Where the helicopter was (m, NED in the flight's frame).
    pub pos_ned_m: [f64; 3],
    /// Its heading (rad).
    pub yaw_rad: f64,
}

/// The longest a roll may go unseen and still be finished from its record (s): the servo
/// board holds the computer's last command for a second (`heli_proto::scb`), so the
/// helicopter rolls on that command for as long; after that it flies the pilot's sticks,
/// and where it went is not known.
pub const ROLL_UNSEEN_MAX_S: f64 = 1.0;

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
    /// The attitude when the window opened, carried by the gyros from a record (a restart
    /// in a roll): used instead of a levelling on the accelerometers, which after a roll
    /// lean with the helicopter's acceleration and, through the compass's steep field, throw
    /// the heading far out.
    carried: Option<UnitQuaternion<f64>>,
}

/// The restart's side of the core.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Restart {
    /// An in-air alignment after a restart, instead of the ground calibration.
    alignment: Option<Alignment>,
    /// Restarted in a roll: the record to align from once the roll is finished (a rolling
    /// helicopter's accelerometers say nothing of which way is up).
    after_roll: Option<WarmStart>,
    /// Restarted in a roll, before the first sample: the roll as recorded, to be carried on
    /// over the time nobody saw it.
    unseen_roll: Option<RollRecord>,
    /// Restarted in a roll: the attitude carried from the record by the gyros, and the time
    /// of the last sample that carried it.
    carried: Option<(UnitQuaternion<f64>, u64)>,
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
                carried: None,
            }),
            ..Self::default()
        }
    }

    /// A restart in the roll `roll` recorded in `warm`: the roll is finished first (on the
    /// gyros, [`super::roll::blind_step`]), then the process aligns from `warm`.
    pub fn in_roll(warm: WarmStart, roll: RollRecord) -> Self {
        Self {
            after_roll: Some(warm),
            unseen_roll: Some(roll),
            ..Self::default()
        }
    }

    /// The roll recorded before the restart, once: at the first real sample.
    pub fn take_unseen_roll(&mut self) -> Option<RollRecord> {
        self.unseen_roll.take()
    }

    /// The roll is finished (or was never to be resumed): the alignment from the record
    /// begins, once, from the attitude carried through the roll if there is one.
    pub fn align_after_roll(&mut self) -> bool {
        let carried = self.carried.take().map(|(att, _)| att);
        match self.after_roll.take() {
            Some(warm) => {
                // Nothing else to keep: a process restarted in a roll has averaged no trim
                // of its own (the blind roll is not a hold).
                let mut next = Self::aligning_from(warm);
                if let Some(a) = next.alignment.as_mut() {
                    a.carried = carried;
                }
                *self = next;
                true
            }
            None => false,
        }
    }

    /// Starts carrying the attitude `att` at `now_us` (reckoned over the unseen time).
    pub fn carry_from(&mut self, att: UnitQuaternion<f64>, now_us: u64) {
        self.carried = Some((att, now_us));
    }

    /// Carries the attitude on by one real sample's rates (less the record's gyro bias); a
    /// gap longer than a few samples is not integrated.
    pub fn carry(&mut self, sample: &ImuRepr, now_us: u64) {
        let bias = Vector3::from(self.after_roll.map_or([0.0; 3], |w| w.gyro_bias_rps));
        if let Some((att, last_us)) = self.carried.as_mut() {
            let dt_s = seconds_between(*last_us, now_us).clamp(0.0, MAX_ALIGN_STEP_S);
            let rate = Vector3::from(sample.rate_rps) - bias;
            *att *= UnitQuaternion::from_scaled_axis(rate * dt_s);
            *last_us = now_us;
        }
    }

    /// The gyro biases of the record a restart in a roll waits to align from.
    pub fn waiting_bias_rps(&self) -> Option<[f64; 3]> {
        self.after_roll.map(|w| w.gyro_bias_rps)
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
            carried: None,
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
        let carried_now = a.carried.map(|start| start * a.to_start);
        self.alignment = None;
        let gps_vel = last_good_fix
            .filter(|_| gps)
            .map(|(_, fix)| Vector3::from(fix.vel_ned_mps));
        nav.initialise_in_air(now_us, &biases, gps_vel);
        if let Some(att) = carried_now {
            nav.set_attitude_in_air(att);
        }
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::AlignedInAir { gps },
        )));
    }
}
