//! The navigation filter: a strapdown INS propagated at 50 Hz from the two most recent 100 Hz
//! IMU samples (as the thesis's main loop does), held to the truth by complementary
//! corrections:
//!
//! - **tilt** from the accelerometer, only while the specific force is close to 1 g (in a
//!   steady flight condition it points straight up whatever the rotor's tilt);
//! - **heading** from the tilt-compensated compass (20 Hz);
//! - **altitude** from the barometer (5 Hz), referenced to the pressure measured on the ground
//!   during calibration;
//! - **horizontal position and velocity** from GPS (1 Hz). A fix is valid about one second
//!   before it arrives; the filter keeps a history of its own past states, forms the
//!   innovation against the state at the fix's time of validity (as PX4's EKF2 fuses on a
//!   delayed horizon), and carries the correction forward to now.
//!
//! Every aiding sample passes an innovation gate; a rejected one is counted, never fused.
//! The error-state Kalman filter of a later issue replaces the fixed gains here.

use std::collections::VecDeque;

use heli_proto::baro::pressure_altitude_m;
use heli_proto::compass::{MagField, heading_rad};
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use nalgebra::{UnitQuaternion, Vector3};

use crate::calibration::{ImuBiases, seconds_to_us};
use crate::geo::GeoOrigin;
use crate::{GRAVITY_MPS2, seconds_between};

/// Gains, gates and latencies of the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    /// GPS latency: a fix is valid this long before its last byte arrives (s).
    pub gps_latency_s: f64,
    /// Fewest satellites for a usable fix (the thesis's ground display wants at least four).
    pub gps_min_satellites: u8,
    /// Fraction of a GPS position innovation applied at each fix.
    pub gps_pos_gain: f64,
    /// Velocity correction per metre of GPS position innovation (1/s).
    pub gps_vel_from_pos_gain: f64,
    /// Fraction of a GPS velocity innovation applied at each fix.
    pub gps_vel_gain: f64,
    /// GPS position innovations larger than this are rejected (m).
    pub gps_gate_m: f64,
    /// Fraction of a barometric altitude innovation applied per reading.
    pub baro_alt_gain: f64,
    /// Vertical-velocity correction per metre of barometric innovation (1/s).
    pub baro_vel_gain: f64,
    /// Barometric innovations larger than this are rejected (m).
    pub baro_gate_m: f64,
    /// Tilt correction rate toward the accelerometer's "up" (1/s).
    pub tilt_gain_per_s: f64,
    /// The accelerometer is used for tilt only while |f| is within this fraction of 1 g.
    pub tilt_accel_tolerance: f64,
    /// Fraction of a compass heading innovation applied per reading.
    pub heading_gain: f64,
    /// Compass innovations larger than this are rejected (rad).
    pub heading_gate_rad: f64,
    /// Magnetic declination: true heading = magnetic heading + declination (rad).
    pub declination_rad: f64,
    /// How much past state to keep for delayed fusion (s).
    pub history_s: f64,
}

impl Default for NavConfig {
    fn default() -> Self {
        Self {
            gps_latency_s: 1.0,
            gps_min_satellites: 4,
            gps_pos_gain: 0.4,
            gps_vel_from_pos_gain: 0.08,
            gps_vel_gain: 0.4,
            gps_gate_m: 25.0,
            baro_alt_gain: 0.06,
            baro_vel_gain: 0.015,
            baro_gate_m: 15.0,
            tilt_gain_per_s: 0.05,
            tilt_accel_tolerance: 0.08,
            heading_gain: 0.02,
            heading_gate_rad: 0.8,
            declination_rad: 0.0,
            history_s: 2.5,
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
    /// Time the last GPS fix was fused (µs), 0 if never.
    pub last_gps_fused_us: u64,
}

#[derive(Clone, Copy, Debug)]
struct HistoryEntry {
    t_us: u64,
    pos: Vector3<f64>,
    vel: Vector3<f64>,
}

/// The navigation filter.
#[derive(Clone, Debug)]
pub struct Navigator {
    config: NavConfig,
    state: Option<NavState>,
    biases: Option<ImuBiases>,
    origin: Option<GeoOrigin>,
    last_gps_ned: Option<Vector3<f64>>,
    baro_reference_mbar: Option<f64>,
    baro_reference_z_m: f64,
    baro_sum_mbar: f64,
    baro_count: u32,
    last_field: Option<MagField>,
    heading_from_compass: bool,
    history: VecDeque<HistoryEntry>,
    history_len: usize,
    stats: NavSensorStats,
}

impl Navigator {
    /// A filter waiting for its initialisation.
    pub fn new(config: NavConfig) -> Self {
        let history_len = (config.history_s.max(0.1) * 50.0).ceil() as usize;
        Self {
            config,
            state: None,
            biases: None,
            origin: None,
            last_gps_ned: None,
            baro_reference_mbar: None,
            baro_reference_z_m: 0.0,
            baro_sum_mbar: 0.0,
            baro_count: 0,
            last_field: None,
            heading_from_compass: false,
            history: VecDeque::with_capacity(history_len.saturating_add(1)),
            history_len,
            stats: NavSensorStats::default(),
        }
    }

    /// The estimate, once initialised.
    pub fn state(&self) -> Option<&NavState> {
        self.state.as_ref()
    }

    /// What the aiding sensors contributed.
    pub fn stats(&self) -> NavSensorStats {
        self.stats
    }

    /// Origin of the local frame (the first good GPS fix).
    pub fn origin(&self) -> Option<GeoOrigin> {
        self.origin
    }

    /// The reference pressure of the barometric altitude (mbar).
    pub fn baro_reference_mbar(&self) -> Option<f64> {
        self.baro_reference_mbar
    }

    /// Starts the estimate at `t_us` from the calibration: roll and pitch from the mean
    /// specific force, heading from the compass if one was read, position from the last GPS
    /// fix if any, at rest; the barometric reference is the mean pressure read so far.
    pub fn initialise(&mut self, t_us: u64, biases: &ImuBiases) {
        let f = biases.mean_accel_mps2;
        let roll = (-f.y).atan2(-f.z);
        let pitch = f.x.atan2((f.y * f.y + f.z * f.z).sqrt());
        let compass_heading = self
            .last_field
            .and_then(|field| heading_rad(&field, roll, pitch));
        self.heading_from_compass = compass_heading.is_some();
        let yaw = compass_heading.map_or(0.0, |h| h + self.config.declination_rad);
        let pos = self.last_gps_ned.unwrap_or_else(Vector3::zeros);
        if self.baro_count > 0 {
            self.baro_reference_mbar = Some(self.baro_sum_mbar / f64::from(self.baro_count));
            self.baro_reference_z_m = pos.z;
        }
        self.biases = Some(*biases);
        self.history.clear();
        self.state = Some(NavState {
            t_us,
            att: UnitQuaternion::from_euler_angles(roll, pitch, yaw),
            vel_ned_mps: Vector3::zeros(),
            pos_ned_m: pos,
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: f,
        });
    }

    /// Propagates to the later of two IMU samples, `a` taken before `b` at `t_b_us`, using
    /// their mean (the thesis propagates every other sample with "the two most recent
    /// readings").
    pub fn propagate(&mut self, t_b_us: u64, a: &ImuRepr, b: &ImuRepr) {
        let (Some(state), Some(biases)) = (self.state.as_mut(), self.biases.as_ref()) else {
            return;
        };
        let dt = seconds_between(state.t_us, t_b_us).min(0.1);
        let rate = mean3(a.rate_rps, b.rate_rps) - biases.gyro_rps;
        let accel = mean3(a.accel_mps2, b.accel_mps2);
        if !(rate.iter().all(|x| x.is_finite()) && accel.iter().all(|x| x.is_finite())) {
            return;
        }
        let att0 = state.att;
        let att1 = att0 * UnitQuaternion::from_scaled_axis(rate * dt);
        // Specific force rotated with the mid-interval attitude.
        let att_mid = att0.slerp(&att1, 0.5);
        let accel_ned = att_mid * accel + Vector3::new(0.0, 0.0, GRAVITY_MPS2);
        let vel0 = state.vel_ned_mps;
        state.vel_ned_mps = vel0 + accel_ned * dt;
        state.pos_ned_m += (vel0 + state.vel_ned_mps) * (0.5 * dt);
        state.att = att1;
        state.t_us = t_b_us;
        state.rate_body_rps = rate;
        state.accel_body_mps2 = accel;

        // Tilt toward the accelerometer's up, only near 1 g. The specific force of a
        // helicopter in steady flight points up (NED −z); seen through the estimated
        // attitude it points elsewhere by exactly the tilt error.
        let f_norm = accel.norm();
        if (f_norm - GRAVITY_MPS2).abs() < self.config.tilt_accel_tolerance * GRAVITY_MPS2
            && f_norm > 1e-6
        {
            let up_est = state.att * (accel / f_norm);
            let axis = up_est.cross(&Vector3::new(0.0, 0.0, -1.0));
            let correction = axis * (self.config.tilt_gain_per_s * dt);
            state.att = UnitQuaternion::from_scaled_axis(correction) * state.att;
        }

        self.history.push_back(HistoryEntry {
            t_us: t_b_us,
            pos: state.pos_ned_m,
            vel: state.vel_ned_mps,
        });
        while self.history.len() > self.history_len {
            self.history.pop_front();
        }
    }

    /// Fuses a GPS fix whose last byte arrived at `t_arrival_us`.
    pub fn fuse_gps(&mut self, t_arrival_us: u64, fix: &GpsNav) {
        let usable = matches!(fix.fix, FixType::Fix3D)
            && fix.satellites >= self.config.gps_min_satellites
            && fix.lat_deg.is_finite()
            && fix.lon_deg.is_finite()
            && fix.alt_m.is_finite();
        if !usable {
            self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
            return;
        }
        let origin = *self.origin.get_or_insert(GeoOrigin {
            lat_deg: fix.lat_deg,
            lon_deg: fix.lon_deg,
            alt_m: fix.alt_m,
        });
        let [n, e, d] = origin.to_ned(fix.lat_deg, fix.lon_deg, fix.alt_m);
        let gps_pos = Vector3::new(n, e, d);
        let [vn, ve, vd] = fix.vel_ned_mps;
        let gps_vel = Vector3::new(vn, ve, vd);
        self.last_gps_ned = Some(gps_pos);
        let Some(state) = self.state.as_mut() else {
            return; // before initialisation a fix only sets the origin and the start position
        };
        let t_valid = t_arrival_us.saturating_sub(seconds_to_us(self.config.gps_latency_s));
        let Some(past) = interpolate(&self.history, t_valid) else {
            self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
            return;
        };
        let pos_innov = gps_pos - past.pos;
        let vel_innov = gps_vel - past.vel;
        let horizontal = Vector3::new(pos_innov.x, pos_innov.y, 0.0);
        if horizontal.norm() > self.config.gps_gate_m || !vel_innov.iter().all(|x| x.is_finite()) {
            self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
            return;
        }
        // Altitude comes from the barometer; GPS corrects horizontal position and all of velocity.
        let dp = horizontal * self.config.gps_pos_gain;
        let dv =
            horizontal * self.config.gps_vel_from_pos_gain + vel_innov * self.config.gps_vel_gain;
        let carry = |t_us: u64| dp + dv * seconds_between(t_valid, t_us);
        for entry in self.history.iter_mut().filter(|h| h.t_us >= t_valid) {
            entry.pos += carry(entry.t_us);
            entry.vel += dv;
        }
        state.pos_ned_m += carry(state.t_us);
        state.vel_ned_mps += dv;
        self.stats.gps_fused = self.stats.gps_fused.saturating_add(1);
        self.stats.last_gps_fused_us = t_arrival_us;
    }

    /// Fuses a barometric pressure reading (before initialisation: accumulates the reference).
    pub fn fuse_baro(&mut self, pressure_mbar: f64) {
        if !(pressure_mbar.is_finite() && pressure_mbar > 0.0) {
            self.stats.baro_rejected = self.stats.baro_rejected.saturating_add(1);
            return;
        }
        let Some(state) = self.state.as_mut() else {
            self.baro_sum_mbar += pressure_mbar;
            self.baro_count = self.baro_count.saturating_add(1);
            return;
        };
        // An altimeter that started after the calibration is referenced where it first speaks.
        let reference = *self.baro_reference_mbar.get_or_insert_with(|| {
            self.baro_reference_z_m = state.pos_ned_m.z;
            pressure_mbar
        });
        let z_baro = self.baro_reference_z_m - pressure_altitude_m(pressure_mbar, reference);
        let innov = z_baro - state.pos_ned_m.z;
        if innov.abs() > self.config.baro_gate_m {
            self.stats.baro_rejected = self.stats.baro_rejected.saturating_add(1);
            return;
        }
        state.pos_ned_m.z += self.config.baro_alt_gain * innov;
        state.vel_ned_mps.z += self.config.baro_vel_gain * innov;
        self.stats.baro_fused = self.stats.baro_fused.saturating_add(1);
    }

    /// Fuses a calibrated compass field (before initialisation: remembers it for the heading).
    pub fn fuse_compass(&mut self, field: &MagField) {
        if !field.field_gauss.iter().all(|x| x.is_finite()) {
            self.stats.compass_rejected = self.stats.compass_rejected.saturating_add(1);
            return;
        }
        self.last_field = Some(*field);
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let (roll, pitch, yaw) = state.att.euler_angles();
        let Some(measured) = heading_rad(field, roll, pitch) else {
            self.stats.compass_rejected = self.stats.compass_rejected.saturating_add(1);
            return;
        };
        let innov = wrap_pi(measured + self.config.declination_rad - yaw);
        if !self.heading_from_compass {
            // No compass before initialisation: the heading was a guess; take the first reading.
            self.heading_from_compass = true;
            let correction = Vector3::new(0.0, 0.0, innov);
            state.att = UnitQuaternion::from_scaled_axis(correction) * state.att;
            self.stats.compass_fused = self.stats.compass_fused.saturating_add(1);
            return;
        }
        if innov.abs() > self.config.heading_gate_rad {
            self.stats.compass_rejected = self.stats.compass_rejected.saturating_add(1);
            return;
        }
        let correction = Vector3::new(0.0, 0.0, self.config.heading_gain * innov);
        state.att = UnitQuaternion::from_scaled_axis(correction) * state.att;
        self.stats.compass_fused = self.stats.compass_fused.saturating_add(1);
    }
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

/// State at `t_us` interpolated from the history; `None` if `t_us` is outside it.
fn interpolate(history: &VecDeque<HistoryEntry>, t_us: u64) -> Option<HistoryEntry> {
    let after_idx = history.iter().position(|h| h.t_us >= t_us)?;
    let after = history.get(after_idx)?;
    if after.t_us == t_us {
        return Some(*after);
    }
    let before = history.get(after_idx.checked_sub(1)?)?;
    let span = seconds_between(before.t_us, after.t_us);
    let w = if span > 0.0 {
        seconds_between(before.t_us, t_us) / span
    } else {
        0.0
    };
    Some(HistoryEntry {
        t_us,
        pos: before.pos.lerp(&after.pos, w),
        vel: before.vel.lerp(&after.vel, w),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level_biases() -> ImuBiases {
        ImuBiases {
            gyro_rps: Vector3::new(0.001, -0.002, 0.0005),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
            samples: 8000,
        }
    }

    fn still_imu(b: &ImuBiases) -> ImuRepr {
        ImuRepr {
            rate_rps: b.gyro_rps.into(),
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        }
    }

    /// A filter whose origin is a first fix at rest, initialised at t = 0.
    fn started_at_origin() -> (ImuBiases, GeoOrigin, Navigator) {
        let b = level_biases();
        let mut nav = Navigator::new(NavConfig::default());
        let origin = GeoOrigin {
            lat_deg: 42.0,
            lon_deg: -71.0,
            alt_m: 20.0,
        };
        nav.fuse_gps(0, &fix_at(&origin, [0.0, 0.0, 0.0], [0.0; 3]));
        nav.initialise(0, &b);
        (b, origin, nav)
    }

    fn fix_at(origin: &GeoOrigin, ned: [f64; 3], vel: [f64; 3]) -> GpsNav {
        let (lat, lon, alt) = origin.to_geodetic(ned);
        GpsNav {
            tow_ms: 0,
            lat_deg: lat,
            lon_deg: lon,
            alt_m: alt,
            vel_ned_mps: vel,
            satellites: 8,
            fix: FixType::Fix3D,
        }
    }

    #[test]
    fn sitting_still_with_calibrated_biases_does_not_drift() {
        let b = level_biases();
        let mut nav = Navigator::new(NavConfig::default());
        nav.initialise(0, &b);
        let imu = still_imu(&b);
        for k in 1..=3000u64 {
            nav.propagate(k * 20_000, &imu, &imu);
        }
        let s = nav.state().copied().unwrap_or_else(|| unreachable!());
        assert!(s.pos_ned_m.norm() < 1e-6, "{:?}", s.pos_ned_m);
        assert!(s.att.angle() < 1e-9);
    }

    #[test]
    fn tilt_error_is_pulled_back_by_the_accelerometer() {
        let b = level_biases();
        let mut nav = Navigator::new(NavConfig::default());
        nav.initialise(0, &b);
        if let Some(s) = nav.state.as_mut() {
            s.att = UnitQuaternion::from_euler_angles(0.05, -0.03, 0.0);
        }
        let imu = still_imu(&b);
        for k in 1..=5000u64 {
            nav.propagate(k * 20_000, &imu, &imu);
        }
        let (roll, pitch, _) = nav.state().map(NavState::euler_rad).unwrap_or_default();
        assert!(
            roll.abs() < 0.002 && pitch.abs() < 0.002,
            "roll {roll} pitch {pitch}"
        );
    }

    #[test]
    fn delayed_gps_is_compared_with_the_past_state() {
        // The helicopter moves north at 2 m/s. Its GPS reports, one second late, exactly
        // where it was: a filter that compares with the past sees no innovation; one that
        // compared with the present would be dragged 2 m back.
        let (b, origin, mut nav) = started_at_origin();
        if let Some(s) = nav.state.as_mut() {
            s.vel_ned_mps = Vector3::new(2.0, 0.0, 0.0);
        }
        let imu = still_imu(&b);
        for k in 1..=150u64 {
            nav.propagate(k * 20_000, &imu, &imu);
        }
        // Now t = 3 s, true north = 6 m; the fix arriving now is valid at t = 2 s (north 4 m).
        nav.fuse_gps(
            3_000_000,
            &fix_at(&origin, [4.0, 0.0, 0.0], [2.0, 0.0, 0.0]),
        );
        let s = nav.state().copied().unwrap_or_else(|| unreachable!());
        assert!((s.pos_ned_m.x - 6.0).abs() < 1e-6, "{:?}", s.pos_ned_m);
        assert_eq!(nav.stats().gps_fused, 1);
    }

    #[test]
    fn a_lying_gps_is_rejected_and_counted() {
        let (b, origin, mut nav) = started_at_origin();
        let imu = still_imu(&b);
        for k in 1..=100u64 {
            nav.propagate(k * 20_000, &imu, &imu);
        }
        nav.fuse_gps(2_000_000, &fix_at(&origin, [500.0, 0.0, 0.0], [0.0; 3]));
        assert_eq!(nav.stats().gps_rejected, 1);
        assert!(nav.state().map(|s| s.pos_ned_m.norm()).unwrap_or(1.0) < 1e-6);
    }

    #[test]
    fn baro_pulls_altitude_toward_the_pressure_altitude() {
        let b = level_biases();
        let mut nav = Navigator::new(NavConfig::default());
        for _ in 0..10 {
            nav.fuse_baro(1013.25);
        }
        nav.initialise(0, &b);
        let target = heli_proto::baro::pressure_at_altitude_mbar(3.0, 1013.25);
        let imu = still_imu(&b);
        for k in 1..=3000u64 {
            nav.propagate(k * 20_000, &imu, &imu);
            if k % 10 == 0 {
                nav.fuse_baro(target);
            }
        }
        let z = nav.state().map(|s| s.pos_ned_m.z).unwrap_or(0.0);
        assert!((z + 3.0).abs() < 0.05, "z {z}");
    }

    #[test]
    fn wrap_pi_wraps() {
        assert!((wrap_pi(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap_pi(-0.5) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn an_altimeter_that_starts_late_is_referenced_where_it_first_speaks() {
        let (b, _, mut nav) = started_at_origin();
        let imu = still_imu(&b);
        let p0 = 1000.0;
        for k in 1..=3000u64 {
            nav.propagate(k * 20_000, &imu, &imu);
            if k % 10 == 0 {
                // First reading at the ground, then the helicopter "climbs" 4 m.
                let alt = if k > 100 { 4.0 } else { 0.0 };
                nav.fuse_baro(heli_proto::baro::pressure_at_altitude_mbar(alt, p0));
            }
        }
        assert_eq!(nav.baro_reference_mbar(), Some(p0));
        let z = nav.state().map_or(0.0, |s| s.pos_ned_m.z);
        assert!((z + 4.0).abs() < 0.05, "z {z}");
        assert_eq!(nav.stats().baro_rejected, 0);
    }

    #[test]
    fn without_a_compass_at_start_the_first_reading_sets_the_heading() {
        let (_, _, mut nav) = started_at_origin();
        // Heading east, far outside the innovation gate from the guessed north.
        let east = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let b = east.inverse() * Vector3::new(0.19, 0.0, 0.48);
        nav.fuse_compass(&MagField {
            field_gauss: [b.x, b.y, b.z],
        });
        let (_, _, yaw) = nav.state().map(NavState::euler_rad).unwrap_or_default();
        assert!(
            (yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "yaw {yaw}"
        );
        assert_eq!(nav.stats().compass_rejected, 0);
    }
}
