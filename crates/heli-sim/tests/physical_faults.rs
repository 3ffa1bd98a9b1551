//! Faults outside the devices act on the helicopter and the pilot's link: the engine, the
//! servos, the receiver's channels and switches, the wind.

use heli_fsw::RecordedInput;
use heli_proto::scb::{PilotUplink, UplinkFramer};
use heli_scenario::faults::{
    EngineFault, FrozenChannel, RcChannel, ServoFault, ServoFaultKind, Switch, SwitchFlicker,
    WindChange, WindShape,
};
use heli_scenario::{self as scenario, Channel as ServoChannel, Scenario};
use heli_sim::Simulation;
use heli_types::Port;

fn fly(s: Scenario, until_s: f64) -> Simulation {
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    while sim.advance((until_s * 1e6) as u64) {}
    sim
}

/// The uplink packets the computer received from `from_s` to `to_s`.
fn uplinks(sim: &Simulation, from_s: f64, to_s: f64) -> Vec<PilotUplink> {
    let mut framer = UplinkFramer::new();
    let window = (from_s * 1e6) as u64..(to_s * 1e6) as u64;
    let mut out = Vec::new();
    for (t, input) in &sim.recording().unwrap_or_else(|| panic!("recorded")).inputs {
        if let RecordedInput::Bytes(Port::Scb, bytes) = input {
            for &b in bytes {
                if let Some(frame) = framer.push(b)
                    && window.contains(t)
                    && let Ok(p) = PilotUplink::parse(frame)
                {
                    out.push(p);
                }
            }
        }
    }
    out
}

fn rotor_rpm(sim: &Simulation) -> f64 {
    sim.helicopter().state.rotor_rps * 30.0 / std::f64::consts::PI
}

#[test]
fn an_engine_failure_stops_the_governor_holding_the_rotor() {
    let healthy = fly(scenario::hover(), 113.0);
    let mut s = scenario::hover();
    s.faults.engine = vec![EngineFault {
        start_s: 110.0,
        end_s: 1000.0,
        power: 0.0,
    }];
    let failed = fly(s, 113.0);
    assert!(
        (rotor_rpm(&healthy) - 1600.0).abs() < 40.0,
        "{}",
        rotor_rpm(&healthy)
    );
    assert!(
        rotor_rpm(&failed) < 0.8 * 1600.0,
        "{} rpm three seconds after the engine quit",
        rotor_rpm(&failed)
    );
    assert_eq!(failed.helicopter().outputs.engine_torque_nm, 0.0);
}

#[test]
fn an_engine_failure_in_the_air_is_raised_and_answered_by_an_autorotation() {
    // The rotor falls through 95 % of its governed speed at about 800 rpm/s some 0.1 s
    // after the engine quits: the flight software raises the failure and autorotates.
    // (From this 10 m hover it does not yet land softly: docs/autorotation.md.)
    let mut s = scenario::hover();
    s.faults.engine = vec![EngineFault {
        start_s: 110.0,
        end_s: 1000.0,
        power: 0.0,
    }];
    let summary = heli_sim::run(s).unwrap_or_else(|e| panic!("{e}"));
    let at = |text: &str| {
        summary
            .events
            .iter()
            .find(|e| e.contains(text))
            .and_then(|e| {
                e.trim_start_matches("t=")
                    .split(' ')
                    .next()?
                    .parse::<f64>()
                    .ok()
            })
    };
    let failure = at("engine failure: rotor at").unwrap_or_else(|| panic!("{:?}", summary.events));
    assert!((110.0..110.3).contains(&failure), "raised at {failure} s");
    let phase = at("phase autorotation").unwrap_or_else(|| panic!("{:?}", summary.events));
    assert!((failure..failure + 0.05).contains(&phase), "{phase} s");
}

#[test]
fn an_engine_losing_part_of_its_power_is_found_when_the_rotor_stays_low() {
    // At 40 % of full power the engine gives 800 W against the hover's 1100: the rotor
    // slows too gently for the falling rule, and is found once below 85 % for 0.1 s.
    let mut s = scenario::hover();
    s.faults.engine = vec![EngineFault {
        start_s: 110.0,
        end_s: 1000.0,
        power: 0.4,
    }];
    let summary = heli_sim::run(s).unwrap_or_else(|e| panic!("{e}"));
    let failure = summary
        .events
        .iter()
        .find(|e| e.contains("engine failure: rotor at"))
        .unwrap_or_else(|| panic!("{:?}", summary.events));
    let t: f64 = failure
        .trim_start_matches("t=")
        .split(' ')
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or(f64::NAN);
    assert!((110.4..115.0).contains(&t), "{failure}");
    let rpm: f64 = failure
        .split("rotor at ")
        .nth(1)
        .and_then(|r| r.split(' ').next()?.parse().ok())
        .unwrap_or(f64::NAN);
    assert!(rpm < 0.85 * 1600.0, "{failure}");
}

#[test]
fn the_rotor_droop_of_the_rolls_is_no_engine_failure() {
    // The rolls pump the collective and the governor lets the rotor droop to about 91 %.
    let summary = heli_sim::run(scenario::demo()).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        !summary.events.iter().any(|e| e.contains("engine failure")),
        "{:?}",
        summary.events
    );
    assert_eq!(summary.crash, None);
}

#[test]
fn a_stuck_servo_stays_where_it_was() {
    let mut s = scenario::hover();
    s.faults.servos = vec![ServoFault {
        channel: ServoChannel::Aileron,
        kind: ServoFaultKind::Stuck,
        start_s: 110.0,
        end_s: 112.0,
        factor: 0.0,
    }];
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    while sim.advance(110_000_000) {}
    let stuck_at = sim.servo_positions().aileron;
    let mut moved = 0.0_f64;
    let mut healthy = 0.0_f64;
    while sim.advance(114_000_000) {
        let d = (sim.servo_positions().aileron - stuck_at).abs();
        if sim.now_us() < 112_000_000 {
            moved = moved.max(d);
        } else {
            healthy = healthy.max(d);
        }
    }
    assert_eq!(moved, 0.0, "stuck for two seconds");
    assert!(healthy > 0.0, "moves again after");
}

#[test]
fn a_frozen_receiver_channel_holds_its_value() {
    // The augmented flight steps the collective stick up at 86 s; frozen from 85 to 90 s
    // the receiver keeps reporting where it was.
    let mut s = scenario::augmented();
    s.faults.rc_frozen = vec![FrozenChannel {
        channel: RcChannel::Collective,
        start_s: 85.0,
        end_s: 90.0,
    }];
    let frozen = fly(s, 92.0);
    let collective = |from, to| {
        uplinks(&frozen, from, to)
            .iter()
            .filter_map(|p| p.sticks())
            .map(|c| c.collective)
            .collect::<Vec<f64>>()
    };
    let during = collective(85.1, 90.0);
    let after = collective(90.1, 92.0);
    assert!(during.len() > 200);
    assert!(during.windows(2).all(|w| w[0] == w[1]), "frozen");
    assert!(
        after.iter().all(|c| *c > during[0] + 0.3),
        "the step shows after"
    );
}

#[test]
fn a_flickering_auto_switch_flickers_on_the_uplink() {
    let mut s = scenario::hover();
    s.faults.switch_flicker = vec![SwitchFlicker {
        switch: Switch::Auto,
        start_s: 110.0,
        end_s: 114.0,
        period_s: 1.0,
    }];
    let sim = fly(s, 115.0);
    let auto: Vec<bool> = uplinks(&sim, 109.0, 115.0)
        .iter()
        .map(|p| p.auto_mode)
        .collect();
    let changes = auto.windows(2).filter(|w| w[0] != w[1]).count();
    assert_eq!(changes, 8, "two changes a second for four seconds");
}

#[test]
fn a_gust_pushes_the_hovering_helicopter() {
    let drift = |gust: bool| {
        let mut s = scenario::hover();
        if gust {
            s.wind_changes = vec![WindChange {
                shape: WindShape::Gust,
                start_s: 110.0,
                end_s: 113.0,
                wind_ned_mps: [0.0, 8.0, 0.0],
            }];
        }
        let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
        while sim.advance(110_000_000) {}
        let start = sim.helicopter().state.pos_ned_m;
        let mut east = 0.0_f64;
        while sim.advance(113_000_000) {
            east = east.max(sim.helicopter().state.pos_ned_m.y - start.y);
        }
        east
    };
    let (calm, gusty) = (drift(false), drift(true));
    assert!(gusty > calm + 0.3, "pushed east {gusty} m against {calm} m");
}

#[test]
fn a_live_transmitter_reaches_the_computer_through_the_receiver_and_its_faults() {
    use heli_proto::scb::Controls;
    use heli_sim::devices::scb::PilotCommand;
    // A person's sticks (heli hilsim --pilot) replace the scenario's, in the uplink bytes;
    // a lost transmitter fault still takes the signal away. (On the ground, collective
    // down: the computer is still calibrating.)
    let mut s = scenario::hover();
    s.faults.transmitter_lost = vec![[20.0, 21.0]];
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    sim.set_live_pilot(Some(PilotCommand {
        sticks: Controls {
            aileron: 0.5,
            elevator: -0.25,
            rudder: 0.0,
            collective: -0.5,
            throttle: 0.8,
        },
        auto_mode: false,
        bypass: false,
        signal_lost: false,
    }));
    while sim.advance(22_000_000) {}
    let live = uplinks(&sim, 10.0, 19.9);
    assert!(
        live.len() > 50,
        "{} uplinks, {} in all",
        live.len(),
        uplinks(&sim, 0.0, 100.0).len()
    );
    for p in &live {
        let sticks = p.sticks().unwrap_or_else(|| panic!("{p:?}"));
        assert!((sticks.aileron - 0.5).abs() < 0.01, "{sticks:?}");
        assert!((sticks.elevator + 0.25).abs() < 0.01, "{sticks:?}");
        assert!(!p.auto_mode && !p.bypass, "{p:?}");
    }
    assert!(
        uplinks(&sim, 20.1, 20.9)
            .iter()
            .all(|p| p.sticks().is_none()),
        "the signal is lost from 20 to 21 s"
    );
    sim.set_live_pilot(None);
    while sim.advance(24_000_000) {}
    assert!(
        uplinks(&sim, 22.1, 23.9).iter().all(|p| p.auto_mode),
        "the script's again"
    );
}
