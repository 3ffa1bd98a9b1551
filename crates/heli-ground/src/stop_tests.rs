//! Stop in the air and Kill at the station: a Stop the vehicle answers "landing first" saves
//! the flight's log only once the flight has ended on the ground; a kill is sent only when the
//! operator confirmed it.

use std::path::PathBuf;

use heli_link::GroundCommand;
use heli_link::status::BootstrapState;

use crate::panel::PanelState;
use crate::station_tests::{Bench, flying_telemetry};

fn flying() -> (Bench, u64) {
    let mut b = Bench::new();
    let op = b.flying_operator("f1", "autonomous");
    b.telemetry = Some(flying_telemetry("hold"));
    b.run(1.0);
    (b, op)
}

#[test]
fn a_stop_in_the_air_saves_the_log_once_the_flight_has_landed() {
    let (mut b, op) = flying();
    b.land_first = true;
    b.ask(
        op,
        r#"{"seq":4,"op":"stop","base_dir":"day1","suffix":"mine"}"#,
    )
    .unwrap();
    b.run(3.0);
    let said = b.messages();
    assert!(said.contains("lands where it is first"), "{said}");
    assert!(b.saved.is_empty(), "saved while still landing");
    let v = b.station.view(b.t);
    assert_eq!(v.panel.state, PanelState::Stopping);
    assert!(v.panel.kill, "Kill stays at hand while it lands");
    // On the skids: the flight ends, and its log is saved where the Stop said.
    b.state = BootstrapState::Idle;
    b.telemetry = None;
    b.run(5.0);
    let said = b.messages();
    assert!(said.contains("stop: landed; the flight ended"), "{said}");
    assert_eq!(b.saved.len(), 1, "{said}");
    assert_eq!(b.saved[0].0, PathBuf::from("/ground/day1/flight_mine.mcap"));
    assert!(!said.contains("without Stop"), "{said}");
}

#[test]
fn a_kill_is_sent_only_when_confirmed() {
    let (mut b, op) = flying();
    let e = b.ask(op, r#"{"seq":4,"op":"kill"}"#).unwrap_err();
    assert!(
        e.contains("kill not confirmed") && e.contains("falls"),
        "{e}"
    );
    let e = b
        .ask(op, r#"{"seq":5,"op":"kill","confirmed":false}"#)
        .unwrap_err();
    assert!(e.contains("kill not confirmed"), "{e}");
    assert!(!b.commands.contains(&GroundCommand::Kill));
    b.ask(op, r#"{"seq":6,"op":"kill","confirmed":true}"#)
        .unwrap();
    b.run(1.0);
    assert!(b.commands.contains(&GroundCommand::Kill));
    // Nothing to kill when idle: the button is not active.
    b.run(2.0);
    let e = b
        .ask(op, r#"{"seq":7,"op":"kill","confirmed":true}"#)
        .unwrap_err();
    assert!(e.contains("Kill is not active"), "{e}");
}
