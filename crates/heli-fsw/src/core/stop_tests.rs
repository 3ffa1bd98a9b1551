//! The operator's Stop (`stop.rs`): the answer in every phase, the landing the sequencer flies
//! for a Stop in the air, and how that landing ends.

use super::sequencer::Crew;
use super::sequencer_tests::{core_in, est, next};
use super::stop::{StopAnswer, StopRefusal, answer, landing_outcome};
use super::tests::raised;
use super::*;
use crate::phase::RollStage;

const S: u64 = 1_000_000;

fn hold() -> Phase {
    Phase::Holding {
        target: heli_control::Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.3),
        since_us: S,
    }
}

fn stop(core: &mut FlightCore, now_us: u64) -> Vec<Action> {
    let mut out = Vec::new();
    core.handle(Input::StopRequested, now_us, &mut out);
    out
}

#[test]
fn on_the_ground_the_flight_ends_and_in_the_air_it_lands_or_is_refused() {
    let landing = Phase::Landing {
        target: heli_control::Target::hold(Vector3::zeros(), 0.0),
        settled_since_us: None,
    };
    for phase in [
        Phase::Calibrating,
        Phase::PreflightCheck { since_us: 0 },
        Phase::TakeoffRefused,
        Phase::GroundFailsafe,
        Phase::Landed,
    ] {
        assert_eq!(answer(phase, true, false), StopAnswer::Now, "{phase:?}");
    }
    for phase in [
        hold(),
        landing,
        Phase::Autorotation {
            settled_since_us: None,
        },
    ] {
        assert_eq!(answer(phase, true, false), StopAnswer::Landing, "{phase:?}");
    }
    for phase in [
        Phase::Manual,
        Phase::Augmented(heli_types::AugmentedMode::Rate),
    ] {
        assert_eq!(
            answer(phase, true, false),
            StopAnswer::Refused(StopRefusal::PilotFlying),
            "{phase:?} in the air"
        );
        assert_eq!(
            answer(phase, true, true),
            StopAnswer::Now,
            "{phase:?} landed"
        );
        assert_eq!(
            answer(phase, false, false),
            StopAnswer::Now,
            "{phase:?} never up"
        );
    }
    assert_eq!(
        answer(Phase::BlindDescent, true, false),
        StopAnswer::Refused(StopRefusal::Blind)
    );
    assert_eq!(answer(Phase::BlindDescent, false, false), StopAnswer::Now);
    assert!(StopRefusal::PilotFlying.text().contains("land, then Stop"));
}

#[test]
fn a_stop_in_a_hover_lands_where_it_is_and_gives_up_the_plan() {
    let mut core = core_in(hold(), FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    let out = stop(&mut core, S);
    assert!(
        raised(&out, CoreEvent::Stop(StopAnswer::Landing)),
        "{out:?}"
    );
    assert!(core.seq.operator_stop);
    let e = est(10.0, 3.0, Vector3::zeros());
    let (phase, _) = next(&mut core, &e, S + 20_000);
    let Phase::Landing { target, .. } = phase else {
        panic!("{phase:?}");
    };
    assert!(
        (target.pos_ned_m - e.pos_ned_m).norm() < 1e-9,
        "down where it is"
    );
    assert!(target.vel_ned_mps.z > 0.0, "descending");
    assert!(core.seq.plan_abandoned);
}

#[test]
fn a_stop_in_a_roll_lets_the_roll_finish_first() {
    let rolling = Phase::Maneuver {
        target: heli_control::Target::hold(Vector3::new(0.0, 0.0, -20.0), 0.3),
        stage: RollStage::Rolling {
            angle_rad: 1.0,
            since_us: S,
        },
        rolls_done: 0,
    };
    let mut core = core_in(rolling, FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    let out = stop(&mut core, S);
    assert!(raised(&out, CoreEvent::Stop(StopAnswer::Landing)));
    let e = est(20.0, 0.0, Vector3::new(8.0, 0.0, 0.0));
    let (phase, _) = next(&mut core, &e, S + 20_000);
    // The roll's own step decides (here it ends it); no landing replaces it mid-roll.
    assert!(!matches!(phase, Phase::Landing { .. }), "{phase:?}");
    core.seq.phase = phase;
    let (phase, _) = next(&mut core, &e, S + 40_000);
    assert!(matches!(phase, Phase::Landing { .. }), "{phase:?}");
}

#[test]
fn under_the_pilot_in_the_air_a_stop_is_refused_and_changes_nothing() {
    let mut core = core_in(Phase::Manual, FlightMode::Manual, false, S);
    core.seq.airborne_once = true;
    let out = stop(&mut core, S);
    assert!(raised(
        &out,
        CoreEvent::Stop(StopAnswer::Refused(StopRefusal::PilotFlying))
    ));
    assert!(!core.seq.operator_stop);
    let (phase, _) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S + 20_000);
    assert_eq!(phase, Phase::Manual);
}

#[test]
fn a_stop_landing_ends_on_the_skids_or_is_given_up_when_the_pilot_takes_it() {
    assert_eq!(landing_outcome(Phase::Landed), Some(StopAnswer::Now));
    assert_eq!(
        landing_outcome(Phase::GroundFailsafe),
        Some(StopAnswer::Now)
    );
    assert_eq!(
        landing_outcome(Phase::Manual),
        Some(StopAnswer::Cancelled(StopRefusal::PilotFlying))
    );
    // The estimate lost on the way down: given up for the blind descent, not the pilot.
    assert_eq!(
        landing_outcome(Phase::BlindDescent),
        Some(StopAnswer::Cancelled(StopRefusal::Blind))
    );
    assert_eq!(landing_outcome(hold()), None);
    // The pilot's switch off during a Stop's landing: the pilot flies.
    let mut core = core_in(hold(), FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    stop(&mut core, S);
    core.devices.pilot = Some(super::tests::uplink(false, false));
    let (phase, _) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S + 20_000);
    assert_eq!(phase, Phase::Manual);
    assert_eq!(
        landing_outcome(phase),
        Some(StopAnswer::Cancelled(StopRefusal::PilotFlying))
    );
}

#[test]
fn a_landed_helicopter_whose_imu_goes_silent_stays_landed_not_blind() {
    let mut core = core_in(Phase::Landed, FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    let mut out = Vec::new();
    let phase = core.seq.next_phase(
        &mut Crew {
            config: &core.config,
            devices: &core.devices,
            aiding: &core.aiding,
            nav: &core.nav,
            estimate_valid: false,
            aligning: false,
            roll_rate_rps: None,
            hover_trim_ned_mps2: Vector3::zeros(),
            modes: &mut core.modes,
            engine: &mut core.engine,
            power: &mut core.power,
            stats: &mut core.stats,
        },
        None,
        S,
        0.02,
        &mut out,
    );
    assert_eq!(phase, Phase::Landed);
    assert_eq!(answer(phase, true, false), StopAnswer::Now);
}

#[test]
fn on_the_ground_means_within_half_a_metre_of_the_take_off_height_and_slower_than_half_a_metre_a_second()
 {
    let core = core_in(Phase::Manual, FlightMode::Manual, false, S);
    // As the core asks it: the height above the take-off point, the speed.
    let settled = |h: f64, v: f64| {
        let e = est(h, 0.0, Vector3::new(v, 0.0, 0.0));
        super::stop::settled(core.seq.height_above_home(&e), e.vel_ned_mps.norm())
    };
    assert!(settled(0.2, 0.1));
    assert!(settled(0.0, 0.0));
    assert!(!settled(0.5, 0.1), "at the height limit: not on the ground");
    assert!(!settled(0.6, 0.1));
    assert!(!settled(0.2, 0.5), "at the speed limit: still moving");
    assert!(!settled(0.2, 0.7));
    // So a pilot who has landed may Stop; one still up may not.
    assert_eq!(
        answer(Phase::Manual, true, settled(0.1, 0.0)),
        StopAnswer::Now
    );
    assert_eq!(
        answer(Phase::Manual, true, settled(3.0, 0.0)),
        StopAnswer::Refused(StopRefusal::PilotFlying)
    );
}

#[test]
fn a_stop_landing_gives_way_only_to_a_lost_transmitter_on_the_ground() {
    let lost = super::tests::uplink(true, true);
    // In the air with the transmitter lost: the Stop's landing, not the loss's hover.
    let mut core = core_in(hold(), FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    stop(&mut core, S);
    core.devices.pilot = Some(lost);
    let (phase, _) = next(&mut core, &est(10.0, 0.0, Vector3::zeros()), S + 20_000);
    assert!(matches!(phase, Phase::Landing { .. }), "{phase:?}");
    // On the ground with the transmitter lost: everything idles.
    let mut core = core_in(hold(), FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    stop(&mut core, S);
    core.devices.pilot = Some(lost);
    let (phase, _) = next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S + 20_000);
    assert!(!matches!(phase, Phase::Landing { .. }), "{phase:?}");
    // On the ground with the transmitter: the Stop's landing (it ends at once on the skids).
    let mut core = core_in(hold(), FlightMode::Autonomous, true, S);
    core.seq.airborne_once = true;
    stop(&mut core, S);
    let (phase, _) = next(&mut core, &est(0.0, 0.0, Vector3::zeros()), S + 20_000);
    assert!(matches!(phase, Phase::Landing { .. }), "{phase:?}");
}
