//! Faults timed from a phase of the flight (`faults.timed_from`): they act at their times
//! counted from the phase's first moment, never before it, and a run whose phase never came
//! fails rather than passing on faults that never acted.

use heli_fsw::phase::{Phase, RollStage};
use heli_scenario::fault_timing::PHASES;
use heli_sim::Simulation;
use heli_types::AugmentedMode;

/// The time (s) of the first event whose text ends with `what`.
fn when(events: &[String], what: &str) -> Option<f64> {
    events
        .iter()
        .find(|e| e.ends_with(what))
        .and_then(|e| e.strip_prefix("t=")?.split(' ').next()?.parse::<f64>().ok())
}

#[test]
fn a_transmitter_loss_timed_from_the_run_up_comes_that_long_after_it_whatever_the_wind() {
    for wind_north_mps in [0.0, -6.0] {
        let mut s = heli_scenario::rolls();
        s.wind_ned_mps = [wind_north_mps, 0.0, 0.0];
        s.faults.timed_from = Some("accelerate".into());
        s.faults.transmitter_lost = vec![[12.0, 400.0]];
        let summary = heli_sim::run(s).unwrap();
        let run_up = when(&summary.events, "phase accelerate").unwrap();
        let lost = when(&summary.events, "pilot signal lost").unwrap();
        // Lost 12 s into the manoeuvre (to the control step), a roll under way finished first.
        assert!(
            (lost - (run_up + 12.0)).abs() < 0.05,
            "wind {wind_north_mps}: run-up at {run_up} s, lost at {lost} s"
        );
        let began = summary
            .criteria
            .iter()
            .find(|c| c.name == "fault_phase_began_s")
            .unwrap();
        assert!(
            began.pass && began.value.is_some_and(|t| (t - run_up).abs() < 0.01),
            "{began:?}"
        );
    }
}

#[test]
fn faults_timed_from_a_phase_that_never_comes_never_act_and_the_run_fails() {
    // A hover never rolls: the loss never comes, and the run says why it judged nothing.
    let mut s = heli_scenario::hover();
    s.faults.timed_from = Some("rolling".into());
    s.faults.transmitter_lost = vec![[0.0, 400.0]];
    let summary = heli_sim::run(s).unwrap();
    assert!(
        when(&summary.events, "pilot signal lost").is_none(),
        "{:?}",
        summary.events
    );
    let began = summary
        .criteria
        .iter()
        .find(|c| c.name == "fault_phase_began_s")
        .unwrap();
    assert!(!began.pass && began.value.is_none(), "{began:?}");
}

#[test]
fn the_hilsim_refuses_faults_timed_from_a_phase_it_cannot_see() {
    let mut s = heli_scenario::hover();
    s.faults.timed_from = Some("hold".into());
    let e = Simulation::hil(s).err().unwrap().to_string();
    assert!(e.contains("timed_from"), "{e}");
}

#[test]
fn the_phases_faults_are_timed_from_are_the_flight_software_s_every_one() {
    let target = heli_control::Target::hold(nalgebra::Vector3::zeros(), 0.0);
    let names: Vec<&str> = [
        Phase::Calibrating,
        Phase::Manual,
        Phase::GroundFailsafe,
        Phase::BlindDescent,
        Phase::TakeoffRefused,
        Phase::Landed,
        Phase::PreflightCheck { since_us: 0 },
        Phase::TakingOff { target },
        Phase::Holding {
            target,
            since_us: 0,
        },
        Phase::Flying {
            target,
            to_ned_m: nalgebra::Vector3::zeros(),
        },
        Phase::Landing {
            target,
            settled_since_us: None,
        },
        Phase::Autorotation {
            settled_since_us: None,
        },
        Phase::Augmented(AugmentedMode::Rate),
        Phase::Augmented(AugmentedMode::Attitude),
        Phase::Augmented(AugmentedMode::Velocity),
    ]
    .iter()
    .map(Phase::name)
    .chain(
        [
            RollStage::Accelerate { since_us: 0 },
            RollStage::PullUp { since_us: 0 },
            RollStage::Rolling {
                angle_rad: 0.0,
                since_us: 0,
            },
            RollStage::Recover { since_us: 0 },
        ]
        .iter()
        .map(RollStage::name),
    )
    .collect();
    for phase in PHASES {
        assert!(names.contains(&phase), "{phase} is not a phase's name");
    }
    for name in &names {
        assert!(PHASES.contains(name), "the phase {name} cannot be named");
    }
    assert_eq!(names.len(), PHASES.len());
}
