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
//! The wait is not begun again by a loss of the estimate on the skids (an IMU stall): the
//! check under way ends in a refusal at once ([`estimate_lost`]). Begun again after every
//! stall, a flaky IMU would hold the helicopter in the check for ever, neither flying nor
//! refused — and an IMU that stalled in the half minute before a take-off is none to take
//! off on. A refusal stands through a loss of the estimate too.

use heli_nav::{NavSensorStats, seconds_between};
use heli_proto::gps::GpsNav;

use crate::phase::Phase;

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
        }
    }
}

/// The checks at `now_us`: the IMU on time (`imu_ok`), the filter's GPS fusions (`nav`),
/// the last good fix, then the safety rule's verdict on automatic flight (asked last, only
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
    if nav.gps_fused == 0 {
        return Some(Refusal::NoGpsFix);
    }
    if seconds_between(nav.last_gps_fused_us, now_us) > GPS_FRESH_S {
        return Some(Refusal::GpsStale);
    }
    match last_good_fix {
        Some((_, fix)) if fix.satellites < MIN_SATELLITES => {
            return Some(Refusal::TooFewSatellites(fix.satellites));
        }
        _ => {}
    }
    let verdict = automatic();
    (!verdict.allowed).then_some(Refusal::Unsafe(verdict))
}

/// What becomes of `phase` when the estimate is lost on a helicopter the pilot left to the
/// computer: a check under way is refused ([`Refusal::EstimateLost`], returned to be
/// raised), a refusal stands; `None` for every other phase (the failsafes decide).
pub fn estimate_lost(phase: Phase) -> Option<(Phase, Option<Refusal>)> {
    match phase {
        Phase::PreflightCheck { .. } => Some((Phase::TakeoffRefused, Some(Refusal::EstimateLost))),
        Phase::TakeoffRefused => Some((Phase::TakeoffRefused, None)),
        _ => None,
    }
}
