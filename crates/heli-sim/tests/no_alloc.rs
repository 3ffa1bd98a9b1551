//! The flight computer (drivers and main control process) does not allocate once it is flying: the 50 Hz step, the
//! watchdog, and the GPS fusion that rolls the filter back and replays the last second all
//! run in memory taken at start-up. Counted (`allocation-counter`, which installs a counting
//! global allocator in this test binary) on a flight computer replaying a simulated hover's inputs.

use heli_fsw::{Action, FlightComputer, Phase};
use heli_scenario as scenario;
use heli_sim::Simulation;

#[test]
fn the_flying_control_process_does_not_allocate() {
    let mut sim = Simulation::new(scenario::hover()).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    while sim.advance(140_000_000) {}
    let recording = sim.recording().cloned().unwrap_or_default();
    let (config, params) = sim.flight_software_setup();

    let mut computer = FlightComputer::new(config, params, heli_proto::baro::DEFAULT_RATE_HZ);
    computer.start(0, &mut |_, _| {});
    let mut out: Vec<Action> = Vec::with_capacity(64);
    let settle_us = 110_000_000;
    let split = recording
        .inputs
        .iter()
        .position(|(t_us, _)| *t_us >= settle_us)
        .unwrap_or(recording.inputs.len());
    let (before, after) = recording.inputs.split_at(split);
    for (t_us, input) in before {
        computer.receive(*t_us, input.as_input(), &mut |_, _| {}, &mut out);
        out.clear();
    }
    let core = computer.core();
    assert!(
        matches!(core.phase(), Phase::Holding { .. }),
        "{:?}",
        core.phase()
    );
    let start = core.stats();
    let counted = allocation_counter::measure(|| {
        for (t_us, input) in after {
            computer.receive(*t_us, input.as_input(), &mut |_, _| {}, &mut out);
            out.clear();
        }
    });
    let stats = computer.core().stats();
    // 30 s of hover: 1500 control steps and 30 GPS fixes, each replaying the filter.
    assert!(
        stats.control_steps - start.control_steps > 1400,
        "{stats:?}"
    );
    assert!(stats.gps_fixes - start.gps_fixes > 25, "{stats:?}");
    assert_eq!(counted.count_total, 0, "{counted:?}");
}

#[test]
fn the_calibration_window_does_not_allocate_once_it_is_open() {
    // Judging each second against the window's median and keeping its seconds is done in
    // buffers taken when the flight computer is made, not once a second on the skids.
    let mut sim = Simulation::new(scenario::hover()).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    while sim.advance(80_000_000) {}
    let recording = sim.recording().cloned().unwrap_or_default();
    let (config, params) = sim.flight_software_setup();

    let mut computer = FlightComputer::new(config, params, heli_proto::baro::DEFAULT_RATE_HZ);
    computer.start(0, &mut |_, _| {});
    let mut out: Vec<Action> = Vec::with_capacity(64);
    let split = recording
        .inputs
        .iter()
        .position(|(t_us, _)| *t_us >= 10_000_000)
        .unwrap_or(recording.inputs.len());
    let (before, after) = recording.inputs.split_at(split);
    for (t_us, input) in before {
        computer.receive(*t_us, input.as_input(), &mut |_, _| {}, &mut out);
        out.clear();
    }
    assert_eq!(computer.core().phase(), Phase::Calibrating);
    let counted = allocation_counter::measure(|| {
        for (t_us, input) in after {
            computer.receive(*t_us, input.as_input(), &mut |_, _| {}, &mut out);
            out.clear();
        }
    });
    assert_eq!(
        computer.core().phase(),
        Phase::Calibrating,
        "still in the window"
    );
    assert!(computer.core().stats().imu_samples > 7000);
    assert_eq!(counted.count_total, 0, "{counted:?}");
}
