//! Replay: the flight computer (drivers and core) is a pure function of its device inputs.
//! Record every byte, ADC reading and tick a simulated flight gave it, feed them to a fresh
//! flight computer, and it must take the same actions, bit for bit
//! — the property that lets a recorded flight be replayed against new code.

use heli_fsw::FlightComputer;
use heli_scenario as scenario;
use heli_sim::Simulation;

#[test]
fn a_fresh_core_fed_the_recorded_inputs_takes_the_same_actions() {
    let mut s = scenario::rolls();
    s.faults.imu_drop_rate = 0.01;
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    // Through calibration, take-off and the first roll.
    while sim.advance(125_000_000) {}
    let recording = sim.recording().cloned().unwrap_or_default();
    assert!(recording.inputs.len() > 20_000);
    assert!(recording.actions.iter().any(|a| matches!(a, heli_fsw::Action::Event(e) if matches!(e.value, heli_fsw::core::CoreEvent::RollCompleted(1)))));

    let (config, params) = sim.flight_software_setup();
    let mut computer = FlightComputer::new(config, params, heli_proto::baro::DEFAULT_RATE_HZ);
    computer.start(0, &mut |_, _| {});
    let mut actions = Vec::new();
    for (t_us, input) in &recording.inputs {
        computer.receive(*t_us, input.as_input(), &mut |_, _| {}, &mut actions);
    }
    assert_eq!(actions.len(), recording.actions.len());
    // PartialEq on f64 fields: bit-for-bit equal numbers (no NaNs flow through).
    let first_difference = actions
        .iter()
        .zip(&recording.actions)
        .position(|(a, b)| a != b);
    assert_eq!(first_difference, None);
    assert_eq!(computer.core().stats(), sim.core().stats());
    assert_eq!(computer.core().health(), sim.core().health());
}
