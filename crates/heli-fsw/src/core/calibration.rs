//! The 80 s ground calibration of the IMU biases (thesis §2.3.2), with what starts it
//! again: motion the IMU sees in its window (`heli_nav::calibration`), or a turn of the
//! fuselage the compass sees (a slow creep the IMU's one-second check cannot see).
//!
//! A component: it owns the bias calibration and the compass's heading watch; the core hands
//! it the real IMU samples and the compass's headings, and it returns the biases when the
//! window closes and the events it raises.

use heli_nav::calibration::Motion;
use heli_nav::navigator::wrap_pi;
use heli_nav::{BiasCalibration, CalibrationPhase, ImuBiases};
use heli_proto::imu::ImuRepr;

use super::event::CoreEvent;

/// A turn of the fuselage during the calibration window that starts it again (rad): 5 deg,
/// which over the 80 s window would put 0.06 deg/s into the yaw bias.
pub const CALIBRATION_TURN_RAD: f64 = 0.087;

/// The ground calibration.
#[derive(Clone, Debug)]
pub struct GroundCalibration {
    bias: BiasCalibration,
    /// During the calibration window: the compass heading when it opened, and the readings'
    /// running average (rad).
    pub(super) heading: Option<(f64, f64)>,
}

impl GroundCalibration {
    /// A calibration of `window_s` after `warm_up_s` of warm-up.
    pub fn new(warm_up_s: f64, window_s: f64) -> Self {
        Self {
            bias: BiasCalibration::new(warm_up_s, window_s),
            heading: None,
        }
    }

    /// One real IMU sample: the biases when the window closes, and the restart the IMU's
    /// check saw, if any.
    pub fn push(
        &mut self,
        now_us: u64,
        sample: &ImuRepr,
    ) -> (Option<ImuBiases>, Option<CoreEvent>) {
        let biases = self.bias.push(now_us, sample);
        let restarted = self.bias.take_motion().map(|motion| {
            self.heading = None;
            CoreEvent::CalibrationRestarted(motion)
        });
        (biases, restarted)
    }

    /// A compass heading: a fuselage that turned more than [`CALIBRATION_TURN_RAD`] during
    /// the window starts it again, and says so.
    pub fn heading(&mut self, now_us: u64, heading_rad: f64) -> Option<CoreEvent> {
        if !matches!(self.bias.phase(), CalibrationPhase::Accumulating { .. })
            || !heading_rad.is_finite()
        {
            self.heading = None;
            return None;
        }
        let (reference, smoothed) = match self.heading {
            None => (heading_rad, heading_rad),
            Some((reference, smoothed)) => {
                // A second's average of the readings (20 Hz): the noise of one is ~0.5 deg.
                let step = wrap_pi(heading_rad - smoothed);
                (reference, wrap_pi(smoothed + step / 20.0))
            }
        };
        let turned = wrap_pi(smoothed - reference).abs();
        if turned > CALIBRATION_TURN_RAD {
            let motion = Motion {
                rate_rps: 0.0,
                tilt_rad: 0.0,
                turn_rad: turned,
            };
            self.bias.restart(now_us, motion);
            self.bias.take_motion();
            self.heading = None;
            return Some(CoreEvent::CalibrationRestarted(motion));
        }
        self.heading = Some((reference, smoothed));
        None
    }

    /// Where the calibration is.
    pub fn phase(&self) -> CalibrationPhase {
        self.bias.phase()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level() -> ImuRepr {
        ImuRepr {
            rate_rps: [0.001, -0.002, 0.0005],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        }
    }

    /// The calibration fed `seconds` of level samples at 100 Hz from `from_s`; what it gave.
    fn feed(
        c: &mut GroundCalibration,
        from_s: f64,
        seconds: f64,
    ) -> (Option<ImuBiases>, Vec<CoreEvent>) {
        let mut events = Vec::new();
        let mut done = None;
        let n = (seconds * 100.0).round() as u64;
        let start = (from_s * 1e6) as u64;
        for k in 0..n {
            let (biases, event) = c.push(start + k * 10_000, &level());
            events.extend(event);
            done = done.or(biases);
        }
        (done, events)
    }

    #[test]
    fn the_window_closes_with_the_biases_after_warm_up_and_window() {
        let mut c = GroundCalibration::new(1.0, 2.0);
        let (biases, events) = feed(&mut c, 0.0, 3.2);
        let b = biases.expect("the window closed");
        assert!((b.gyro_rps.x - 0.001).abs() < 1e-9);
        assert!(events.is_empty());
    }

    #[test]
    fn a_turn_the_compass_sees_in_the_window_starts_it_again_and_says_so() {
        let mut c = GroundCalibration::new(0.0, 10.0);
        feed(&mut c, 0.0, 1.0);
        assert!(matches!(c.phase(), CalibrationPhase::Accumulating { .. }));
        assert_eq!(c.heading(1_000_000, 0.5), None);
        assert_eq!(c.heading, Some((0.5, 0.5)));
        // A steady heading 0.2 rad away: the running average reaches the turn limit.
        let mut raised = Vec::new();
        for k in 0..100u64 {
            raised.extend(c.heading(1_050_000 + k * 50_000, 0.7));
        }
        assert_eq!(raised.len(), 1, "{raised:?}");
        let CoreEvent::CalibrationRestarted(m) = raised[0] else {
            panic!("{raised:?}")
        };
        assert!(m.turn_rad > CALIBRATION_TURN_RAD && m.rate_rps == 0.0);
        // The window started again, and so did the watch, from where the fuselage stands.
        assert_eq!(c.heading.map(|(reference, _)| reference), Some(0.7));
    }

    #[test]
    fn headings_outside_the_window_or_not_numbers_are_not_watched() {
        let mut c = GroundCalibration::new(5.0, 10.0);
        assert_eq!(c.heading(0, 0.5), None, "still warming up");
        assert_eq!(c.heading, None);
        feed(&mut c, 0.0, 6.0);
        c.heading(6_000_000, 0.5);
        assert!(c.heading.is_some());
        assert_eq!(c.heading(6_050_000, f64::NAN), None);
        assert_eq!(
            c.heading, None,
            "a heading that is no number forgets the watch"
        );
    }
}
