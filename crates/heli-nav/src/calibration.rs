//! The thesis's IMU bias calibration: after the IMU has warmed up, every sample of an
//! eighty-second window is accumulated; when the window closes the mean gyro rates are the
//! gyro biases, and the mean specific force tells which way is down.
//!
//! The window must be still: a fuselage that turns on its skids or rocks in the wind while
//! the rotor spins up would be averaged in as bias, and the whole flight flown with it. Each
//! second of samples is compared with the mean so far; a second whose mean rate or
//! direction of gravity differs by more than [`MOTION_RATE_RPS`] or [`MOTION_TILT_RAD`] is
//! motion, and the window starts again ([`BiasCalibration::take_motion`] says so). A caller
//! that sees motion by other means (the compass turning) restarts it with
//! [`BiasCalibration::restart`].

use heli_proto::imu::ImuRepr;
use nalgebra::Vector3;

/// Biases found by the calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuBiases {
    /// Gyro bias (rad/s), subtracted from every rate sample.
    pub gyro_rps: Vector3<f64>,
    /// Mean specific force over the window (m/s²), body axes: the helicopter sat still, so
    /// this is the reaction to gravity and gives the initial roll and pitch.
    pub mean_accel_mps2: Vector3<f64>,
    /// Number of samples averaged.
    pub samples: u32,
}

/// Where the calibration is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalibrationPhase {
    /// Waiting for the first IMU sample.
    Waiting,
    /// The IMU is warming up until this time (µs).
    WarmingUp {
        /// End of warm-up (µs).
        until_us: u64,
    },
    /// Accumulating samples until this time (µs).
    Accumulating {
        /// End of the window (µs).
        until_us: u64,
    },
    /// Finished.
    Done(ImuBiases),
}

/// A second's mean rate that differs this much from the window's mean is motion (rad/s):
/// 3 deg/s — handling, a push, a turn on the skids; far above what the IMU's noise and the
/// rotor's vibration leave in a second's mean, and above a gust's rocking, which averages
/// out.
pub const MOTION_RATE_RPS: f64 = 0.05;

/// A second's mean direction of gravity that differs this much from the window's is motion
/// (rad): 2 deg of tilt.
pub const MOTION_TILT_RAD: f64 = 0.035;

/// Samples in one block of the motion check (a second at 100 Hz).
const BLOCK: u32 = 100;

/// Motion seen during the calibration window: it was started again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// How far a second's mean rate was from the window's (rad/s).
    pub rate_rps: f64,
    /// How far a second's direction of gravity was from the window's (rad).
    pub tilt_rad: f64,
    /// How far the heading turned, as the compass saw it (rad; 0 when the IMU saw it).
    pub turn_rad: f64,
}

/// The whole seconds of the window so far, which each new second is compared with.
#[derive(Clone, Copy, Debug, Default)]
struct Reference {
    /// Sum of the seconds' mean rates (rad/s).
    gyro_sum: Vector3<f64>,
    /// Sum of the seconds' specific forces (its direction is the mean direction of gravity).
    accel_sum: Vector3<f64>,
    seconds: u32,
}

impl Reference {
    fn add(&mut self, gyro: &Vector3<f64>, accel: &Vector3<f64>) {
        self.gyro_sum += gyro;
        self.accel_sum += accel;
        self.seconds = self.seconds.saturating_add(1);
    }

    /// The motion of a second of mean rate `gyro` and specific force along `accel`, if it
    /// moved.
    fn motion(&self, gyro: &Vector3<f64>, accel: &Vector3<f64>) -> Option<Motion> {
        let rate_rps = (gyro - self.gyro_sum / f64::from(self.seconds)).norm();
        let tilt_rad = accel.angle(&self.accel_sum);
        (beyond(rate_rps, MOTION_RATE_RPS) || beyond(tilt_rad, MOTION_TILT_RAD)).then_some(Motion {
            rate_rps,
            tilt_rad,
            turn_rad: 0.0,
        })
    }
}

/// Whether a second moved by `value` is beyond the motion limit `limit`: a second exactly at
/// the limit is still.
fn beyond(value: f64, limit: f64) -> bool {
    value > limit
}

/// Accumulates IMU samples into bias estimates.
#[derive(Clone, Debug)]
pub struct BiasCalibration {
    warm_up_us: u64,
    window_us: u64,
    phase: CalibrationPhase,
    gyro_sum: Vector3<f64>,
    accel_sum: Vector3<f64>,
    count: u32,
    block_gyro: Vector3<f64>,
    block_accel: Vector3<f64>,
    block_count: u32,
    reference: Option<Reference>,
    motion: Option<Motion>,
    restarts: u32,
}

impl BiasCalibration {
    /// The thesis's window is 80 s; the warm-up is the IMU's (a few seconds).
    pub fn new(warm_up_s: f64, window_s: f64) -> Self {
        Self {
            warm_up_us: seconds_to_us(warm_up_s),
            window_us: seconds_to_us(window_s),
            phase: CalibrationPhase::Waiting,
            gyro_sum: Vector3::zeros(),
            accel_sum: Vector3::zeros(),
            count: 0,
            block_gyro: Vector3::zeros(),
            block_accel: Vector3::zeros(),
            block_count: 0,
            reference: None,
            motion: None,
            restarts: 0,
        }
    }

    /// Motion that restarted the window since the last call (once).
    pub fn take_motion(&mut self) -> Option<Motion> {
        self.motion.take()
    }

    /// Times the window was started again.
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Starts the window again at `t_us`, throwing away what it had (motion seen by other
    /// means). Nothing happens before the window has opened or after it has closed.
    pub fn restart(&mut self, t_us: u64, motion: Motion) {
        if let CalibrationPhase::Accumulating { .. } = self.phase {
            self.phase = CalibrationPhase::Accumulating {
                until_us: t_us.saturating_add(self.window_us),
            };
            self.gyro_sum = Vector3::zeros();
            self.accel_sum = Vector3::zeros();
            self.count = 0;
            self.block_gyro = Vector3::zeros();
            self.block_accel = Vector3::zeros();
            self.block_count = 0;
            self.reference = None;
            self.motion = Some(motion);
            self.restarts = self.restarts.saturating_add(1);
        }
    }

    /// Current phase.
    pub fn phase(&self) -> CalibrationPhase {
        self.phase
    }

    /// The biases, once the window has closed.
    pub fn biases(&self) -> Option<ImuBiases> {
        match self.phase {
            CalibrationPhase::Done(b) => Some(b),
            _ => None,
        }
    }

    /// Feeds one IMU sample taken at `t_us`. Returns the biases on the sample that closes
    /// the window (once), `None` otherwise.
    pub fn push(&mut self, t_us: u64, imu: &ImuRepr) -> Option<ImuBiases> {
        match self.phase {
            CalibrationPhase::Waiting => {
                self.phase = CalibrationPhase::WarmingUp {
                    until_us: t_us.saturating_add(self.warm_up_us),
                };
                None
            }
            CalibrationPhase::WarmingUp { until_us } => {
                if t_us >= until_us {
                    self.phase = CalibrationPhase::Accumulating {
                        until_us: t_us.saturating_add(self.window_us),
                    };
                    self.accumulate(imu);
                }
                None
            }
            CalibrationPhase::Accumulating { until_us } => {
                if t_us < until_us {
                    if let Some(motion) = self.block(imu) {
                        self.restart(t_us, motion);
                        return None;
                    }
                    self.accumulate(imu);
                    return None;
                }
                let n = f64::from(self.count.max(1));
                let biases = ImuBiases {
                    gyro_rps: self.gyro_sum / n,
                    mean_accel_mps2: self.accel_sum / n,
                    samples: self.count,
                };
                self.phase = CalibrationPhase::Done(biases);
                Some(biases)
            }
            CalibrationPhase::Done(_) => None,
        }
    }

    /// Adds a sample to the current second's block; at the block's end, compares its mean
    /// with the mean of the window's whole seconds before it (the first second is only the
    /// reference of the ones after it). Returns the motion if the block moved.
    fn block(&mut self, imu: &ImuRepr) -> Option<Motion> {
        self.block_gyro += Vector3::from(imu.rate_rps);
        self.block_accel += Vector3::from(imu.accel_mps2);
        self.block_count = self.block_count.saturating_add(1);
        if self.block_count < BLOCK {
            return None;
        }
        let gyro = self.block_gyro / f64::from(self.block_count);
        // Only the direction of gravity is compared: the sum points where the mean does.
        let accel = self.block_accel;
        self.block_gyro = Vector3::zeros();
        self.block_accel = Vector3::zeros();
        self.block_count = 0;
        let motion = self
            .reference
            .as_ref()
            .and_then(|r| r.motion(&gyro, &accel));
        self.reference
            .get_or_insert_with(Reference::default)
            .add(&gyro, &accel);
        motion
    }

    fn accumulate(&mut self, imu: &ImuRepr) {
        let [p, q, r] = imu.rate_rps;
        let [x, y, z] = imu.accel_mps2;
        self.gyro_sum += Vector3::new(p, q, r);
        self.accel_sum += Vector3::new(x, y, z);
        self.count = self.count.saturating_add(1);
    }
}

/// Seconds to whole microseconds, saturating (negative and NaN give 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub fn seconds_to_us(s: f64) -> u64 {
    (s * 1e6).round() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(bias: f64) -> ImuRepr {
        ImuRepr {
            rate_rps: [bias, -bias, 2.0 * bias],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        }
    }

    #[test]
    fn eighty_second_window_after_warm_up_yields_mean_gyro() {
        let mut cal = BiasCalibration::new(5.0, 80.0);
        let mut done = None;
        let mut t = 0u64;
        // Samples during warm-up carry a different (transient) bias that must be ignored.
        while t < 5_000_000 {
            assert!(cal.push(t, &sample(0.5)).is_none());
            t += 10_000;
        }
        while done.is_none() {
            done = cal.push(t, &sample(0.01));
            t += 10_000;
            assert!(t < 100_000_000, "calibration never finished");
        }
        let b = done.unwrap_or_else(|| unreachable!());
        assert!((b.gyro_rps.x - 0.01).abs() < 1e-9);
        assert!((b.gyro_rps.z - 0.02).abs() < 1e-9);
        assert!((b.mean_accel_mps2.z + 9.81).abs() < 1e-9);
        assert_eq!(b.samples, 8000);
        // It closes 85 s after the first sample (5 s warm-up + 80 s).
        assert_eq!(t - 10_000, 85_000_000);
        assert!(
            cal.push(t, &sample(0.01)).is_none(),
            "biases are delivered once"
        );
    }

    #[test]
    fn a_fuselage_turning_on_its_skids_restarts_the_window() {
        let mut cal = BiasCalibration::new(1.0, 20.0);
        let mut t = 0u64;
        let mut push = |cal: &mut BiasCalibration, rate_z: f64, tilt: f64| {
            let s = ImuRepr {
                rate_rps: [0.01, -0.01, 0.02 + rate_z],
                accel_mps2: [9.81 * tilt.sin(), 0.0, -9.81 * tilt.cos()],
                temp_c: 25.0,
            };
            t += 10_000;
            cal.push(t, &s)
        };
        // Still for ten seconds, a gust's rocking that averages out, then turning at
        // 5 deg/s for two.
        for k in 0..1100 {
            let rock = if k > 500 && k < 700 {
                0.2 * (f64::from(k) * 0.6).sin()
            } else {
                0.0
            };
            assert!(push(&mut cal, rock, 0.0).is_none());
        }
        assert_eq!(cal.take_motion(), None);
        for _ in 0..200 {
            assert!(push(&mut cal, 0.09, 0.0).is_none());
        }
        let motion = cal.take_motion().unwrap_or_else(|| panic!("motion seen"));
        assert!(motion.rate_rps > 0.06, "{motion:?}");
        assert_eq!(cal.take_motion(), None, "said once");
        // Still again: a whole new window of 20 s before the biases, and they are the
        // still ones.
        let mut done = None;
        let mut seconds = 0.0;
        while done.is_none() {
            done = push(&mut cal, 0.0, 0.0);
            seconds += 0.01;
            assert!(seconds < 30.0, "never finished");
        }
        let b = done.unwrap_or_else(|| unreachable!());
        // What was left of the turn in the new window's first second is a twentieth of
        // its rate (the rest is the compass's to catch, as net turn).
        assert!((b.gyro_rps.z - 0.02).abs() < 0.005, "{b:?}");
        assert!(seconds >= 19.0, "the window started again ({seconds} s)");
        // Tilted 4 deg: also motion.
        let mut cal = BiasCalibration::new(1.0, 20.0);
        for _ in 0..500 {
            push(&mut cal, 0.0, 0.0);
        }
        for _ in 0..200 {
            push(&mut cal, 0.0, 0.07);
        }
        let m = cal.take_motion();
        assert!(m.is_some_and(|m| m.tilt_rad > 0.05), "{m:?}");
        assert_eq!(cal.restarts(), 1);
    }
    /// A calibration whose window opened with one still sample at 1 s (no warm-up beyond
    /// the first sample's second), and the time of the next sample.
    fn opened() -> (BiasCalibration, u64) {
        let mut cal = BiasCalibration::new(1.0, 60.0);
        assert!(cal.push(0, &sample(0.0)).is_none());
        assert!(cal.push(1_000_000, &sample(0.0)).is_none());
        assert!(matches!(cal.phase(), CalibrationPhase::Accumulating { .. }));
        (cal, 1_010_000)
    }

    #[test]
    fn motion_is_judged_on_whole_seconds_after_the_first() {
        // The first second after the window opens is the reference; a turn over the whole
        // second second is found on its last sample and not before.
        let (mut cal, mut t) = opened();
        for k in 1..=200u32 {
            let turning = if k > 100 { 0.2 } else { 0.0 };
            let s = ImuRepr {
                rate_rps: [0.0, 0.0, turning],
                ..sample(0.0)
            };
            cal.push(t, &s);
            t += 10_000;
            let motion = cal.take_motion();
            assert_eq!(motion.is_some(), k == 200, "sample {k}: {motion:?}");
        }
        assert_eq!(cal.restarts(), 1);
        // A one-sample jolt of 3 rad/s in a still second averages out (0.03 rad/s).
        let (mut cal, mut t) = opened();
        for k in 1..=300u32 {
            let rate = if k == 150 { 3.0 } else { 0.0 };
            let s = ImuRepr {
                rate_rps: [rate, 0.0, 0.0],
                ..sample(0.0)
            };
            cal.push(t, &s);
            t += 10_000;
        }
        assert_eq!(cal.take_motion(), None);
    }

    #[test]
    fn a_second_exactly_at_the_rate_limit_is_still_and_one_beyond_it_is_motion() {
        // Five samples of 1 rad/s in a second of 100: a mean of exactly 0.05 rad/s.
        let second = |cal: &mut BiasCalibration, t: &mut u64, fast: f64| {
            for k in 0..100 {
                let rate = if k < 5 { fast } else { 0.0 };
                let s = ImuRepr {
                    rate_rps: [0.0, rate, 0.0],
                    ..sample(0.0)
                };
                cal.push(*t, &s);
                *t += 10_000;
            }
        };
        let (mut cal, mut t) = opened();
        second(&mut cal, &mut t, 0.0);
        second(&mut cal, &mut t, 1.0);
        assert_eq!(cal.take_motion(), None, "at the limit");
        let (mut cal, mut t) = opened();
        second(&mut cal, &mut t, 0.0);
        second(&mut cal, &mut t, 1.001);
        let m = cal.take_motion();
        assert!(
            m.is_some_and(|m| (m.rate_rps - 0.05005).abs() < 1e-12),
            "{m:?}"
        );
    }
}
