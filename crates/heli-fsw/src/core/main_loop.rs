//! The loop: every IMU sample (or the watchdog's copy of the last one) is one iteration;
//! the calibration runs on real samples; every second iteration is a control step.

use super::*;

impl FlightCore {
    /// One iteration of the main loop on an IMU sample (real, or repeated by the watchdog).
    pub(super) fn loop_iteration(
        &mut self,
        sample: ImuRepr,
        repeated: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        out.push(Action::Publish(Record::Imu(Stamped::new(
            now_us,
            ImuRecord {
                imu: sample,
                repeated,
            },
        ))));
        if !repeated && self.alignment.is_some() {
            self.align(now_us, &sample, out);
        } else if !repeated
            && self.nav.state().is_none()
            && let Some(biases) = self.calibrate(now_us, &sample, out)
        {
            self.nav.initialise(now_us, &biases);
            self.home_ned_m = self.nav.state().map(|s| s.pos_ned_m);
            let b = biases.gyro_rps;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::CalibrationDone {
                    gyro_bias_rps: [b.x, b.y, b.z],
                },
            )));
        }
        let previous = self.last_imu.replace(sample);
        self.odd_sample = !self.odd_sample;
        if self.odd_sample {
            return;
        }
        self.control_step(previous.unwrap_or(sample), sample, now_us, out);
    }

    /// One sample of the ground calibration; motion in its window (seen by the IMU here, or
    /// by the compass) starts it again, and says so.
    fn calibrate(
        &mut self,
        now_us: u64,
        sample: &ImuRepr,
        out: &mut Vec<Action>,
    ) -> Option<heli_nav::ImuBiases> {
        let biases = self.calibration.push(now_us, sample);
        if let Some(motion) = self.calibration.take_motion() {
            self.calibration_heading = None;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::CalibrationRestarted(motion),
            )));
        }
        biases
    }

    /// A compass heading during the calibration window: a fuselage that turned more than
    /// [`CALIBRATION_TURN_RAD`] (a slow creep the IMU's one-second check cannot see) starts
    /// the window again.
    pub(super) fn watch_calibration_heading(
        &mut self,
        now_us: u64,
        heading_rad: f64,
        out: &mut Vec<Action>,
    ) {
        if !matches!(
            self.calibration.phase(),
            heli_nav::CalibrationPhase::Accumulating { .. }
        ) || !heading_rad.is_finite()
        {
            self.calibration_heading = None;
            return;
        }
        let (reference, smoothed) = match self.calibration_heading {
            None => (heading_rad, heading_rad),
            Some((reference, smoothed)) => {
                // A second's average of the readings (20 Hz): the noise of one is ~0.5 deg.
                let step = heli_nav::navigator::wrap_pi(heading_rad - smoothed);
                (
                    reference,
                    heli_nav::navigator::wrap_pi(smoothed + step / 20.0),
                )
            }
        };
        let turned = heli_nav::navigator::wrap_pi(smoothed - reference).abs();
        if turned > CALIBRATION_TURN_RAD {
            let motion = heli_nav::calibration::Motion {
                rate_rps: 0.0,
                tilt_rad: 0.0,
                turn_rad: turned,
            };
            self.calibration.restart(now_us, motion);
            self.calibration.take_motion();
            self.calibration_heading = None;
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::CalibrationRestarted(motion),
            )));
            return;
        }
        self.calibration_heading = Some((reference, smoothed));
    }
}

/// A turn of the fuselage during the calibration window that starts it again (rad): 5 deg,
/// which over the 80 s window would put 0.06 deg/s into the yaw bias.
pub const CALIBRATION_TURN_RAD: f64 = 0.087;
