//! Each kind of injected fault acts where the flight computer can see it: in the bytes its
//! drivers receive.

use heli_fsw::RecordedInput;
use heli_scenario::{self as scenario, ByteLoss, ForcedSatellites, GpsGlitch, Scenario};
use heli_sim::Simulation;
use heli_types::Port;

/// Flies `s` to `until_s` recording the flight computer's inputs.
fn fly(s: Scenario, until_s: f64) -> Simulation {
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    while sim.advance((until_s * 1e6) as u64) {}
    sim
}

fn events(sim: &Simulation) -> String {
    sim.events().join("\n")
}

#[test]
fn a_stuck_imu_repeats_its_packet_byte_for_byte() {
    let mut s = scenario::hover();
    s.faults.imu_stuck = vec![[100.0, 101.0]];
    let sim = fly(s, 101.0);
    let inputs = &sim.recording().unwrap_or_else(|| panic!("recorded")).inputs;
    let imu: Vec<&Vec<u8>> = inputs
        .iter()
        .filter(|(t, _)| (100_050_000..101_000_000).contains(t))
        .filter_map(|(_, i)| match i {
            RecordedInput::Bytes(Port::Imu, b) => Some(b),
            _ => None,
        })
        .collect();
    assert!(imu.len() > 80, "{}", imu.len());
    assert!(
        imu.windows(2).all(|w| w[0] == w[1]),
        "the same bytes, packet after packet"
    );
}

#[test]
fn a_gps_glitch_jumps_the_reported_position_and_is_refused_on_board() {
    let mut s = scenario::hover();
    s.faults.gps_glitches = vec![GpsGlitch {
        start_s: 120.0,
        end_s: 123.0,
        north_m: 300.0,
        east_m: 0.0,
    }];
    let sim = fly(s, 130.0);
    let text = events(&sim);
    assert!(text.contains("GPS fix refused: jumped 3"), "{text}");
    assert!(sim.core().stats().gps_implausible >= 2);
}

#[test]
fn a_forced_satellite_count_reaches_the_filter() {
    let mut s = scenario::hover();
    s.faults.gps_satellites = vec![ForcedSatellites {
        start_s: 110.0,
        end_s: 120.0,
        satellites: 3,
    }];
    let before = fly(scenario::hover(), 125.0);
    let after = fly(s, 125.0);
    let rejected = |sim: &Simulation| sim.core().navigator().stats().gps_rejected;
    // Three satellites are too few for the filter (it wants four): ten fixes refused.
    assert!(
        rejected(&after) >= rejected(&before) + 9,
        "{} vs {}",
        rejected(&after),
        rejected(&before)
    );
    assert!(events(&after).contains("GPS lost"), "{}", events(&after));
}

#[test]
fn lost_serial_bytes_break_frames_and_the_watchdog_sees_it() {
    let mut s = scenario::hover();
    s.faults.byte_loss = vec![ByteLoss {
        port: "imu".into(),
        start_s: 100.0,
        end_s: 110.0,
        rate: 0.05,
    }];
    let sim = fly(s, 111.0);
    assert!(sim.bytes_lost() > 500, "{}", sim.bytes_lost());
    let imu = sim.computer().drivers().imu.stats().framer;
    assert!(imu.checksum_errors + imu.framing_errors > 50, "{imu:?}");
    assert!(sim.core().stats().watchdog_fires > 50);
}

#[test]
fn a_fault_on_an_unknown_port_is_refused_when_loaded() {
    let e = scenario::from_toml(
        "[[faults.byte_loss]]\nport = \"radio\"\nstart_s = 1.0\nend_s = 2.0\nrate = 0.1\n",
    )
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(e.contains("faults.byte_loss[0].port"), "{e}");
}

#[test]
fn a_wrong_reading_the_gate_refuses_is_raised_and_its_return_too() {
    // An altimeter reading 30 m high and a compass field turned around for 10 s each: the
    // readings arrive (the watchdogs see healthy devices) but the filter's gate refuses them.
    // That is an event after 3 s, and another when the aid is fused again.
    use heli_scenario::faults::{Device, DeviceFault, DeviceFaultKind};
    let wrong = |device, kind, value, start_s: f64| DeviceFault {
        device,
        kind,
        start_s,
        end_s: start_s + 10.0,
        value,
        rate: 0.0,
        period_s: 0.0,
        duty: 1.0,
    };
    let mut s = scenario::hover();
    s.faults.devices = vec![
        wrong(Device::Baro, DeviceFaultKind::Bias, 30.0, 110.0),
        wrong(Device::Compass, DeviceFaultKind::Scale, -1.0, 130.0),
    ];
    let sim = fly(s, 150.0);
    let text = events(&sim);
    for (aid, from_s, to_s) in [("altimeter", 112.5, 115.0), ("compass", 132.5, 135.0)] {
        let refused = sim
            .events()
            .iter()
            .find(|e| e.contains(&format!("{aid} refused by the filter")))
            .unwrap_or_else(|| panic!("no {aid} refusal in\n{text}"))
            .clone();
        let t: f64 = refused[2..refused.find(" s").unwrap_or(2)]
            .parse()
            .unwrap_or_else(|e| panic!("{refused}: {e}"));
        assert!((from_s..to_s).contains(&t), "{refused}");
        assert!(
            text.contains(&format!("{aid} fused again")),
            "{aid} never fused again:\n{text}"
        );
    }
}

#[test]
fn a_clean_flight_never_reports_a_refused_aid() {
    let sim = fly(scenario::demo(), 260.0);
    let text = events(&sim);
    assert!(!text.contains("refused by the filter"), "{text}");
}
