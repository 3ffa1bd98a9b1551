//! Aids the filter keeps refusing: an altimeter or compass whose readings arrive but fail
//! the innovation gate (a biased or scaled sensor, a wrong compass calibration) leaves the
//! estimate without that aid as surely as a silent device, yet its watchdog sees it healthy.
//! Each is raised as an event once its readings have been refused for [`AID_REFUSED_AFTER_S`]
//! and again when one is fused (as PX4 reports an innovation-check failure of a sensor).
//! The GPS has its own events, raised here too: a fix refused before the filter sees it
//! (`crate::core::gps`: off the globe, or a jump no helicopter makes), the filter's reset
//! onto a fix, its outage and its return.
//!
//! A component: it owns what it last raised and the last good fix; the core hands it the
//! filter (`heli_nav::Navigator`) with each fix and each control step, and it raises.

use heli_nav::{FilterHealth, Navigator};
use heli_proto::gps::GpsNav;

use super::event::CoreEvent;
use super::gps;
use super::{Action, Stamped};

/// How long an aid's readings must all have been refused before it is reported (s): longer
/// than a gust or a manoeuvre that a single refused reading may be.
pub const AID_REFUSED_AFTER_S: f64 = 3.0;

pub use super::event::Aid;

/// An aid whose last reading failed the gate (test ratio above one) and none of whose
/// readings was fused for [`AID_REFUSED_AFTER_S`] (or ever).
fn refused(test_ratio: f64, since_fused_s: Option<f64>) -> bool {
    test_ratio > 1.0 && since_fused_s.is_none_or(|s| s > AID_REFUSED_AFTER_S)
}

/// Which aids are being reported as refused.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct RefusedAids {
    altimeter: bool,
    compass: bool,
}

/// The aids' watch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aiding {
    /// The altimeter and compass as reported refused by the filter's gate.
    refused: RefusedAids,
    /// The GPS outage as last reported.
    gps_lost: bool,
    /// The last GPS fix that passed the plausibility check, with its time.
    pub(super) last_good_fix: Option<(u64, GpsNav)>,
}

impl Aiding {
    /// Raises an event when an aid starts or stops being refused by the filter's gate.
    pub fn watch(&mut self, nav: &Navigator, now_us: u64, out: &mut Vec<Action>) {
        if nav.state().is_none() {
            return;
        }
        let health = nav.health(now_us);
        self.judge(&health, now_us, out);
    }

    /// [`Aiding::watch`] on a health of the filter given.
    pub fn judge(&mut self, health: &FilterHealth, now_us: u64, out: &mut Vec<Action>) {
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
                Aid::Altimeter => &mut self.refused.altimeter,
                Aid::Compass => &mut self.refused.compass,
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

    /// A GPS fix at `now_us`: checked before the filter sees it — a fix off the globe, or one
    /// that jumps faster than any helicopter flies from the last good one, is refused and
    /// raised (true: refused); a good one is fused, and the filter's reset onto it raised.
    pub fn gps(
        &mut self,
        nav: &mut Navigator,
        fix: &GpsNav,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> bool {
        if let Some(why) = gps::implausible(fix, self.last_good_fix, now_us) {
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::GpsImplausible(why),
            )));
            return true;
        }
        self.last_good_fix = Some((now_us, *fix));
        let resets = nav.stats().gps_resets;
        nav.fuse_gps(now_us, fix);
        if nav.stats().gps_resets != resets {
            out.push(Action::Event(Stamped::new(now_us, CoreEvent::GpsReset)));
        }
        false
    }

    /// The filter's GPS outage at a control step with an estimate: its start and its end
    /// raised.
    pub fn gps_outage(&mut self, nav: &Navigator, now_us: u64, out: &mut Vec<Action>) {
        let gps_lost = nav.gps_outage(now_us);
        if gps_lost != self.gps_lost {
            self.gps_lost = gps_lost;
            let event = if gps_lost {
                CoreEvent::GpsLost
            } else {
                CoreEvent::GpsRegained
            };
            out.push(Action::Event(Stamped::new(now_us, event)));
        }
    }

    /// The last fix that passed the plausibility check, with its time.
    pub fn last_good_fix(&self) -> Option<(u64, GpsNav)> {
        self.last_good_fix
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

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
        let mut aiding = Aiding::default();
        let mut nav = Navigator::new(heli_nav::NavConfig::default());
        let mut out = Vec::new();
        aiding.watch(&nav, 0, &mut out);
        assert!(out.is_empty(), "no estimate yet");
        for _ in 0..5 {
            nav.fuse_baro(1013.25);
        }
        nav.initialise(
            0,
            &heli_nav::ImuBiases {
                gyro_rps: Vector3::zeros(),
                mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
                samples: 100,
            },
        );
        // An altimeter reading far off the estimate is refused by the gate...
        for _ in 0..40 {
            nav.fuse_baro(900.0);
        }
        aiding.watch(&nav, 10_000_000, &mut out);
        assert!(out.iter().any(|a| matches!(
            a,
            Action::Event(e) if matches!(e.value, CoreEvent::AidRefused { aid: Aid::Altimeter, .. })
        )), "{out:?}");
    }

    #[test]
    fn refused_and_accepted_are_raised_once_each_per_aid() {
        let mut aiding = Aiding::default();
        let health = |baro: f64, compass: f64| heli_nav::FilterHealth {
            gps_test_ratio: 0.0,
            baro_test_ratio: baro,
            compass_test_ratio: compass,
            since_gps_s: None,
            since_baro_s: Some(10.0),
            since_compass_s: Some(1.0),
        };
        let mut out = Vec::new();
        aiding.judge(&health(2.0, 2.0), 5, &mut out);
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
        aiding.judge(&health(3.0, 2.0), 6, &mut out);
        assert!(out.is_empty(), "raised once");
        aiding.judge(&health(0.5, 2.0), 7, &mut out);
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
        aiding.judge(&compass, 8, &mut out);
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
