//! Aids the filter keeps refusing: an altimeter or compass whose readings arrive but fail
//! the innovation gate (a biased or scaled sensor, a wrong compass calibration) leaves the
//! estimate without that aid as surely as a silent device, yet its watchdog sees it healthy.
//! Each is raised as an event once its readings have been refused for [`AID_REFUSED_AFTER_S`]
//! and again when one is fused (as PX4 reports an innovation-check failure of a sensor).
//! The GPS has its own events (`GpsLost`, `GpsReset`).

use super::*;

/// How long an aid's readings must all have been refused before it is reported (s): longer
/// than a gust or a manoeuvre that a single refused reading may be.
pub const AID_REFUSED_AFTER_S: f64 = 3.0;

/// An aid of the filter other than the GPS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aid {
    /// The barometric altimeter.
    Altimeter,
    /// The magnetic compass.
    Compass,
}

impl Aid {
    /// Short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Aid::Altimeter => "altimeter",
            Aid::Compass => "compass",
        }
    }
}

/// An aid whose last reading failed the gate (test ratio above one) and none of whose
/// readings was fused for [`AID_REFUSED_AFTER_S`] (or ever).
fn refused(test_ratio: f64, since_fused_s: Option<f64>) -> bool {
    test_ratio > 1.0 && since_fused_s.is_none_or(|s| s > AID_REFUSED_AFTER_S)
}

/// Which aids are being reported as refused.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct RefusedAids {
    altimeter: bool,
    compass: bool,
}

impl FlightCore {
    /// Raises an event when an aid starts or stops being refused by the filter's gate.
    pub(super) fn watch_aids(&mut self, now_us: u64, out: &mut Vec<Action>) {
        if self.nav.state().is_none() {
            return;
        }
        let health = self.nav.health(now_us);
        self.judge_aids(&health, now_us, out);
    }

    /// [`FlightCore::watch_aids`] on the filter's health as it is now.
    pub(super) fn judge_aids(
        &mut self,
        health: &heli_nav::FilterHealth,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        for (aid, now_refused, ratio) in [
            (
                Aid::Altimeter,
                refused(health.baro_test_ratio, health.since_baro_s),
                health.baro_test_ratio,
            ),
            (
                Aid::Compass,
                refused(health.compass_test_ratio, health.since_compass_s),
                health.compass_test_ratio,
            ),
        ] {
            let was = match aid {
                Aid::Altimeter => &mut self.refused_aids.altimeter,
                Aid::Compass => &mut self.refused_aids.compass,
            };
            if *was == now_refused {
                continue;
            }
            *was = now_refused;
            let event = if now_refused {
                CoreEvent::AidRefused {
                    aid,
                    test_ratio: ratio,
                }
            } else {
                CoreEvent::AidAccepted(aid)
            };
            out.push(Action::Event(Stamped::new(now_us, event)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_aid_is_refused_after_three_seconds_of_failing_the_gate() {
        assert!(!refused(1.0, None), "a ratio of one is inside the gate");
        assert!(refused(1.01, None));
        assert!(!refused(1.5, Some(AID_REFUSED_AFTER_S)));
        assert!(refused(1.5, Some(AID_REFUSED_AFTER_S + 0.01)));
        assert!(!refused(0.5, Some(100.0)));
        assert_eq!(Aid::Altimeter.name(), "altimeter");
        assert_eq!(Aid::Compass.name(), "compass");
    }

    #[test]
    fn the_watch_reads_the_filters_health_once_it_runs() {
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        let mut out = Vec::new();
        core.watch_aids(0, &mut out);
        assert!(out.is_empty(), "no estimate yet");
        for _ in 0..5 {
            core.nav.fuse_baro(1013.25);
        }
        core.nav.initialise(
            0,
            &heli_nav::ImuBiases {
                gyro_rps: Vector3::zeros(),
                mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
                samples: 100,
            },
        );
        // An altimeter reading far off the estimate is refused by the gate...
        for _ in 0..40 {
            core.nav.fuse_baro(900.0);
        }
        core.watch_aids(10_000_000, &mut out);
        assert!(out.iter().any(|a| matches!(
            a,
            Action::Event(e) if matches!(e.value, CoreEvent::AidRefused { aid: Aid::Altimeter, .. })
        )), "{out:?}");
    }

    #[test]
    fn refused_and_accepted_are_raised_once_each_per_aid() {
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        let health = |baro: f64, compass: f64| heli_nav::FilterHealth {
            gps_test_ratio: 0.0,
            baro_test_ratio: baro,
            compass_test_ratio: compass,
            since_gps_s: None,
            since_baro_s: Some(10.0),
            since_compass_s: Some(1.0),
        };
        let mut out = Vec::new();
        core.judge_aids(&health(2.0, 2.0), 5, &mut out);
        // The compass was fused a second ago: not yet refused.
        assert_eq!(
            out,
            vec![Action::Event(Stamped::new(
                5,
                CoreEvent::AidRefused {
                    aid: Aid::Altimeter,
                    test_ratio: 2.0
                }
            ))]
        );
        out.clear();
        core.judge_aids(&health(3.0, 2.0), 6, &mut out);
        assert!(out.is_empty(), "raised once");
        core.judge_aids(&health(0.5, 2.0), 7, &mut out);
        assert_eq!(
            out,
            vec![Action::Event(Stamped::new(
                7,
                CoreEvent::AidAccepted(Aid::Altimeter)
            ))]
        );
        out.clear();
        let mut compass = health(0.5, 2.0);
        compass.since_compass_s = None;
        core.judge_aids(&compass, 8, &mut out);
        assert_eq!(
            out,
            vec![Action::Event(Stamped::new(
                8,
                CoreEvent::AidRefused {
                    aid: Aid::Compass,
                    test_ratio: 2.0
                }
            ))]
        );
    }
}
