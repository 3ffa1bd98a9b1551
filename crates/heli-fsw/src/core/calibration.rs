//! The 80 s ground calibration of the IMU biases (thesis §2.3.2), with what it tells the
//! operator: seconds the helicopter moved (left out of the average, seen by the gyros and
//! accelerometers in `heli_nav::calibration`), restarts, a calibration held up by a
//! helicopter that keeps moving (why, and what to do), and a compass heading that moved
//! while the gyros saw no turn (a notice: the compass never starts the window again).
//!
//! A component: it owns the bias calibration and the compass's heading watch; the core hands
//! it the real IMU samples and the compass's headings, and it returns the biases when the
//! window closes and raises its events.

use heli_nav::navigator::wrap_pi;
use heli_nav::{BiasCalibration, CalibrationPhase, ImuBiases};
use heli_proto::imu::ImuRepr;

use super::event::CoreEvent;

/// A compass heading that moved this far from where it stood when the gyros last saw the
/// helicopter still (rad) is said once a window: 5 deg.
pub const CALIBRATION_TURN_RAD: f64 = 0.087;

/// Restarts of the window, counted from the first, at every multiple of which the
/// calibration is said to be held up.
pub const HELD_UP_RESTARTS: u32 = 3;

/// Seconds left out of one window at every multiple of which the calibration is said to be
/// held up.
pub const HELD_UP_LEFT_OUT_S: u32 = 20;

/// The ground calibration.
#[derive(Clone, Debug)]
pub struct GroundCalibration {
    bias: BiasCalibration,
    /// During the calibration window: the compass heading since the gyros last saw the
    /// helicopter move, and the readings' running average (rad).
    pub(super) heading: Option<(f64, f64)>,
    /// The compass's notice was given in this window.
    compass_said: bool,
    /// A compass move waiting for the gyros' judgement: how far it moved (rad) and the
    /// seconds judged when it did. Said once two more seconds are judged with none left out.
    compass_pending: Option<(f64, usize)>,
    /// The seconds left out when the calibration was last said to be held up by them.
    said_left_out: u32,
    /// The seconds left out of this window the compass's watch has seen.
    left_out_seen: u32,
}

impl GroundCalibration {
    /// A calibration of `window_s` after `warm_up_s` of warm-up.
    pub fn new(warm_up_s: f64, window_s: f64) -> Self {
        Self {
            bias: BiasCalibration::new(warm_up_s, window_s),
            heading: None,
            compass_said: false,
            compass_pending: None,
            said_left_out: 0,
            left_out_seen: 0,
        }
    }

    /// One real IMU sample: the biases when the window closes; what the calibration saw is
    /// handed to `raise`.
    pub fn push(
        &mut self,
        sample: &ImuRepr,
        raise: &mut dyn FnMut(CoreEvent),
    ) -> Option<ImuBiases> {
        let biases = self.bias.push(sample);
        if let Some(motion) = self.bias.take_motion() {
            self.heading = None;
            self.compass_pending = None;
            self.compass_said = false;
            self.said_left_out = 0;
            raise(CoreEvent::CalibrationRestarted(motion));
            let restarts = self.bias.restarts();
            if restarts.is_multiple_of(HELD_UP_RESTARTS) {
                raise(CoreEvent::CalibrationHeldUp {
                    restarts,
                    left_out_s: 0,
                });
            }
        }
        if let Some(left) = self.bias.take_left_out() {
            raise(CoreEvent::CalibrationLeftOut(left));
        }
        let left_out_s = self.bias.left_out_s();
        if left_out_s != self.left_out_seen {
            // The gyros saw it move (every second of a run): the compass's watch starts from
            // where it stands once it is still.
            self.left_out_seen = left_out_s;
            self.heading = None;
            self.compass_pending = None;
        }
        if let Some((moved_rad, judged)) = self.compass_pending
            && self.bias.seconds_judged() >= judged.saturating_add(2)
        {
            self.compass_pending = None;
            self.compass_said = true;
            raise(CoreEvent::CalibrationCompassMoved { moved_rad });
        }
        if self.bias_left_out_crossed(left_out_s) {
            raise(CoreEvent::CalibrationHeldUp {
                restarts: self.bias.restarts(),
                left_out_s,
            });
        }
        biases
    }

    /// Whether the seconds left out of this window just reached another multiple of
    /// [`HELD_UP_LEFT_OUT_S`] (they grow by one or two at a time: crossing it counts).
    fn bias_left_out_crossed(&mut self, left_out_s: u32) -> bool {
        let multiples = |s: u32| s.checked_div(HELD_UP_LEFT_OUT_S).unwrap_or(0);
        let crossed = multiples(left_out_s) > multiples(self.said_left_out);
        if crossed {
            self.said_left_out = left_out_s;
        }
        crossed
    }

    /// A compass heading: one that moved more than [`CALIBRATION_TURN_RAD`] while the gyros
    /// saw the helicopter still — the second it moved in and the one after judged, none left
    /// out — is said once a window by [`Self::push`] ([`CoreEvent::CalibrationCompassMoved`]):
    /// a magnetic disturbance, or a creep too slow for the gyros. It never restarts the
    /// window: only the gyros and accelerometers judge motion.
    pub fn heading(&mut self, heading_rad: f64) {
        if !matches!(self.bias.phase(), CalibrationPhase::Accumulating { .. })
            || !heading_rad.is_finite()
        {
            self.heading = None;
            return;
        }
        let (reference, smoothed) = match self.heading {
            None => (heading_rad, heading_rad),
            Some((reference, smoothed)) => {
                // A second's average of the readings (20 Hz): the noise of one is ~0.5 deg.
                let step = wrap_pi(heading_rad - smoothed);
                (reference, wrap_pi(smoothed + step / 20.0))
            }
        };
        self.heading = Some((reference, smoothed));
        let moved_rad = wrap_pi(smoothed - reference).abs();
        if moved_rad > CALIBRATION_TURN_RAD && !self.compass_said && self.compass_pending.is_none()
        {
            self.compass_pending = Some((moved_rad, self.bias.seconds_judged()));
        }
    }

    /// Where the calibration is.
    pub fn phase(&self) -> CalibrationPhase {
        self.bias.phase()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_nav::calibration::LeftOut;

    fn level() -> ImuRepr {
        ImuRepr {
            rate_rps: [0.001, -0.002, 0.0005],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        }
    }

    /// The calibration fed `seconds` of samples made by `f` (of the time, s) at 100 Hz from
    /// `from_s`; what it gave.
    fn feed(
        c: &mut GroundCalibration,
        from_s: f64,
        seconds: f64,
        f: impl Fn(f64) -> ImuRepr,
    ) -> (Option<ImuBiases>, Vec<CoreEvent>) {
        let mut events = Vec::new();
        let mut done = None;
        let n = (seconds * 100.0).round() as u64;
        let start = (from_s * 1e6) as u64;
        for k in 0..n {
            let t_us = start + k * 10_000;
            let biases = c.push(&f(t_us as f64 * 1e-6), &mut |e| events.push(e));
            done = done.or(biases);
        }
        (done, events)
    }

    #[test]
    fn the_window_closes_with_the_biases_after_warm_up_and_window() {
        let mut c = GroundCalibration::new(1.0, 2.0);
        let (biases, events) = feed(&mut c, 0.0, 3.2, |_| level());
        let b = biases.expect("the window closed");
        assert!((b.gyro_rps.x - 0.001).abs() < 1e-9);
        assert!(events.is_empty());
    }

    #[test]
    fn a_turn_seen_by_the_gyros_is_left_out_and_restarts_the_compass_watch() {
        let mut c = GroundCalibration::new(0.0, 30.0);
        feed(&mut c, 0.0, 5.0, |_| level());
        c.heading(0.5);
        // The compass turns with the gyros: 10 deg/s for two seconds.
        let turning = ImuRepr {
            rate_rps: [0.001, -0.002, 0.175],
            ..level()
        };
        let (_, events) = feed(&mut c, 5.0, 2.0, |_| turning);
        assert!(
            matches!(
                events.as_slice(),
                [CoreEvent::CalibrationLeftOut(LeftOut { seconds: 2, .. })]
            ),
            "{events:?}"
        );
        assert_eq!(c.heading, None, "watched again from where it stands");
        c.heading(0.85);
        assert_eq!(c.heading, Some((0.85, 0.85)));
    }

    #[test]
    fn the_compass_is_said_once_two_seconds_are_judged_and_not_at_its_limit() {
        let turning = ImuRepr {
            rate_rps: [0.001, -0.002, 0.3],
            ..level()
        };
        // Exactly at the limit: nothing.
        let h = CALIBRATION_TURN_RAD * 20.0;
        assert_eq!(h / 20.0, CALIBRATION_TURN_RAD, "an exact limit");
        let mut c = GroundCalibration::new(0.0, 60.0);
        feed(&mut c, 0.0, 3.0, |_| level());
        c.heading(0.0);
        c.heading(h);
        assert_eq!(c.heading, Some((0.0, CALIBRATION_TURN_RAD)));
        let (_, events) = feed(&mut c, 3.0, 3.0, |_| level());
        assert!(events.is_empty(), "{events:?}");
        // Beyond it: said when the second it moved in and the next are judged still.
        let mut c = GroundCalibration::new(0.0, 60.0);
        feed(&mut c, 0.0, 3.0, |_| level());
        c.heading(0.0);
        c.heading(2.0);
        let (_, events) = feed(&mut c, 3.0, 1.0, |_| level());
        assert!(events.is_empty(), "one second judged: {events:?}");
        let (_, events) = feed(&mut c, 4.0, 1.0, |_| level());
        assert!(
            matches!(events.as_slice(), [CoreEvent::CalibrationCompassMoved { moved_rad }] if *moved_rad > CALIBRATION_TURN_RAD),
            "{events:?}"
        );
        // A move the gyros saw as a turn is not the compass's to tell.
        let mut c = GroundCalibration::new(0.0, 60.0);
        feed(&mut c, 0.0, 3.0, |_| level());
        c.heading(0.0);
        c.heading(2.0);
        let (_, events) = feed(
            &mut c,
            3.0,
            4.0,
            |t| if t < 4.0 { turning } else { level() },
        );
        assert!(
            events
                .iter()
                .all(|e| matches!(e, CoreEvent::CalibrationLeftOut(_))),
            "{events:?}"
        );
    }

    #[test]
    fn a_helicopter_rocked_again_and_again_is_said_held_up_every_twenty_seconds_left_out() {
        // A turn one second in four: each costs three seconds (its edges with it), one in
        // four kept; the seconds left out pass 20 at 27 s and 40 at 54 s — said once each.
        let turning = ImuRepr {
            rate_rps: [0.001, -0.002, 0.3],
            ..level()
        };
        let mut c = GroundCalibration::new(0.0, 200.0);
        let (_, events) = feed(&mut c, 0.0, 60.0, |t| {
            if t >= 4.0 && (t as u64).is_multiple_of(4) {
                turning
            } else {
                level()
            }
        });
        let held: Vec<(u32, u32)> = events
            .iter()
            .filter_map(|e| match e {
                CoreEvent::CalibrationHeldUp {
                    restarts,
                    left_out_s,
                } => Some((*restarts, *left_out_s)),
                _ => None,
            })
            .collect();
        assert!(
            !events
                .iter()
                .any(|e| matches!(e, CoreEvent::CalibrationRestarted(_))),
            "{events:?}"
        );
        assert_eq!(held.len(), 2, "{held:?}");
        assert!(held[0].0 == 0 && (20..23).contains(&held[0].1), "{held:?}");
        assert!(held[1].0 == 0 && (40..43).contains(&held[1].1), "{held:?}");
    }

    #[test]
    fn headings_outside_the_window_or_not_numbers_are_not_watched() {
        let mut c = GroundCalibration::new(5.0, 10.0);
        c.heading(0.5);
        assert_eq!(c.heading, None, "still warming up");
        feed(&mut c, 0.0, 6.0, |_| level());
        c.heading(0.5);
        assert!(c.heading.is_some());
        c.heading(f64::NAN);
        assert_eq!(
            c.heading, None,
            "a heading that is no number forgets the watch"
        );
    }
}
