//! Skid contact: sitting, touching down, and the crash detector.

use heli_scenario as scenario;
use heli_sim::lockstep::Simulation;
use nalgebra::{UnitQuaternion, Vector3};

/// A run whose helicopter is dropped from `height_m` at `sink_mps` with `roll_rad`.
fn dropped(height_m: f64, sink_mps: f64, roll_rad: f64) -> Simulation {
    let mut s = scenario::hover();
    s.duration_s = 6.0;
    s.pilot.auto = false;
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    let heli = sim.helicopter_mut();
    heli.state.pos_ned_m = Vector3::new(0.0, 0.0, -height_m);
    heli.state.att = UnitQuaternion::from_euler_angles(roll_rad, 0.0, 0.0);
    heli.state.vel_body_mps = heli.state.att.inverse() * Vector3::new(0.0, 0.0, sink_mps);
    while sim.advance(6_000_000) {}
    sim
}

#[test]
fn a_hard_landing_is_a_crash() {
    let sim = dropped(1.0, 5.0, 0.0);
    let why = sim.crash().unwrap_or_else(|| panic!("no crash"));
    assert!(why.contains("hit the ground"), "{why}");
}

#[test]
fn tipping_over_on_the_ground_is_a_crash() {
    let sim = dropped(0.3, 0.0, 1.3);
    let why = sim.crash().unwrap_or_else(|| panic!("no crash"));
    assert!(why.contains("rolled over"), "{why}");
}

#[test]
fn a_gentle_touchdown_settles_on_the_skids() {
    let sim = dropped(0.5, 0.5, 0.05);
    assert_eq!(sim.crash(), None);
    let h = sim.helicopter();
    assert_eq!(h.outputs.contact_points, 4);
    assert!(
        h.state.vel_ned_mps().norm() < 0.05,
        "{:?}",
        h.state.vel_ned_mps()
    );
    let (roll, pitch, _) = h.state.att.euler_angles();
    assert!(roll.abs() < 0.02 && pitch.abs() < 0.02, "{roll} {pitch}");
}
