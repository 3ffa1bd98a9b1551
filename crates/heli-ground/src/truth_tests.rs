//! The display never contradicts the vehicle: standing refusals, the command's outcome, the
//! flight's own parameters on every page, refusals known before Start Logging is sent, and
//! the message area by severity.

use mavlink::dialects::common::MavSeverity;

use crate::panel::PanelState;
use crate::station_tests::{Bench, flying_telemetry};

#[test]
fn a_refused_take_off_stands_in_the_header_and_the_verdict_until_the_phase_moves_on() {
    let mut b = Bench::new();
    b.flying_operator("r1", "autonomous");
    // The vehicle refused the take-off; then every condition became good again (the
    // satellites came back), but the refusal stands until the auto switch is cycled.
    b.vehicle.status_text(
        MavSeverity::MAV_SEVERITY_WARNING,
        "flight: event warning-hi t=31.00 s take-off refused: 4 satellites, fewer than 5",
        b.t,
    );
    b.telemetry = Some(flying_telemetry("takeoff-refused"));
    b.run(2.0);
    let v = b.station.view(b.t);
    assert_eq!(v.vehicle.phase, Some("takeoff-refused"));
    let standing = v.vehicle.standing.clone().unwrap_or_default();
    assert!(
        standing.contains("take-off refused: 4 satellites") && standing.contains("auto switch"),
        "{standing}"
    );
    assert!(!v.safety.automatic.allowed, "never safe while refused");
    assert_eq!(
        v.safety.automatic.refused_by_vehicle.as_deref(),
        Some(standing.as_str())
    );
    // The pilot cycled the switch and the vehicle flies the take-off: nothing stands.
    b.telemetry = Some(flying_telemetry("takeoff"));
    b.run(1.0);
    let v = b.station.view(b.t);
    assert!(v.vehicle.standing.is_none());
    assert!(v.safety.automatic.refused_by_vehicle.is_none());
}

#[test]
fn a_mode_refused_in_the_air_stands_while_the_pilot_flies_manual_with_the_switch_on() {
    let mut b = Bench::new();
    b.flying_operator("m1", "velocity");
    b.vehicle.status_text(
        MavSeverity::MAV_SEVERITY_WARNING,
        "flight: event warning-hi t=90.00 s velocity flight refused: fewer than 5 satellites",
        b.t,
    );
    b.telemetry = Some(flying_telemetry("manual"));
    b.run(2.0);
    let v = b.station.view(b.t);
    let standing = v.vehicle.standing.clone().unwrap_or_default();
    assert!(
        standing.starts_with("the vehicle flies manual: velocity flight refused"),
        "{standing}"
    );
    assert!(!v.safety.augmented.allowed);
    // The switch taken off: the pilot flies manual by choice, nothing is refused.
    if let Some(t) = b.telemetry.as_mut()
        && let Some(u) = t.uplink.as_mut()
    {
        u.auto_mode = false;
    }
    b.run(1.0);
    assert!(b.station.view(b.t).vehicle.standing.is_none());
}

#[test]
fn a_refused_start_says_the_vehicles_reason_and_the_suffix_is_refused_up_front_next_time() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.refuse_start = Some(
        "a log flight_d1.mcap exists already in /var/log/heli (a log is never replaced): choose another suffix"
            .into(),
    );
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"d1","controller":"manual"}"#,
    )
    .unwrap();
    assert_eq!(b.station.view(b.t).command.map(|c| c.outcome), Some("sent"));
    b.run(1.0);
    let v = b.station.view(b.t);
    let c = v.command.clone().unwrap();
    assert_eq!((c.name, c.outcome), ("start logging", "refused"));
    assert!(
        c.text.contains("flight_d1.mcap exists already"),
        "{}",
        c.text
    );
    assert!(
        b.messages()
            .contains("start logging: failed: a log flight_d1.mcap exists"),
        "{}",
        b.messages()
    );
    // The display is reset with Stop, and the vehicle, still connected, is not told.
    assert_eq!(v.panel.state, PanelState::LoggingFailed);
    let sent = b.commands.len();
    assert_eq!(
        b.ask(op, r#"{"seq":4,"op":"stop"}"#).unwrap(),
        "display reset"
    );
    b.run(1.0);
    assert_eq!(b.commands.len(), sent);
    assert_eq!(b.panel(), PanelState::Connected);
    // The same suffix again is refused before it is sent, as the check says while typing.
    b.refuse_start = None;
    let check = b
        .ask(
            op,
            r#"{"seq":5,"op":"check-start","suffix":"d1","controller":"manual"}"#,
        )
        .unwrap_err();
    assert!(check.contains("flight_d1.mcap already"), "{check}");
    let e = b
        .ask(
            op,
            r#"{"seq":6,"op":"start","suffix":"d1","controller":"manual"}"#,
        )
        .unwrap_err();
    assert!(e.contains("choose another suffix"), "{e}");
    assert_eq!(b.commands.len(), sent, "nothing sent");
    let ok = b
        .ask(
            op,
            r#"{"seq":7,"op":"check-start","suffix":"d2","controller":"manual"}"#,
        )
        .unwrap();
    assert_eq!(ok, "Start Logging would send flight_d2");
    assert!(
        !b.messages().contains("check"),
        "a check is the page's question, not a message: {}",
        b.messages()
    );
}

#[test]
fn every_page_shows_the_flight_s_own_parameters_while_it_flies() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"p1","controller":"autonomous","plan":"rolls"}"#,
    )
    .unwrap();
    b.run(1.0);
    let f = b.station.view(b.t).flight.unwrap();
    assert_eq!(
        (f.suffix.as_str(), f.controller, f.plan.as_str()),
        ("p1", "autonomous", "rolls")
    );
    b.ask(op, r#"{"seq":4,"op":"stop"}"#).unwrap();
    b.run(1.0);
    assert!(b.station.view(b.t).flight.is_none());
}

#[test]
fn an_autonomous_start_is_told_what_the_take_off_would_wait_for() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    // Telemetry of a vehicle on the ground with too few satellites.
    let mut t = flying_telemetry("manual");
    if let Some(g) = t.gps.as_mut() {
        g.satellites = 3;
    }
    b.telemetry = Some(t);
    b.run(1.0);
    let ok = b
        .ask(
            op,
            r#"{"seq":3,"op":"check-start","suffix":"w1","controller":"autonomous"}"#,
        )
        .unwrap();
    assert!(
        ok.contains("the take-off would wait: fewer than 5 satellites"),
        "{ok}"
    );
    let manual = b
        .ask(
            op,
            r#"{"seq":4,"op":"check-start","suffix":"w1","controller":"manual"}"#,
        )
        .unwrap();
    assert!(!manual.contains("wait"), "{manual}");
}

#[test]
fn fatal_events_stay_pinned_through_a_flood_of_notices_until_acknowledged() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.vehicle.status_text(
        MavSeverity::MAV_SEVERITY_CRITICAL,
        "flight: event fatal t=5.00 s imu silent",
        b.t,
    );
    b.run(0.5);
    // A minute of device notices, five a second.
    for k in 0..300u32 {
        let (sev, text) = if k % 2 == 0 {
            (MavSeverity::MAV_SEVERITY_NOTICE, "imu late")
        } else {
            (MavSeverity::MAV_SEVERITY_INFO, "imu ok")
        };
        b.vehicle.status_text(
            sev,
            &format!(
                "flight: event warning-lo t={:.2} s {text}",
                6.0 + f64::from(k) * 0.2
            ),
            b.t,
        );
        b.run(0.2);
    }
    let v = b.station.view(b.t);
    assert_eq!(v.pinned.len(), 1, "{:?}", v.pinned);
    assert!(v.pinned[0].text.contains("imu silent"));
    let late = v
        .messages
        .iter()
        .find(|m| m.text.contains("imu late"))
        .unwrap();
    assert!(late.count >= 140, "collapsed: {}", late.count);
    let rate = late.rate_hz.unwrap_or(0.0);
    assert!((2.0..3.0).contains(&rate), "{rate}");
    // A page opened now gets the fatal line, however many notices came after.
    assert!(
        b.station
            .message_history()
            .iter()
            .any(|m| m.text.contains("imu silent"))
    );
    // A watching page cannot acknowledge; the operator in control can.
    let watcher = b.station.join();
    let upto = v.pinned[0].seq;
    let json = format!(r#"{{"seq":1,"op":"acknowledge-messages","upto":{upto}}}"#);
    assert!(b.ask(watcher, &json).is_err());
    let json = format!(r#"{{"seq":3,"op":"acknowledge-messages","upto":{upto}}}"#);
    assert!(b.ask(op, &json).unwrap().contains("acknowledged 1"));
    assert!(b.station.view(b.t).pinned.is_empty());
}

#[test]
fn a_condition_never_read_says_so_rather_than_blaming_the_battery() {
    let mut b = Bench::new();
    b.connected_operator();
    let v = b.station.view(b.t);
    let battery = v
        .safety
        .conditions
        .iter()
        .find(|c| c.name == "battery")
        .unwrap();
    assert_eq!(battery.why.as_deref(), Some("no battery reading yet"));
    assert!(
        !v.safety.augmented.failing.contains("down to a third"),
        "{}",
        v.safety.augmented.failing
    );
}

#[test]
fn a_flight_that_ends_without_stop_is_saved_all_the_same() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"crash1","controller":"autonomous"}"#,
    )
    .unwrap();
    b.run(2.0);
    // Stopped on the vehicle (in `heli sim --ui`: the simulated helicopter crashed and the
    // flight was stopped there), not by this station.
    b.state = heli_link::status::BootstrapState::Idle;
    b.telemetry = None;
    b.run(8.0);
    assert_eq!(b.saved.len(), 1, "{}", b.messages());
    assert_eq!(
        b.saved[0].0,
        std::path::PathBuf::from("/ground/flight_crash1.mcap")
    );
    assert_eq!(b.saved[0].1, b.store.logs[0].1);
    let said = b.messages();
    assert!(said.contains("ended on the vehicle without Stop"), "{said}");
    assert!(
        said.contains("log saved: /ground/flight_crash1.mcap"),
        "{said}"
    );
    let v = b.station.view(b.t);
    assert_eq!(v.panel.state, PanelState::Idle);
    assert!(v.flight.is_none());
    // Once only.
    b.run(5.0);
    assert_eq!(b.saved.len(), 1);
}

#[test]
fn the_gps_row_has_posn_pose_from_the_estimates_origin_and_ages_by_its_fix() {
    let mut b = Bench::new();
    b.flying_operator("g1", "manual");
    let mut t = flying_telemetry("manual");
    t.origin = Some([42.36, -71.09, 10.0]);
    if let Some(g) = t.gps.as_mut() {
        g.lat_deg = 42.3601;
    }
    b.telemetry = Some(t.clone());
    b.run(1.0);
    let v = b.station.view(b.t);
    let gps = v.rows.gps.clone().unwrap();
    let cell = |label: &str| {
        gps.cells
            .iter()
            .find(|c| c.label == label)
            .map(|c| c.value.clone())
            .unwrap_or_default()
    };
    let north: f64 = cell("PosN m").parse().unwrap();
    assert!((north - 11.1).abs() < 0.2, "{north}");
    assert_eq!(cell("PosE m"), "0.0");
    assert_eq!(cell("Lat °"), "42.3601000");
    assert!(v.gps.as_ref().is_some_and(|g| g.ok && !g.stale));
    // The vehicle's last fix is 1.4 s old (the GPS fell silent; its watchdog has not said
    // so yet): the lamp leaves green on the fix's age, with that age.
    if let Some(g) = t.gps.as_mut() {
        g.age_s = 1.4;
    }
    b.telemetry = Some(t);
    b.run(0.5);
    let lamp = b.station.view(b.t).gps.unwrap();
    assert!(lamp.stale && !lamp.ok, "{lamp:?}");
    assert!((1.3..1.9).contains(&lamp.age_s), "{lamp:?}");
}

#[test]
fn a_new_flight_s_gps_lamp_is_not_green_on_the_last_flight_s_fix() {
    let mut b = Bench::new();
    b.flying_operator("g1", "manual");
    b.telemetry = Some(flying_telemetry("manual"));
    b.run(1.0);
    assert!(b.station.view(b.t).gps.is_some_and(|g| g.ok && !g.stale));
    // The flight ends and the next one begins at once: the new flight process has no fix
    // (nor any telemetry) yet, and the last flight's fix is still under its age limit.
    b.state = heli_link::status::BootstrapState::Idle;
    b.telemetry = None;
    b.run(0.05);
    b.state = heli_link::status::BootstrapState::Starting;
    b.run(0.05);
    b.state = heli_link::status::BootstrapState::Flying;
    b.run(0.1);
    let lamp = b.station.view(b.t).gps.unwrap();
    assert!(lamp.stale && !lamp.ok, "{lamp:?}");
}
