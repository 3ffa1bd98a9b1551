//! The navigation filter: an error-state extended Kalman filter around a strapdown INS.
//!
//! The nominal state — attitude quaternion (body to NED), NED velocity and position, gyro and
//! accelerometer biases — is propagated at 50 Hz with the mean of the two most recent 100 Hz
//! IMU samples (as the thesis's main loop does). A 15-element error state (attitude error as a
//! small rotation in NED axes, velocity, position, gyro bias, accelerometer bias) carries the
//! covariance. Aiding:
//!
//! - **GPS** position (horizontal) and velocity at 1 Hz, valid about one second before the
//!   fix arrives. The filter keeps a log of everything it did for the last few seconds —
//!   each propagation with the state and covariance before it, each altimeter and compass
//!   update. A fix rolls the filter back to its time of validity, is fused there, and the
//!   logged propagations and updates are replayed to the present: the exact delayed update,
//!   the job PX4's EKF2 does with its delayed fusion horizon.
//! - **Barometric altitude** at 5 Hz, referenced to the pressure read on the ground during
//!   calibration.
//! - **Magnetic field** at 20 Hz, all three axes against the earth field learned at
//!   initialisation, so that heading (and tilt) stay observable at any attitude — inverted
//!   included, where a heading computed from the field would be singular.
//!
//! The accelerometer is never used as a gravity reference: in a roll it is not one. Attitude
//! is held by the gyros, with tilt made observable by GPS velocity and the magnetic field.
//!
//! Every aiding sample passes a normalised-innovation gate; a rejected one is counted, never
//! fused, so a sensor that stops or lies cannot drag the state away.

use std::collections::VecDeque;

use heli_proto::baro::pressure_altitude_m;
use heli_proto::compass::{MagField, heading_rad};
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use crate::calibration::{ImuBiases, seconds_to_us};
use crate::geo::GeoOrigin;
use crate::{GRAVITY_MPS2, seconds_between};

/// Error-state size.
pub const N_ERR: usize = 15;
/// Error-state covariance.
pub type Covariance = SMatrix<f64, N_ERR, N_ERR>;
type ErrState = SVector<f64, N_ERR>;

/// Offsets of the error-state blocks.
pub mod ix {
    /// Attitude error (small rotation, NED axes).
    pub const ATT: usize = 0;
    /// Velocity error.
    pub const VEL: usize = 3;
    /// Position error.
    pub const POS: usize = 6;
    /// Gyro bias error.
    pub const GYRO_BIAS: usize = 9;
    /// Accelerometer bias error.
    pub const ACCEL_BIAS: usize = 12;
}

/// Noise, gates, latency and initial uncertainty of the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    /// GPS latency: a fix is valid this long before its last byte arrives (s).
    pub gps_latency_s: f64,
    /// Fewest satellites for a usable fix (the thesis's ground display wants at least four).
    pub gps_min_satellites: u8,
    /// GPS horizontal position noise (m, 1σ).
    pub gps_pos_sigma_m: f64,
    /// GPS velocity noise (m/s, 1σ).
    pub gps_vel_sigma_mps: f64,
    /// Barometric altitude noise (m, 1σ): noise, 2 ft resolution, ground effect.
    pub baro_sigma_m: f64,
    /// Magnetometer noise (gauss, 1σ per axis), calibration residuals included.
    pub mag_sigma_gauss: f64,
    /// Innovation gate, in standard deviations.
    pub gate_sigmas: f64,
    /// Gyro noise density (rad/s/√Hz), rotor vibration included.
    pub gyro_noise_density: f64,
    /// Accelerometer noise density (m/s²/√Hz), rotor vibration included.
    pub accel_noise_density: f64,
    /// Gyro bias random walk (rad/s/√s).
    pub gyro_bias_walk: f64,
    /// Accelerometer bias random walk (m/s²/√s).
    pub accel_bias_walk: f64,
    /// Initial tilt uncertainty (rad, 1σ).
    pub initial_tilt_sigma_rad: f64,
    /// Initial heading uncertainty (rad, 1σ).
    pub initial_heading_sigma_rad: f64,
    /// Initial velocity uncertainty (m/s, 1σ).
    pub initial_vel_sigma_mps: f64,
    /// Initial position uncertainty (m, 1σ).
    pub initial_pos_sigma_m: f64,
    /// Gyro bias uncertainty left after the calibration (rad/s, 1σ).
    pub initial_gyro_bias_sigma_rps: f64,
    /// Accelerometer bias uncertainty (m/s², 1σ): the calibration cannot tell it from tilt.
    pub initial_accel_bias_sigma_mps2: f64,
    /// Magnetic declination: true heading = magnetic heading + declination (rad).
    pub declination_rad: f64,
    /// How much past state to keep for delayed fusion (s).
    pub history_s: f64,
    /// After this long without a fused fix (s), fixes that keep failing the gate reset the
    /// position and velocity to GPS (`navigator::reset`): the inertial solution has drifted,
    /// not the GPS. PX4 and ArduPilot reset on a timeout likewise.
    pub gps_reset_after_s: f64,
    /// Fixes in a row that must fail the gate before such a reset.
    pub gps_reset_rejections: u32,
    /// No GPS fused for this long is an outage (s).
    pub gps_outage_after_s: f64,
    /// The velocity of a helicopter standing on its skids, as a zero-velocity update
    /// ([`Navigator::fuse_still`]) sees it: the rocking and the rotor's shaking at the IMU
    /// (σ, m/s).
    pub still_sigma_mps: f64,
}

impl Default for NavConfig {
    fn default() -> Self {
        Self {
            gps_latency_s: 1.0,
            gps_min_satellites: 4,
            gps_pos_sigma_m: 0.7,
            gps_vel_sigma_mps: 0.08,
            baro_sigma_m: 0.5,
            mag_sigma_gauss: 0.01,
            gate_sigmas: 5.0,
            gyro_noise_density: 1.5e-3,
            accel_noise_density: 0.05,
            gyro_bias_walk: 2e-5,
            accel_bias_walk: 2e-4,
            initial_tilt_sigma_rad: 0.03,
            initial_heading_sigma_rad: 0.2,
            initial_vel_sigma_mps: 0.3,
            initial_pos_sigma_m: 1.0,
            initial_gyro_bias_sigma_rps: 2e-3,
            initial_accel_bias_sigma_mps2: 0.1,
            declination_rad: 0.0,
            history_s: 2.5,
            gps_outage_after_s: 3.0,
            gps_reset_after_s: 5.0,
            gps_reset_rejections: 3,
            still_sigma_mps: 0.05,
        }
    }
}

/// The estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState {
    /// Time of the IMU sample the estimate was propagated to (µs).
    pub t_us: u64,
    /// Attitude, body to NED.
    pub att: UnitQuaternion<f64>,
    /// Velocity, NED (m/s).
    pub vel_ned_mps: Vector3<f64>,
    /// Position, NED about the GPS origin (m).
    pub pos_ned_m: Vector3<f64>,
    /// Bias-corrected angular rate, body axes (rad/s).
    pub rate_body_rps: Vector3<f64>,
    /// Bias-corrected specific force, body axes (m/s²).
    pub accel_body_mps2: Vector3<f64>,
    /// Estimated gyro bias (rad/s).
    pub gyro_bias_rps: Vector3<f64>,
    /// Estimated accelerometer bias (m/s²).
    pub accel_bias_mps2: Vector3<f64>,
}

impl NavState {
    /// Roll, pitch and yaw (rad), ZYX Euler angles.
    pub fn euler_rad(&self) -> (f64, f64, f64) {
        self.att.euler_angles()
    }
}

/// Counts of what each aiding sensor contributed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NavSensorStats {
    /// GPS fixes fused.
    pub gps_fused: u32,
    /// GPS fixes rejected (gate, too few satellites, no fix, too old).
    pub gps_rejected: u32,
    /// Barometer readings fused.
    pub baro_fused: u32,
    /// Barometer readings rejected.
    pub baro_rejected: u32,
    /// Compass readings fused.
    pub compass_fused: u32,
    /// Compass readings rejected.
    pub compass_rejected: u32,
    /// Position and velocity resets to GPS after a long rejection (see
    /// [`NavConfig::gps_reset_after_s`]).
    pub gps_resets: u32,
    /// GPS fixes rejected by the gate in a row, since the last one fused.
    pub gps_rejected_in_row: u32,
    /// Time the last GPS fix was fused (µs), 0 if never.
    pub last_gps_fused_us: u64,
    /// Time of the estimate when an altimeter reading was last fused (µs), 0 if never.
    pub last_baro_fused_us: u64,
    /// Time of the estimate when a compass reading was last fused (µs), 0 if never.
    pub last_compass_fused_us: u64,
    /// Zero-velocity updates fused (standing on the skids).
    pub still_fused: u32,
    /// Zero-velocity updates refused by the gate (it was moving after all).
    pub still_rejected: u32,
}

/// One thing the filter did, kept for replay after a delayed fix.
// The propagation variant carries a covariance inline on purpose: the log is allocated once,
// and boxing would allocate in the 50 Hz step.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum Op {
    /// A propagation to `t_us` with two IMU samples; `before` is the state and covariance
    /// it started from.
    Propagate {
        t_us: u64,
        a: ImuRepr,
        b: ImuRepr,
        before: NavState,
        cov_before: Covariance,
    },
    /// An altimeter update.
    Baro(f64),
    /// A compass update.
    Mag(MagField),
    /// A zero-velocity update.
    Still,
}

/// What the filter records in a second, for the history a delayed fix is replayed from:
/// propagations at 50 Hz, altimeter at 5 Hz, compass at 20 Hz, zero-velocity updates on the
/// skids at up to 10 Hz.
const OPS_PER_S: f64 = 85.0;

/// The navigation filter.
#[derive(Clone, Debug)]
pub struct Navigator {
    config: NavConfig,
    state: Option<NavState>,
    cov: Covariance,
    origin: Option<GeoOrigin>,
    last_gps_ned: Option<Vector3<f64>>,
    /// When the last usable fix was valid (its arrival less the GPS's latency, µs).
    last_gps_valid_us: Option<u64>,
    baro_reference_mbar: Option<f64>,
    baro_reference_z_m: f64,
    baro_sum_mbar: f64,
    baro_count: u32,
    last_field: Option<MagField>,
    earth_field_ned: Option<Vector3<f64>>,
    history: VecDeque<Op>,
    /// Scratch for the operations replayed after a delayed GPS fix, allocated once.
    replay: Vec<Op>,
    history_len: usize,
    initialised_us: u64,
    stats: NavSensorStats,
    /// The test ratio of the last update, whatever its aid.
    last_test_ratio: f64,
    /// The last test ratio of each aid.
    ratios: health::TestRatios,
}

mod covariance;
mod fusion;
mod health;
mod reset;
mod still;
pub use reset::GroundReferences;

use covariance::Transition;

pub use health::FilterHealth;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn mean3(a: [f64; 3], b: [f64; 3]) -> Vector3<f64> {
    (Vector3::from(a) + Vector3::from(b)) * 0.5
}

/// Angle wrapped to (−π, π].
pub fn wrap_pi(angle: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let a = angle.rem_euclid(two_pi);
    if a > std::f64::consts::PI {
        a - two_pi
    } else {
        a
    }
}

impl Navigator {
    /// A filter waiting for its initialisation.
    pub fn new(config: NavConfig) -> Self {
        // The log must reach back past the GPS latency, and stays bounded: 0.5–10 s beyond it.
        let latency_s = if config.gps_latency_s.is_finite() {
            config.gps_latency_s.clamp(0.0, 5.0)
        } else {
            1.0
        };
        let history_s = if config.history_s.is_finite() {
            config.history_s
        } else {
            0.0
        };
        let config = NavConfig {
            gps_latency_s: latency_s,
            history_s: history_s.clamp(latency_s + 0.5, latency_s + 10.0),
            ..config
        };
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "history_s is clamped to a few seconds above"
        )]
        let history_len = (config.history_s * OPS_PER_S).ceil() as usize;
        Self {
            config,
            state: None,
            cov: Covariance::zeros(),
            origin: None,
            last_gps_ned: None,
            last_gps_valid_us: None,
            baro_reference_mbar: None,
            baro_reference_z_m: 0.0,
            baro_sum_mbar: 0.0,
            baro_count: 0,
            last_field: None,
            earth_field_ned: None,
            history: VecDeque::with_capacity(history_len.saturating_add(1)),
            replay: Vec::with_capacity(history_len.saturating_add(1)),
            history_len,
            initialised_us: 0,
            stats: NavSensorStats::default(),
            last_test_ratio: 0.0,
            ratios: health::TestRatios::default(),
        }
    }

    /// The estimate, once initialised.
    pub fn state(&self) -> Option<&NavState> {
        self.state.as_ref()
    }

    /// The error-state covariance.
    pub fn covariance(&self) -> &Covariance {
        &self.cov
    }

    /// What the aiding sensors contributed.
    pub fn stats(&self) -> NavSensorStats {
        self.stats
    }

    /// True when no GPS fix has been fused for longer than the configured outage time.
    pub fn gps_outage(&self, now_us: u64) -> bool {
        // Counted from the initialisation when no fix has been fused since.
        let last = self.stats.last_gps_fused_us.max(self.initialised_us);
        self.state.is_some() && seconds_between(last, now_us) > self.config.gps_outage_after_s
    }

    /// Origin of the local frame (the first good GPS fix).
    pub fn origin(&self) -> Option<GeoOrigin> {
        self.origin
    }

    /// Sets the origin of the local frame before any fix has: a filter started again in the
    /// air keeps the frame of the flight before (an origin already set is kept).
    pub fn set_origin(&mut self, origin: GeoOrigin) {
        self.origin.get_or_insert(origin);
    }

    /// The reference pressure of the barometric altitude (mbar).
    pub fn baro_reference_mbar(&self) -> Option<f64> {
        self.baro_reference_mbar
    }

    /// Starts the estimate at `t_us` from the calibration: roll and pitch from the mean
    /// specific force, heading from the compass if one was read, position from the last GPS
    /// fix if any, at rest, gyro biases from the calibration; the barometric reference is the
    /// mean pressure read so far.
    pub fn initialise(&mut self, t_us: u64, biases: &ImuBiases) {
        let c = self.config;
        let f = biases.mean_accel_mps2;
        let roll = (-f.y).atan2(-f.z);
        let pitch = f.x.atan2((f.y * f.y + f.z * f.z).sqrt());
        let pos = self.last_gps_ned.unwrap_or_else(Vector3::zeros);
        if self.baro_count > 0 {
            self.baro_reference_mbar = Some(self.baro_sum_mbar / f64::from(self.baro_count));
            self.baro_reference_z_m = pos.z;
        }
        self.history.clear();
        self.initialised_us = t_us;
        self.state = Some(NavState {
            t_us,
            att: UnitQuaternion::from_euler_angles(roll, pitch, 0.0),
            vel_ned_mps: Vector3::zeros(),
            pos_ned_m: pos,
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: f,
            gyro_bias_rps: biases.gyro_rps,
            // Sitting still, the accelerometers must read exactly 1 g; what they read beyond
            // that along the measured direction is bias. (Across it, bias cannot be told from
            // tilt on the ground; the filter's accelerometer-bias states learn it in flight.)
            accel_bias_mps2: if f.norm() > 1.0 {
                f * (1.0 - GRAVITY_MPS2 / f.norm())
            } else {
                Vector3::zeros()
            },
        });
        let mut diag = ErrState::zeros();
        let blocks = [
            (ix::VEL, c.initial_vel_sigma_mps),
            (ix::POS, c.initial_pos_sigma_m),
            (ix::GYRO_BIAS, c.initial_gyro_bias_sigma_rps),
            (ix::ACCEL_BIAS, c.initial_accel_bias_sigma_mps2),
        ];
        for (offset, sigma) in blocks {
            diag.fixed_rows_mut::<3>(offset).fill(sigma * sigma);
        }
        let tilt = c.initial_tilt_sigma_rad.powi(2);
        diag.fixed_rows_mut::<3>(ix::ATT).copy_from(&Vector3::new(
            tilt,
            tilt,
            c.initial_heading_sigma_rad.powi(2),
        ));
        self.cov = Covariance::from_diagonal(&diag);
        self.earth_field_ned = None;
        if let Some(field) = self.last_field {
            self.align_heading(&field);
        }
    }

    /// Sets the heading from a magnetic reading (tilt-compensated with the current roll and
    /// pitch) and learns the earth's field in NED from it.
    fn align_heading(&mut self, field: &MagField) {
        let declination = self.config.declination_rad;
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let (roll, pitch, _) = state.att.euler_angles();
        let Some(heading) = heading_rad(field, roll, pitch) else {
            return;
        };
        state.att = UnitQuaternion::from_euler_angles(roll, pitch, heading + declination);
        self.earth_field_ned = Some(state.att * Vector3::from(field.field_gauss));
        // The heading was a guess until now: nothing before this may be replayed over it, so
        // the log starts here and a fix valid earlier is refused as too old.
        self.history.clear();
    }

    /// Propagates to the later of two IMU samples, `a` taken before `b` at `t_b_us`, using
    /// their mean (the thesis propagates every other sample with "the two most recent
    /// readings").
    pub fn propagate(&mut self, t_b_us: u64, a: &ImuRepr, b: &ImuRepr) {
        let Some(before) = self.state else { return };
        let cov_before = self.cov;
        if self.apply_propagate(t_b_us, a, b) {
            self.record(Op::Propagate {
                t_us: t_b_us,
                a: *a,
                b: *b,
                before,
                cov_before,
            });
        }
    }

    fn record(&mut self, op: Op) {
        self.history.push_back(op);
        while self.history.len() > self.history_len {
            self.history.pop_front();
        }
    }

    fn apply_propagate(&mut self, t_b_us: u64, a: &ImuRepr, b: &ImuRepr) -> bool {
        let c = self.config;
        let Some(state) = self.state.as_mut() else {
            return false;
        };
        let dt = seconds_between(state.t_us, t_b_us).min(0.1);
        let rate = mean3(a.rate_rps, b.rate_rps) - state.gyro_bias_rps;
        let accel = mean3(a.accel_mps2, b.accel_mps2) - state.accel_bias_mps2;
        if !(rate.iter().all(|x| x.is_finite()) && accel.iter().all(|x| x.is_finite())) {
            return false;
        }
        let att0 = state.att;
        let att1 = att0 * UnitQuaternion::from_scaled_axis(rate * dt);
        let att_mid = att0.slerp(&att1, 0.5);
        let rot = att_mid.to_rotation_matrix().into_inner();
        let f_ned = rot * accel;
        let accel_ned = f_ned + Vector3::new(0.0, 0.0, GRAVITY_MPS2);
        let vel0 = state.vel_ned_mps;
        state.vel_ned_mps = vel0 + accel_ned * dt;
        state.pos_ned_m += (vel0 + state.vel_ned_mps) * (0.5 * dt);
        state.att = att1;
        state.t_us = t_b_us;
        state.rate_body_rps = rate;
        state.accel_body_mps2 = accel;

        // Error-state transition and process noise.
        let phi = Transition {
            att_from_gyro_bias: -rot * dt,
            vel_from_att: -skew(&f_ned) * dt,
            vel_from_accel_bias: -rot * dt,
            dt_s: dt,
        };
        let mut q = ErrState::zeros();
        let noise = [
            (ix::ATT, c.gyro_noise_density),
            (ix::VEL, c.accel_noise_density),
            (ix::GYRO_BIAS, c.gyro_bias_walk),
            (ix::ACCEL_BIAS, c.accel_bias_walk),
        ];
        for (offset, density) in noise {
            q.fixed_rows_mut::<3>(offset).fill(density * density * dt);
        }
        self.cov = phi.propagate(&self.cov, &q);
        true
    }

    /// Applies an error-state correction to the nominal state.
    fn inject(&mut self, dx: &ErrState) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let dth: Vector3<f64> = dx.fixed_rows::<3>(ix::ATT).into_owned();
        state.att = UnitQuaternion::from_scaled_axis(dth) * state.att;
        state.vel_ned_mps += dx.fixed_rows::<3>(ix::VEL);
        state.pos_ned_m += dx.fixed_rows::<3>(ix::POS);
        state.gyro_bias_rps += dx.fixed_rows::<3>(ix::GYRO_BIAS);
        state.accel_bias_mps2 += dx.fixed_rows::<3>(ix::ACCEL_BIAS);
    }

    /// Keeps the covariance symmetric and its diagonal positive after an update.
    fn tidy_covariance(&mut self) {
        self.cov = (self.cov + self.cov.transpose()) * 0.5;
        for i in 0..N_ERR {
            if let Some(d) = self.cov.get_mut((i, i)) {
                *d = d.max(1e-12);
            }
        }
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod algebra_tests;
#[cfg(test)]
mod references_tests;
