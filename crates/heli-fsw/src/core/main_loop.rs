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
        } else if !repeated && let Some(biases) = self.calibration.push(now_us, &sample) {
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
}
