//! Component tests of the pre-flight check (`preflight.rs`) through the core's inputs, on
//! the skids: the wait counted from the pilot's request, a refusal that stands through a
//! transmitter blip and an IMU stall, and only the pilot's switch, off and on, asking
//! again. Every input's outcome is checked against the core's invariants.

use heli_proto::scb::PilotUplink;

use super::preflight::{CHECK_WAIT_S, Refusal};
use super::tests::{core_with, gps_fix, raised, still, uplink};
use super::*;
use crate::invariants::Invariants;

/// The switch on, the transmitter heard.
fn on() -> PilotUplink {
    uplink(true, false)
}

/// An autonomous core (short calibration) on its skids, what it did, its time, and the
/// checker of its invariants.
struct Skids {
    core: FlightCore,
    out: Vec<Action>,
    t: u64,
    checker: Invariants,
}

impl Skids {
    fn new() -> Self {
        Self::started_at(core_with(FlightMode::Autonomous), 0)
    }

    /// The same core as [`Skids::new`]'s, started again from `warm` (a crash or a
    /// brown-out), its time going on from `t` µs.
    fn restarted(warm: WarmStart, t: u64) -> Self {
        let like = core_with(FlightMode::Autonomous);
        Self::started_at(FlightCore::restarted(like.config, like.seq.params, warm), t)
    }

    fn started_at(mut core: FlightCore, t: u64) -> Self {
        core.start(t);
        let checker = Invariants::new(&core, core.config.watchdog_us);
        Self {
            core,
            out: Vec::new(),
            t,
            checker,
        }
    }

    /// The pilot's switch off and on again, half a second each, with eight satellites.
    fn cycle_switch(&mut self) {
        self.run(0.5, true, uplink(false, false), Some(8));
        self.run(0.5, true, on(), Some(8));
    }

    /// Panics unless the core is taking off.
    fn assert_taking_off(&self) {
        assert!(
            matches!(self.core.phase(), Phase::TakingOff { .. }),
            "{:?}",
            self.core.phase()
        );
    }

    /// The estimate's down position (m).
    fn est_z(&self) -> f64 {
        self.core.navigator().state().expect("estimate").pos_ned_m.z
    }

    /// `seconds` of the IMU (when `imu`), `pilot`'s packets at 50 Hz and, when
    /// `satellites` is given, a fix with them every half second.
    fn run(&mut self, seconds: f64, imu: bool, pilot: PilotUplink, satellites: Option<u8>) {
        let end = self.t + (seconds * 1e6) as u64;
        while self.t < end {
            self.t += 1_000;
            let t = self.t;
            let mut inputs = Vec::new();
            if self.core.poll_at().is_some_and(|at| at <= t) {
                inputs.push(Input::Timer);
            }
            if imu && t.is_multiple_of(10_000) {
                inputs.push(Input::Imu(still()));
            }
            if t.is_multiple_of(20_000) {
                inputs.push(Input::Uplink(pilot));
            }
            if let Some(n) = satellites
                && t.is_multiple_of(500_000)
            {
                inputs.push(Input::Gps(gps_fix(n)));
            }
            for input in inputs {
                let mut actions = Vec::new();
                self.core.handle(input, t, &mut actions);
                let verdict = self.checker.check(&self.core, t, &actions);
                assert_eq!(verdict, Ok(()), "t = {t} µs, {:?}", self.core.phase());
                self.out.extend(actions);
            }
        }
    }

    /// The take-off refusals raised so far.
    fn refusals(&self) -> Vec<Refusal> {
        self.out
            .iter()
            .filter_map(|a| match a {
                Action::Event(e) => match e.value {
                    CoreEvent::TakeoffRefused(r) => Some(r),
                    _ => None,
                },
                _ => None,
            })
            .collect()
    }
}

#[test]
fn the_wait_counts_from_the_request_through_a_transmitter_blip() {
    let mut skids = Skids::new();
    // Three satellites: the check waits.
    skids.run(5.0, true, on(), Some(3));
    let Phase::PreflightCheck { since_us } = skids.core.phase() else {
        panic!("{:?}", skids.core.phase());
    };
    // The transmitter lost on the skids for a second: everything idles.
    skids.run(1.0, true, uplink(true, true), Some(3));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    // Back, the check goes on from the request: begun again after every blip, an
    // unsteady link would keep the helicopter in the check for ever, neither flying nor
    // refused.
    skids.run(1.0, true, on(), Some(3));
    assert_eq!(skids.core.phase(), Phase::PreflightCheck { since_us });
    let refused_at = since_us + (CHECK_WAIT_S * 1e6) as u64;
    skids.run(
        (refused_at - skids.t) as f64 * 1e-6 + 0.1,
        true,
        on(),
        Some(3),
    );
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::TooFewSatellites(3)]);
}

#[test]
fn a_refusal_stands_through_a_transmitter_blip_until_the_switch_is_cycled() {
    let mut skids = Skids::new();
    skids.run(CHECK_WAIT_S + 5.0, true, on(), Some(3));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    // Eight satellites now, and a blip: back from the ground failsafe the refusal stands;
    // the checks, which would pass, are not asked again, and nothing is raised again.
    skids.run(3.0, true, on(), Some(8));
    skids.run(1.0, true, uplink(true, true), Some(8));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    skids.run(5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::TooFewSatellites(3)]);
    // Off, then on: a new request, whose checks pass: it takes off.
    skids.run(0.5, true, uplink(false, false), Some(8));
    assert_eq!(skids.core.phase(), Phase::Manual);
    skids.run(0.5, true, on(), Some(8));
    skids.assert_taking_off();
}

#[test]
fn a_stall_during_the_check_refuses_the_take_off_at_once_and_the_refusal_stands() {
    let mut skids = Skids::new();
    skids.run(5.0, true, on(), Some(3));
    assert!(matches!(skids.core.phase(), Phase::PreflightCheck { .. }));
    // The IMU stalls long enough to lose the estimate, which never starts again on a
    // helicopter that never flew: the take-off will not happen, and the operator is told
    // so now rather than shown a ground failsafe.
    skids.run(1.0, false, on(), Some(3));
    assert!(raised(&skids.out, CoreEvent::EstimateInvalid));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::EstimateLost]);
    // The IMU back: the refusal stands, the rotor governed on the skids; through another
    // stall, and a transmitter blip (idle meanwhile), too.
    skids.run(5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    skids.run(1.0, false, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    skids.run(1.0, true, uplink(true, true), Some(8));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    skids.run(1.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::EstimateLost]);
    // The switch off gives the pilot the helicopter; on again, with no estimate, nothing
    // flies on its own: the ground failsafe.
    skids.run(0.5, true, uplink(false, false), Some(8));
    assert_eq!(skids.core.phase(), Phase::Manual);
    skids.run(0.5, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
}

#[test]
fn a_stall_after_a_blip_interrupted_the_check_refuses_too() {
    let mut skids = Skids::new();
    skids.run(5.0, true, on(), Some(3));
    // Transmitter lost, and while it is the IMU stalls: the request is refused (idle while
    // the transmitter is lost), and the refusal shows when it is back.
    skids.run(0.5, true, uplink(true, true), Some(3));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    skids.run(1.0, false, uplink(true, true), Some(3));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    assert_eq!(skids.refusals(), [Refusal::EstimateLost]);
    skids.run(1.0, true, on(), Some(3));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
}

#[test]
fn a_transmitter_lost_past_the_wait_refuses_then_and_its_return_is_no_take_off() {
    let mut skids = Skids::new();
    // Three satellites: the check waits; then the transmitter is lost on the skids.
    skids.run(5.0, true, on(), Some(3));
    let Phase::PreflightCheck { since_us } = skids.core.phase() else {
        panic!("{:?}", skids.core.phase());
    };
    skids.run(5.0, true, uplink(true, true), Some(3));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    assert_eq!(skids.refusals(), []);
    // The wait runs out while it is lost: refused then, with the check that fails, and
    // said while the helicopter idles.
    let refused_at = since_us + (CHECK_WAIT_S * 1e6) as u64;
    skids.run(
        (refused_at - skids.t) as f64 * 1e-6 + 0.1,
        true,
        uplink(true, true),
        Some(3),
    );
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    assert_eq!(skids.refusals(), [Refusal::TooFewSatellites(3)]);
    // Eight satellites, and minutes later the transmitter back with the switch still on:
    // the refusal stands, nothing takes off.
    skids.run(120.0, true, uplink(true, true), Some(8));
    skids.run(5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::TooFewSatellites(3)]);
    // Only the switch, off and on, asks again.
    skids.cycle_switch();
    skids.assert_taking_off();
}

#[test]
fn a_wait_whose_checks_pass_while_the_transmitter_is_lost_is_refused_for_the_loss() {
    let mut skids = Skids::new();
    skids.run(5.0, true, on(), Some(3));
    // Lost; the satellites come meanwhile; the wait runs out: the loss is the reason.
    skids.run(40.0, true, uplink(true, true), Some(8));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    assert_eq!(skids.refusals(), [Refusal::TransmitterLost]);
    skids.run(5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
}

/// A core calibrated on the skids with the switch on and refused for three satellites,
/// and the record it leaves.
fn refused_then_record() -> (Skids, WarmStart) {
    let mut skids = Skids::new();
    skids.run(CHECK_WAIT_S + 5.0, true, on(), Some(3));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    let warm = skids.core.warm_start().expect("calibrated");
    assert!(!warm.airborne);
    (skids, warm)
}

#[test]
fn a_process_started_again_on_the_skids_with_the_switch_on_refuses_until_it_is_cycled() {
    let (before, warm) = refused_then_record();
    // The process crashes and is started again; the switch is still on and the checks
    // would pass now: a switch left on is no request, refused once the calibration is done.
    let mut skids = Skids::restarted(warm, before.t + 500_000);
    skids.run(CHECK_WAIT_S + 5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::Restarted]);
    assert!(Refusal::Restarted.text().contains("off and on"));
    // Off and on: the pilot's request, whose checks pass.
    skids.cycle_switch();
    skids.assert_taking_off();
    assert_eq!(skids.refusals(), [Refusal::Restarted]);
}

#[test]
fn a_switch_seen_off_during_the_restarted_calibration_makes_the_next_on_a_request() {
    let (before, warm) = refused_then_record();
    let mut skids = Skids::restarted(warm, before.t + 500_000);
    // Off while the new process calibrates, on afterwards: an ordinary take-off.
    skids.run(0.5, true, uplink(false, false), Some(8));
    assert_eq!(skids.core.phase(), Phase::Calibrating);
    skids.run(5.0, true, uplink(false, false), Some(8));
    skids.run(1.0, true, on(), Some(8));
    skids.assert_taking_off();
    assert_eq!(skids.refusals(), []);
}

#[test]
fn the_altimeter_s_drift_through_a_long_wait_is_no_climb() {
    let mut skids = Skids::new();
    skids.run(CHECK_WAIT_S + 5.0, true, on(), Some(3));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    // The weather's pressure drifts the estimate 0.3 m up from home over five minutes on
    // the skids (home moved down against it, second by second): home's height follows
    // within a few centimetres, and the helicopter is never airborne.
    let drift_m = 0.3;
    let wait_s = 300;
    let mut worst_lag_m: f64 = 0.0;
    for _ in 0..wait_s {
        if let Some(home) = skids.core.seq.home_ned_m.as_mut() {
            home.z += drift_m / f64::from(wait_s);
        }
        skids.run(1.0, true, on(), Some(3));
        let home_z = skids.core.seq.home_ned_m.expect("home").z;
        worst_lag_m = worst_lag_m.max((home_z - skids.est_z()).abs());
    }
    assert!(worst_lag_m < 0.08, "home lagged {worst_lag_m} m behind");
    assert!(!skids.core.seq.airborne_once);
    // Home half a metre below the estimate at once (as a wrong reading would put it): held
    // down by the computer, still not airborne; then the transmitter is lost: on the
    // ground, idle — not a hover to lift into.
    let est_z = skids.est_z();
    skids.core.seq.home_ned_m = skids
        .core
        .seq
        .home_ned_m
        .map(|h| Vector3::new(h.x, h.y, est_z + 0.5));
    skids.run(1.0, true, uplink(true, true), Some(3));
    assert_eq!(skids.core.phase(), Phase::GroundFailsafe);
    assert!(!skids.core.seq.airborne_once);
}

#[test]
fn home_s_height_is_the_estimate_s_average_on_the_skids_not_one_reading() {
    use super::step::{HOME_FOLLOW_S, follow_ground};
    let dt_s = 0.02;
    // The estimate jumping 0.2 m either side of 1 m at every step, for the 30 s of a
    // pre-flight check: home stays within 2 cm of the average (within the same at once).
    let mut home_z = 1.0;
    for step in 0..1500 {
        let est_z = if step % 2 == 0 { 1.2 } else { 0.8 };
        home_z = follow_ground(home_z, est_z, dt_s);
        assert!((home_z - 1.0).abs() < 0.02, "step {step}: {home_z}");
    }
    // A step of the ground's height is followed with the time constant: 1 − 1/e of it after
    // HOME_FOLLOW_S in control steps, nearly all of it after five. In one step as long as
    // the time constant, half of it (the implicit form: never past the estimate).
    let one_tau = 1.0 - (-1.0f64).exp();
    let mut home_z = 0.0;
    let steps = (HOME_FOLLOW_S / dt_s).round() as u32;
    for _ in 0..steps {
        home_z = follow_ground(home_z, 1.0, dt_s);
    }
    assert!((home_z - one_tau).abs() < 1e-3, "{home_z}");
    assert!((follow_ground(0.0, 1.0, HOME_FOLLOW_S) - 0.5).abs() < 1e-12);
    assert!((follow_ground(2.0, 1.0, 3.0 * HOME_FOLLOW_S) - 1.25).abs() < 1e-12);
    for _ in 0..4 * steps {
        home_z = follow_ground(home_z, 1.0, dt_s);
    }
    assert!((home_z - 1.0).abs() < 0.01, "{home_z}");
    // Not a step forward, or no estimate to follow: home stays.
    assert_eq!(follow_ground(0.5, f64::NAN, dt_s), 0.5);
    assert_eq!(follow_ground(0.5, 1.0, 0.0), 0.5);
    assert_eq!(follow_ground(0.5, 1.0, -0.02), 0.5);
    assert_eq!(follow_ground(0.5, 1.0, f64::INFINITY), 0.5);
    // A step far longer than the time constant does not overshoot.
    assert!(follow_ground(0.0, 1.0, 1e9) <= 1.0);
}

#[test]
fn during_the_restarted_calibration_the_switch_off_asks_again_but_a_lost_signal_does_not() {
    // Off and on again within the calibration: the pilot's request, taken at its end.
    let (before, warm) = refused_then_record();
    let mut skids = Skids::restarted(warm, before.t + 500_000);
    skids.run(0.3, true, on(), Some(8));
    skids.run(0.2, true, uplink(false, false), Some(8));
    skids.run(0.2, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::Calibrating);
    skids.run(5.0, true, on(), Some(8));
    skids.assert_taking_off();
    assert_eq!(skids.refusals(), []);
    // A receiver's failsafe packet (every channel zero, the auto flag with them) in the
    // calibration is no switch the pilot moved: a switch left on is still refused.
    let (before, warm) = refused_then_record();
    let mut skids = Skids::restarted(warm, before.t + 500_000);
    skids.run(0.3, true, on(), Some(8));
    skids.run(0.2, true, uplink(false, true), Some(8));
    skids.run(0.2, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::Calibrating);
    skids.run(5.0, true, on(), Some(8));
    assert_eq!(skids.core.phase(), Phase::TakeoffRefused);
    assert_eq!(skids.refusals(), [Refusal::Restarted]);
}
