//! The thesis's IMU bias calibration: after the IMU has warmed up, every sample of an
//! eighty-second window is accumulated; when the window closes the mean gyro rates are the
//! gyro biases, and the mean specific force tells which way is down.

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

/// Accumulates IMU samples into bias estimates.
#[derive(Clone, Debug)]
pub struct BiasCalibration {
    warm_up_us: u64,
    window_us: u64,
    phase: CalibrationPhase,
    gyro_sum: Vector3<f64>,
    accel_sum: Vector3<f64>,
    count: u32,
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

    fn accumulate(&mut self, imu: &ImuRepr) {
        let [p, q, r] = imu.rate_rps;
        let [x, y, z] = imu.accel_mps2;
        self.gyro_sum += Vector3::new(p, q, r);
        self.accel_sum += Vector3::new(x, y, z);
        self.count = self.count.saturating_add(1);
    }
}

/// Seconds to whole microseconds, saturating (negative and NaN give 0).
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
}
