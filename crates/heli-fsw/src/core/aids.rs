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
        let refused = |ratio: f64, since_s: Option<f64>| {
            ratio > 1.0 && since_s.is_none_or(|s| s > AID_REFUSED_AFTER_S)
        };
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
