//! Pre-flight checks: what must hold before the helicopter leaves the ground on its own.
//! When the pilot asks for an autonomous take-off the core waits on the skids, rotor
//! governed, up to [`CHECK_WAIT_S`] for the checks to pass (the first GPS fix is fused only
//! once the filter starts, just after the calibration), then takes off; if they still fail,
//! the take-off is refused — raised, and the helicopter stays on its skids until the pilot
//! takes the auto switch off. It needs:
//!
//! - a GPS fix fused in the last [`GPS_FRESH_S`] seconds (the position hold needs one);
//! - at least [`MIN_SATELLITES`] satellites in the last good fix (the thesis: fewer than
//!   five is dangerous);
//! - an IMU whose watchdog says it is on time;
//! - and then the whole safety rule for automatic flight (`heli_control::safety`).
//!
//! The pilot's request ([`Request`]) is held from the auto switch put on to the take-off or
//! the switch off, through whatever interrupts the check on the ground (a transmitter
//! blip's ground failsafe): the wait counts from the request, not from the interruption,
//! and a refusal stands through it — only the switch, off and on, asks again. The estimate
//! lost during the wait (an IMU stall on the skids, after which the estimate never starts
//! again on the ground) refuses the take-off at once, said so, rather than leaving the
//! operator a ground failsafe that never says the helicopter will not go.

use heli_nav::{NavSensorStats, seconds_between};
use heli_proto::gps::GpsNav;

/// Longest wait for the checks to pass before a take-off is refused (s): longer than a
/// receiver's satellite drop-outs (up to 15 s) and a short GPS outage, which pass.
pub const CHECK_WAIT_S: f64 = 30.0;

/// The last GPS fix fused must be this recent (s).
pub const GPS_FRESH_S: f64 = 3.0;
/// Fewest satellites for an autonomous take-off (the thesis's ground display turns its GPS indicator red below five: "any kind of automatic or augmented control flight is dangerous").
pub const MIN_SATELLITES: u8 = 5;

/// Why a take-off was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// No GPS fix has ever been fused.
    NoGpsFix,
    /// The last fused fix is older than [`GPS_FRESH_S`].
    GpsStale,
    /// The last good fix had this many satellites, fewer than [`MIN_SATELLITES`].
    TooFewSatellites(u8),
    /// The IMU is late or silent.
    ImuNotHealthy,
    /// The safety rule for automatic flight fails (`heli_control::safety::AUTOMATIC`).
    Unsafe(heli_control::safety::Verdict),
    /// The estimate was lost during the check (the IMU stalled on the skids).
    EstimateLost,
    /// The transmitter was lost when the wait ran out, the checks passing then.
    TransmitterLost,
    /// The flight process started again on the ground (after a crash or a brown-out) with
    /// the auto switch on: a switch left on is no request.
    Restarted,
}

impl Refusal {
    /// What it says on the ground display.
    pub fn text(self) -> String {
        match self {
            Refusal::NoGpsFix => "no GPS fix".into(),
            Refusal::GpsStale => format!("no GPS fix in the last {GPS_FRESH_S} s"),
            Refusal::TooFewSatellites(n) => {
                format!("{n} satellites, fewer than {MIN_SATELLITES}")
            }
            Refusal::ImuNotHealthy => "the IMU is not on time".into(),
            Refusal::Unsafe(verdict) => format!("not safe for automatic flight: {verdict}"),
            Refusal::EstimateLost => {
                "the estimate was lost (the IMU stalled) during the checks".into()
            }
            Refusal::TransmitterLost => {
                format!("the transmitter was lost when the checks' {CHECK_WAIT_S} s ran out")
            }
            Refusal::Restarted => {
                "the flight process started again on the ground with the auto switch on: take it off and on to ask again".into()
            }
        }
    }
}

/// The checks at `now_us`: the IMU on time (`imu_ok`), the last good fix's satellites, the
/// filter's GPS fusions (`nav`), then the safety rule's verdict on automatic flight (asked last, only
/// when everything else passed). `None` when the take-off may go.
pub fn check(
    imu_ok: bool,
    nav: &NavSensorStats,
    last_good_fix: Option<(u64, GpsNav)>,
    automatic: impl FnOnce() -> heli_control::safety::Verdict,
    now_us: u64,
) -> Option<Refusal> {
    if !imu_ok {
        return Some(Refusal::ImuNotHealthy);
    }
    // Too few satellites first: the receiver's fix, too poor for the filter to fuse, is
    // what the operator sees (the ground's GPS lamp names its satellites), not "no fix".
    match last_good_fix {
        Some((_, fix)) if fix.satellites < MIN_SATELLITES => {
            return Some(Refusal::TooFewSatellites(fix.satellites));
        }
        _ => {}
    }
    if nav.gps_fused == 0 {
        return Some(Refusal::NoGpsFix);
    }
    if seconds_between(nav.last_gps_fused_us, now_us) > GPS_FRESH_S {
        return Some(Refusal::GpsStale);
    }
    let verdict = automatic();
    (!verdict.allowed).then_some(Refusal::Unsafe(verdict))
}

/// The pilot's request for an autonomous take-off, as the pre-flight check holds it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Request {
    /// Nothing asked: the switch off, or the take-off under way.
    #[default]
    None,
    /// Asked at `since_us`, the checks not yet passed.
    Waiting {
        /// When the wait began (µs).
        since_us: u64,
    },
    /// Refused: it stands until the pilot takes the switch off.
    Refused,
    /// The flight process started again on the ground (a crash, a brown-out): the switch
    /// must be seen off before a request is taken; on, it is refused
    /// ([`Refusal::Restarted`]) — the process before may have refused a take-off, or been
    /// waiting on one, that the switch still asks for.
    AfterRestart,
}

impl Request {
    /// The wait's start: the request's under way, or `now_us` for a new one (the caller
    /// has found no standing refusal).
    pub fn wait_since(&mut self, now_us: u64) -> u64 {
        match *self {
            Request::Waiting { since_us } => since_us,
            Request::None | Request::Refused | Request::AfterRestart => {
                *self = Request::Waiting { since_us: now_us };
                now_us
            }
        }
    }

    /// The estimate lost: a wait under way is refused ([`Refusal::EstimateLost`], returned
    /// to be raised).
    pub fn estimate_lost(&mut self) -> Option<Refusal> {
        let Request::Waiting { .. } = self else {
            return None;
        };
        *self = Request::Refused;
        Some(Refusal::EstimateLost)
    }

    /// Whether a refusal stands.
    pub fn refused(self) -> bool {
        self == Request::Refused
    }

    /// Whether a wait under way has run out at `now_us`.
    pub fn expired(self, now_us: u64) -> bool {
        matches!(self, Request::Waiting { since_us } if seconds_between(since_us, now_us) >= CHECK_WAIT_S)
    }
}
