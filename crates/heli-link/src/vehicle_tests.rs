//! The vehicle's link against the ground's, datagram by datagram, with no sockets.

use super::*;
use crate::command::command_long;
use crate::ground::GroundLink;
use crate::logs::MemoryStore;
use crate::messages::StartParameters;
use crate::telemetry::{ImuRow, StateRow};

const T0: u64 = 1_763_900_000_000_000;

fn store() -> MemoryStore {
    MemoryStore {
        logs: vec![(
            "flight_a.mcap".into(),
            (0..20_000u32).map(|i| (i * 7 % 251) as u8).collect(),
        )],
    }
}

fn telemetry() -> Telemetry {
    Telemetry {
        imu: Some(ImuRow::default()),
        state: Some(StateRow::default()),
        ..Telemetry::default()
    }
}

/// Runs both ends for `steps` of 10 ms, carrying datagrams both ways; `drop` decides from a
/// counter whether a datagram is lost.
fn run(
    vehicle: &mut VehicleLink,
    ground: &mut GroundLink,
    t: &mut u64,
    steps: u32,
    drop: &mut dyn FnMut() -> bool,
    events: &mut Vec<LinkEvent>,
) {
    let s = store();
    for _ in 0..steps {
        *t += 10_000;
        let status = VehicleStatus::default();
        events.extend(vehicle.tick(*t, status, Some(&telemetry()), &s));
        for d in vehicle.take_outgoing() {
            if !drop() {
                ground.receive(&d, *t);
            }
        }
        let mut up = Vec::new();
        if t.is_multiple_of(1_000_000) {
            up.push(ground.heartbeat_frame(*t));
        }
        up.extend(ground.download_tick(*t));
        for d in up {
            if !drop() {
                events.extend(vehicle.receive(&d, *t, &s));
            }
        }
    }
}

fn never() -> impl FnMut() -> bool {
    || false
}

#[test]
fn heartbeats_and_telemetry_arrive_at_their_rates() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let (mut t, mut ev) = (T0, Vec::new());
    run(&mut v, &mut g, &mut t, 300, &mut never(), &mut ev);
    // 3 s: 3 heartbeats, about 9 attitudes (3 Hz).
    let hb = g.counts[&HEARTBEAT_DATA::ID];
    let att = g.counts[&ATTITUDE_DATA::ID];
    assert!((3..=4).contains(&hb), "{hb}");
    assert!((9..=10).contains(&att), "{att}");
    let (_, h) = g.heartbeat.clone().unwrap();
    assert_eq!(h.mavtype, MavType::MAV_TYPE_HELICOPTER);
    assert!(
        !h.base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
    );
}

#[test]
fn a_message_interval_is_set_and_a_message_can_be_stopped() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let (mut t, mut ev) = (T0, Vec::new());
    let s = store();
    for (id, us) in [(ATTITUDE_DATA::ID, 100_000.0), (SCALED_IMU_DATA::ID, -1.0)] {
        let cmd = COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: id as f32,
            param2: us,
            ..Default::default()
        };
        let frame = g.command_frame(cmd, t);
        v.receive(&frame, t, &s);
    }
    run(&mut v, &mut g, &mut t, 300, &mut never(), &mut ev);
    let att = g.counts[&ATTITUDE_DATA::ID];
    assert!((29..=31).contains(&att), "10 Hz for 3 s: {att}");
    assert!(!g.counts.contains_key(&SCALED_IMU_DATA::ID));
    assert_eq!(
        g.final_ack(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
}

#[test]
fn the_autopilot_version_is_given_when_asked_as_ground_stations_ask() {
    #[allow(deprecated)]
    let old = MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES;
    for (command, param1, given) in [
        (
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            AUTOPILOT_VERSION_DATA::ID as f32,
            true,
        ),
        (old, 1.0, true),
        (MavCmd::MAV_CMD_REQUEST_MESSAGE, 300.0, false),
    ] {
        let mut v = VehicleLink::new(None, T0);
        let mut g = GroundLink::new(None);
        let cmd = COMMAND_LONG_DATA {
            command,
            param1,
            ..Default::default()
        };
        v.receive(&g.command_frame(cmd, T0), T0, &store());
        for d in v.take_outgoing() {
            g.receive(&d, T0);
        }
        let ack = g.final_ack(command);
        let sent = g
            .counts
            .get(&AUTOPILOT_VERSION_DATA::ID)
            .copied()
            .unwrap_or(0);
        if given {
            assert_eq!(ack, Some(MavResult::MAV_RESULT_ACCEPTED), "{command:?}");
            assert_eq!(sent, 1, "{command:?}");
        } else {
            assert_ne!(ack, Some(MavResult::MAV_RESULT_ACCEPTED), "{param1}");
            assert_eq!(sent, 0);
        }
    }
    let MavMessage::AUTOPILOT_VERSION(version) = crate::vehicle::autopilot_version() else {
        panic!("not an AUTOPILOT_VERSION")
    };
    assert!(
        version
            .capabilities
            .contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2)
    );
    let [major, minor, patch] = [
        env!("CARGO_PKG_VERSION_MAJOR"),
        env!("CARGO_PKG_VERSION_MINOR"),
        env!("CARGO_PKG_VERSION_PATCH"),
    ]
    .map(|s| s.parse::<u32>().unwrap());
    assert_eq!(
        version.flight_sw_version,
        major << 24 | minor << 16 | patch << 8
    );
}

#[test]
fn a_message_interval_refused_is_denied_with_a_text_naming_why() {
    for (id, us, says) in [
        (SCALED_IMU_DATA::ID as f32, 1000.0, "10000 us"),
        (SCALED_IMU_DATA::ID as f32, -5.0, "-1 (off)"),
        (
            9999.0,
            100_000.0,
            "message 9999 is not one of the telemetry's",
        ),
        (f32::NAN, 100_000.0, "is not one of the telemetry's"),
        (
            ATTITUDE_DATA::ID as f32 + 0.7,
            100_000.0,
            "is not one of the telemetry's",
        ),
    ] {
        let mut v = VehicleLink::new(None, T0);
        let mut g = GroundLink::new(None);
        let cmd = COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: id,
            param2: us,
            ..Default::default()
        };
        v.receive(&g.command_frame(cmd, T0), T0, &store());
        for d in v.take_outgoing() {
            g.receive(&d, T0);
        }
        assert_eq!(
            g.final_ack(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL),
            Some(MavResult::MAV_RESULT_DENIED),
            "{id} {us}"
        );
        assert!(
            g.texts
                .iter()
                .any(|(_, t)| t.contains("message interval refused") && t.contains(says)),
            "{id} {us}: {:?}",
            g.texts
        );
    }
}

#[test]
fn a_thesis_command_is_handed_on_and_acknowledged_twice() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let start = StartParameters::new("hover1", "autonomous").unwrap();
    let long = command_long(&GroundCommand::StartLogging(start.clone()), (1, 1)).unwrap();
    let frame = g.command_frame(long, T0);
    let events = v.receive(&frame, T0, &store());
    let [LinkEvent::Command { token, command }] = events.as_slice() else {
        panic!("{events:?}")
    };
    assert_eq!(*command, GroundCommand::StartLogging(start));
    v.finish(*token, CommandOutcome::Accepted("flying".into()), T0);
    for d in v.take_outgoing() {
        g.receive(&d, T0);
    }
    assert_eq!(
        g.acks,
        vec![
            (CMD_START_LOGGING, MavResult::MAV_RESULT_IN_PROGRESS),
            (CMD_START_LOGGING, MavResult::MAV_RESULT_ACCEPTED)
        ]
    );
    assert!(
        g.texts
            .iter()
            .any(|(_, t)| t.contains("start logging: flying"))
    );
}

#[test]
fn with_a_key_unsigned_wrong_and_replayed_commands_are_refused_and_the_ground_told() {
    let key = Key::new([3; 32]);
    let mut v = VehicleLink::new(Some(key.clone()), T0);
    let mut good = GroundLink::new(Some(key.clone()));
    let mut unsigned = GroundLink::new(None);
    let mut wrong = GroundLink::new(Some(Key::new([4; 32])));
    let stop = command_long(&GroundCommand::Stop, (1, 1)).unwrap();
    let s = store();
    let signed = good.command_frame(stop.clone(), T0);
    let mut commands = 0;
    let mut refused = Vec::new();
    let frames = [
        signed.clone(),
        unsigned.command_frame(stop.clone(), T0),
        wrong.command_frame(stop.clone(), T0),
        signed,
    ];
    for (i, f) in frames.iter().enumerate() {
        for e in v.receive(f, T0 + i as u64 * 2_000_000, &s) {
            match e {
                LinkEvent::Command { .. } => commands += 1,
                LinkEvent::Refused { reason, .. } => refused.push(reason),
                _ => {}
            }
        }
    }
    assert_eq!(commands, 1);
    assert_eq!(
        refused,
        vec![Refusal::Unsigned, Refusal::BadSignature, Refusal::Replayed]
    );
    assert_eq!(v.refused().total(), 3);
    v.tick(T0 + 6_000_000, VehicleStatus::default(), None, &s);
    for d in v.take_outgoing() {
        good.receive(&d, T0 + 6_000_000);
    }
    let notices = good
        .texts
        .iter()
        .filter(|(_, t)| t.contains("refused"))
        .count();
    assert_eq!(notices, 3, "{:?}", good.texts);
    assert_eq!(good.bad_frames, 0);
    // SYS_STATUS counts them too.
    let Some((_, MavMessage::SYS_STATUS(st))) = good.latest.get(&SYS_STATUS_DATA::ID) else {
        panic!("no SYS_STATUS")
    };
    assert_eq!(st.errors_comm, 3);
}

#[test]
fn a_log_downloads_byte_exact_with_a_fifth_of_the_datagrams_lost_both_ways() {
    let mut v = VehicleLink::new(Some(Key::new([5; 32])), T0);
    let mut g = GroundLink::new(Some(Key::new([5; 32])));
    let (mut t, mut ev) = (T0, Vec::new());
    let s = store();
    let list = g.log_list_frame(t);
    v.receive(&list, t, &s);
    for d in v.take_outgoing() {
        g.receive(&d, t);
    }
    let entry = g.log_entries[&1].clone();
    assert_eq!(entry.size, 20_000);
    let req = g.start_download(1, entry.size, t);
    v.receive(&req, t, &s);
    // A fixed pseudo-random sequence that loses one datagram in five, both ways (a plain
    // "every fifth" would fall into step with the vehicle's bursts of ten).
    let mut state = 0x2545_f491_u32;
    let mut drop = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state.is_multiple_of(5)
    };
    let mut steps = 0;
    while steps < 3000 && !g.download.as_ref().is_some_and(|d| d.complete()) {
        run(&mut v, &mut g, &mut t, 1, &mut drop, &mut ev);
        steps += 1;
    }
    let dl = g.download.as_ref().unwrap();
    assert!(
        dl.complete(),
        "{} of {}, {} requests",
        dl.received(),
        dl.size,
        dl.requests
    );
    assert_eq!(dl.bytes, s.logs[0].1);
    assert!(dl.requests > 1, "gaps were asked for again");
    // A gap is asked for as soon as the request before it has ended, not after a 0.3 s
    // stall: 7.3 s of link time here (14.5 s when every gap waited for the stall).
    assert!(steps * 10 < 10_000, "{} ms", steps * 10);
}

/// A store that cannot read one of its directories, and whose reads fail while `failing`.
struct Troubled {
    inner: MemoryStore,
    failing: std::cell::Cell<bool>,
}

impl LogStore for Troubled {
    fn list(&self) -> crate::logs::Listing {
        let mut listing = self.inner.list();
        listing
            .problems
            .push("/dev/shm/heli-0: Permission denied (os error 13)".into());
        listing
    }
    fn read(&self, name: &str, ofs: u32, buf: &mut [u8]) -> Result<usize, String> {
        if self.failing.get() {
            return Err(format!("{name}: Input/output error (os error 5)"));
        }
        self.inner.read(name, ofs, buf)
    }
}

#[test]
fn what_the_log_store_cannot_do_reaches_the_ground_once_a_spell() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let mut t = T0;
    let s = Troubled {
        inner: store(),
        failing: std::cell::Cell::new(true),
    };
    let carry = |v: &mut VehicleLink, g: &mut GroundLink, t: u64| {
        for d in v.take_outgoing() {
            g.receive(&d, t);
        }
    };
    // 10 ms of both ends: the vehicle's tick, its datagrams, the ground's asking again.
    let step = |v: &mut VehicleLink, g: &mut GroundLink, t: &mut u64| {
        *t += 10_000;
        v.tick(*t, VehicleStatus::default(), None, &s);
        carry(v, g, *t);
        if let Some(again) = g.download_tick(*t) {
            v.receive(&again, *t, &s);
        }
    };
    v.receive(&g.log_list_frame(t), t, &s);
    carry(&mut v, &mut g, t);
    assert_eq!(g.log_entries.len(), 1, "the logs it could list are listed");
    assert!(
        g.texts
            .iter()
            .any(|(sev, text)| *sev == MavSeverity::MAV_SEVERITY_ERROR
                && text == "log list: /dev/shm/heli-0: Permission denied (os error 13)"),
        "{:?}",
        g.texts
    );
    let req = g.start_download(1, 20_000, t);
    v.receive(&req, t, &s);
    // The ground asks again and again (every 0.3 s without progress): one text.
    for _ in 0..200 {
        step(&mut v, &mut g, &mut t);
    }
    let failed: Vec<_> = g
        .texts
        .iter()
        .filter(|(_, text)| text.contains("cannot be read"))
        .collect();
    assert_eq!(failed.len(), 1, "{:?}", g.texts);
    assert_eq!(
        failed[0].1,
        "log 1 (flight_a.mcap) cannot be read at byte 0: flight_a.mcap: Input/output error (os error 5)"
    );
    assert!(g.download.as_ref().is_some_and(|d| d.received() == 0));
    // The ground's download knows the vehicle's word, for its transfer to stop waiting.
    assert_eq!(
        g.download
            .as_ref()
            .and_then(|d| d.vehicle_said())
            .map(|(_, t)| t.as_str()),
        Some(failed[0].1.as_str())
    );
    // The storage reads again: said, and the log comes whole.
    s.failing.set(false);
    for _ in 0..2000 {
        step(&mut v, &mut g, &mut t);
        if g.download.as_ref().is_some_and(|d| d.complete()) {
            break;
        }
    }
    assert!(
        g.texts
            .iter()
            .any(|(_, text)| text.starts_with("log 1: read again, after "))
    );
    assert_eq!(g.download.as_ref().unwrap().bytes, s.inner.logs[0].1);
}

#[test]
fn the_ground_falling_silent_is_an_event_and_its_return_too() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let (mut t, mut ev) = (T0, Vec::new());
    run(&mut v, &mut g, &mut t, 200, &mut never(), &mut ev);
    let mut silent = || true;
    run(&mut v, &mut g, &mut t, 700, &mut silent, &mut ev);
    assert!(ev.contains(&LinkEvent::LinkLost));
    run(&mut v, &mut g, &mut t, 200, &mut never(), &mut ev);
    assert!(ev.contains(&LinkEvent::LinkRegained));
}

#[test]
fn bad_commands_are_denied_with_a_reason_and_unknown_ones_unsupported() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let s = store();
    let mut long = command_long(
        &GroundCommand::StartLogging(StartParameters::new("x", "manual").unwrap()),
        (1, 1),
    )
    .unwrap();
    long.param1 = 42.0;
    let f = g.command_frame(long, T0);
    assert!(v.receive(&f, T0, &s).is_empty());
    let takeoff = COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_NAV_TAKEOFF,
        ..Default::default()
    };
    let f = g.command_frame(takeoff, T0);
    v.receive(&f, T0, &s);
    for d in v.take_outgoing() {
        g.receive(&d, T0);
    }
    assert_eq!(
        g.final_ack(CMD_START_LOGGING),
        Some(MavResult::MAV_RESULT_DENIED)
    );
    assert_eq!(
        g.final_ack(MavCmd::MAV_CMD_NAV_TAKEOFF),
        Some(MavResult::MAV_RESULT_UNSUPPORTED)
    );
    assert!(
        g.texts.iter().any(|(_, t)| t.contains("controller 42")),
        "{:?}",
        g.texts
    );
}

proptest::proptest! {
    #[test]
    fn random_datagrams_never_panic_the_vehicle(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
        let mut v = VehicleLink::new(Some(Key::new([1; 32])), T0);
        let _ = v.receive(&bytes, T0, &store());
        let mut open = VehicleLink::new(None, T0);
        let _ = open.receive(&bytes, T0, &store());
        let mut g = GroundLink::new(None);
        g.receive(&bytes, T0);
    }
}

#[test]
fn status_texts_are_cut_into_pieces_that_join_back_exactly() {
    let texts = [
        "flight: event activity-hi t=6.03 s calibration done, gyro bias [0.0028, -0.0137, 0.0010] rad/s".to_string(),
        // A word longer than a piece, and one that straddles a cut.
        format!("stopped {{\"control_steps\":2166,\"log_error\":\"{}\"}}", "x".repeat(70)),
        "flight: stopped {\"baro_readings\":215,\"compass_readings\":867,\"control_steps\":2166}".to_string(),
        "x".repeat(120),
        "météo: vent à 8 m/s, rafales à 12 m/s — décollage refusé".repeat(2),
        // Whose last piece would be exactly full, or end with a space: the ground could not
        // tell that the text ends there.
        "command refused: controller 42 is not 0-4 (manual, autonomous, rate, attitude, velocity), or 16-20 with the override of the lab-tested check".to_string(),
        "y".repeat(100),
        "a text that ends with a space ".to_string(),
        String::new(),
    ];
    for text in &texts {
        let parts = chunks(text, 50);
        assert!(parts.iter().all(|p| p.len() <= 50), "{parts:?}");
        assert_eq!(parts.concat(), *text, "{parts:?}");
        // Every piece but the last says it continues: a space at its end, or full.
        let last = parts.len() - 1;
        for p in &parts[..last] {
            assert!(p.ends_with(' ') || p.len() == 50, "{p:?} in {parts:?}");
        }
        // The last one says it ends.
        assert!(
            parts[last].len() < 50 && !parts[last].ends_with(' '),
            "{parts:?}"
        );
    }
    assert_eq!(chunks(&"x".repeat(120), 50).len(), 3);
    assert_eq!(chunks("", 50), vec![String::new()]);
    // Through the link, a long line with a long word arrives as it was sent.
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    for text in &texts[..8] {
        v.status_text(MavSeverity::MAV_SEVERITY_INFO, text, T0);
        for frame in v.take_outgoing() {
            g.receive(&frame, T0);
        }
        // Whole at once: no wait for a continuation that is not coming.
        let (_, got) = g.texts.pop().unwrap();
        assert_eq!(&got, text);
    }
}

#[test]
fn parameters_are_listed_read_and_set_and_a_bad_value_changes_nothing() {
    use crate::params::{ParamSpec, ParamTable, param_name};
    const SPECS: [ParamSpec; 2] = [
        ParamSpec {
            name: "A_GAIN",
            what: "",
            min: 0.0,
            max: 1.0,
            default: 0.5,
        },
        ParamSpec {
            name: "B_LIMIT",
            what: "",
            min: 1.0,
            max: 9.0,
            default: 3.0,
        },
    ];
    let mut v = VehicleLink::new(None, T0).with_params(ParamTable::new(&SPECS));
    let mut g = GroundLink::new(None);
    let s = store();
    let send = |g: &mut GroundLink, m: MavMessage| g.encode(&m, T0);
    let list = send(
        &mut g,
        MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 1,
        }),
    );
    let good = send(
        &mut g,
        MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: 0.75,
            target_system: 1,
            target_component: 1,
            param_id: "A_GAIN".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }),
    );
    let bad = send(
        &mut g,
        MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: 50.0,
            target_system: 1,
            target_component: 1,
            param_id: "B_LIMIT".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }),
    );
    let read = send(
        &mut g,
        MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: 1,
            target_component: 1,
            param_id: "A_GAIN".into(),
        }),
    );
    let mut events = Vec::new();
    for f in [list, good, bad, read] {
        events.extend(v.receive(&f, T0, &s));
    }
    for d in v.take_outgoing() {
        g.receive(&d, T0);
    }
    assert_eq!(
        g.counts[&PARAM_VALUE_DATA::ID],
        5,
        "2 listed, 2 set answers, 1 read"
    );
    let Some((_, MavMessage::PARAM_VALUE(last))) = g.latest.get(&PARAM_VALUE_DATA::ID) else {
        panic!()
    };
    assert_eq!(
        (param_name(&last.param_id).as_str(), last.param_value),
        ("A_GAIN", 0.75)
    );
    assert_eq!(v.params().get("B_LIMIT"), Some(3.0));
    assert!(
        g.texts
            .iter()
            .any(|(_, t)| t.contains("B_LIMIT: 50 refused")),
        "{:?}",
        g.texts
    );
    assert_eq!(
        events
            .iter()
            .filter(|e| matches!(e, LinkEvent::ParamSet { .. }))
            .count(),
        1
    );
}

#[test]
fn a_flood_of_refusals_is_told_once_a_second_per_kind() {
    let key = Key::new([3; 32]);
    let mut v = VehicleLink::new(Some(key.clone()), T0);
    let mut unsigned = GroundLink::new(None);
    let mut good = GroundLink::new(Some(key));
    let stop = command_long(&GroundCommand::Stop, (1, 1)).unwrap();
    let s = store();
    let signed = good.command_frame(stop.clone(), T0);
    v.receive(&signed, T0, &s);
    for i in 0..50 {
        let f = unsigned.command_frame(stop.clone(), T0 + i * 1000);
        v.receive(&f, T0 + i * 1000, &s);
    }
    // A replay within the same second is a kind of its own: told too.
    v.receive(&signed, T0 + 60_000, &s);
    for d in v.take_outgoing() {
        good.receive(&d, T0 + 100_000);
    }
    let told: Vec<&String> = good.texts.iter().map(|(_, t)| t).collect();
    assert_eq!(
        told.iter().filter(|t| t.contains("unsigned")).count(),
        1,
        "{told:?}"
    );
    assert_eq!(
        told.iter().filter(|t| t.contains("replayed")).count(),
        1,
        "{told:?}"
    );
    assert_eq!(v.refused().unsigned, 50);
}

#[test]
fn a_retried_command_is_answered_again_never_carried_out_twice() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let s = store();
    let mut stop = command_long(&GroundCommand::Stop, (1, 1)).unwrap();
    let first = g.command_frame(stop.clone(), T0);
    let commands = |ev: &[LinkEvent]| {
        ev.iter()
            .filter(|e| matches!(e, LinkEvent::Command { .. }))
            .count()
    };
    let ev = v.receive(&first, T0, &s);
    assert_eq!(commands(&ev), 1);
    let token = match &ev[0] {
        LinkEvent::Command { token, .. } => *token,
        other => panic!("{other:?}"),
    };
    // The IN_PROGRESS was lost: the ground retries while the stop is under way.
    stop.confirmation = 1;
    let retry = g.command_frame(stop.clone(), T0 + 500_000);
    assert_eq!(commands(&v.receive(&retry, T0 + 500_000, &s)), 0);
    v.finish(
        token,
        CommandOutcome::Accepted("stopped (exit code 0)".into()),
        T0 + 1_000_000,
    );
    // The final ack was lost: a later retry gets the result again.
    stop.confirmation = 2;
    let again = g.command_frame(stop, T0 + 3_000_000);
    assert_eq!(commands(&v.receive(&again, T0 + 3_000_000, &s)), 0);
    for d in v.take_outgoing() {
        g.receive(&d, T0 + 3_000_000);
    }
    let acks: Vec<MavResult> = g.acks.iter().map(|a| a.1).collect();
    assert_eq!(
        acks,
        vec![
            MavResult::MAV_RESULT_IN_PROGRESS,
            MavResult::MAV_RESULT_IN_PROGRESS,
            MavResult::MAV_RESULT_ACCEPTED,
            MavResult::MAV_RESULT_ACCEPTED
        ]
    );
}

#[test]
fn connect_over_the_link_is_refused_while_a_flight_is_under_way() {
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let s = store();
    let flying = VehicleStatus {
        state: BootstrapState::Flying,
        mode: 2,
        ..VehicleStatus::default()
    };
    v.tick(T0, flying, None, &s);
    let connect = g.command_frame(command_long(&GroundCommand::Connect, (1, 1)).unwrap(), T0);
    let ev = v.receive(&connect, T0, &s);
    assert!(
        !ev.iter().any(|e| matches!(e, LinkEvent::Command { .. })),
        "{ev:?}"
    );
    for d in v.take_outgoing() {
        g.receive(&d, T0);
    }
    assert_eq!(g.final_ack(CMD_CONNECT), Some(MavResult::MAV_RESULT_DENIED));
    assert!(
        g.texts
            .iter()
            .any(|(_, t)| t.contains("flight is under way"))
    );
}

#[test]
fn a_signed_command_held_back_is_refused_and_reflections_are_ignored() {
    let key = Key::new([6; 32]);
    let mut v = VehicleLink::new(Some(key.clone()), T0);
    let mut g = GroundLink::new(Some(key.clone()));
    let s = store();
    // Signed 30 s before it arrives (a fresh stream would accept up to a minute).
    let stop = command_long(&GroundCommand::Stop, (1, 1)).unwrap();
    let late = g.command_frame(stop, T0 - 30_000_000);
    let ev = v.receive(&late, T0, &s);
    assert!(
        matches!(
            ev.as_slice(),
            [LinkEvent::Refused {
                reason: Refusal::Stale,
                ..
            }]
        ),
        "{ev:?}"
    );
    // The vehicle's own heartbeat, bounced back: neither a ground nor the link's life.
    v.tick(T0, VehicleStatus::default(), None, &s);
    let own = v.take_outgoing();
    for d in &own {
        assert!(v.receive(d, T0 + 1, &s).is_empty());
    }
    assert_eq!(v.stats.frames_in, 0);
    // And the ground does not take its own frames for the vehicle's.
    let hb = g.heartbeat_frame(T0);
    g.receive(&hb, T0);
    assert!(g.heartbeat.is_none());
}

#[test]
fn messages_for_another_system_change_nothing() {
    use crate::params::{ONE_GAIN, ParamTable};
    let mut v = VehicleLink::new(None, T0).with_params(ParamTable::new(&ONE_GAIN));
    let mut g = GroundLink::new(None);
    let set = g.encode(
        &MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: 0.9,
            target_system: 2,
            target_component: 1,
            param_id: "A_GAIN".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }),
        T0,
    );
    let ev = v.receive(&set, T0, &store());
    assert!(ev.is_empty(), "{ev:?}");
    assert_eq!(v.params().get("A_GAIN"), Some(0.5));
}

#[test]
fn the_heartbeat_s_phase_is_the_flight_core_s_now_without_a_current_estimate() {
    let mut v = VehicleLink::new(None, T0);
    let beat_phase = |v: &mut VehicleLink, t_us: u64, telemetry: &Telemetry| {
        let status = VehicleStatus {
            state: BootstrapState::Flying,
            mode: 2,
            ..VehicleStatus::default()
        };
        v.tick(t_us, status, Some(telemetry), &store());
        v.status.phase
    };
    // Calibrating: no estimate yet, the phase all the same.
    let calibrating = Telemetry {
        phase: Some("calibrating".into()),
        state: None,
        ..telemetry()
    };
    assert_eq!(
        beat_phase(&mut v, T0, &calibrating),
        crate::status::phase_code("calibrating")
    );
    // The estimate lost: its last row says hold, the core says blind descent.
    let lost = Telemetry {
        phase: Some("blind-descent".into()),
        state: Some(StateRow {
            phase: "hold".into(),
            ..StateRow::default()
        }),
        ..telemetry()
    };
    assert_eq!(
        beat_phase(&mut v, T0 + 100_000, &lost),
        crate::status::phase_code("blind-descent")
    );
    assert_ne!(crate::status::phase_code("blind-descent"), 0);
}

#[test]
fn the_heartbeat_carries_the_phase_flown_beside_the_mode_asked() {
    for (k, name) in crate::status::PHASES.iter().enumerate() {
        let status = VehicleStatus {
            state: BootstrapState::Flying,
            mode: 2,
            phase: crate::status::phase_code(name),
            tested: crate::status::Tested::NotTested,
        };
        assert_eq!(usize::from(status.phase), k + 1);
        let MavMessage::HEARTBEAT(hb) = crate::status::heartbeat(status) else {
            panic!("not a heartbeat");
        };
        let back = VehicleStatus::from_heartbeat(&hb).unwrap();
        assert_eq!(back, status);
        assert_eq!(back.phase_name(), Some(*name));
    }
    assert_eq!(crate::status::phase_code("somersault"), 0);
    for tested in [
        crate::status::Tested::Unknown,
        crate::status::Tested::LabTested,
        crate::status::Tested::NotTested,
        crate::status::Tested::BenchOverride,
    ] {
        let status = VehicleStatus {
            tested,
            ..VehicleStatus::default()
        };
        let MavMessage::HEARTBEAT(hb) = crate::status::heartbeat(status) else {
            panic!("not a heartbeat");
        };
        assert_eq!(hb.custom_mode >> 24, tested as u32);
        assert_eq!(VehicleStatus::from_heartbeat(&hb).unwrap().tested, tested);
    }
    assert_eq!(VehicleStatus::default().phase_name(), None);
}

#[test]
fn a_change_of_state_is_said_at_once_not_at_the_next_beat() {
    use crate::status::BootstrapState;
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let s = store();
    let mut beat = |t: u64, state: BootstrapState| {
        let status = VehicleStatus {
            state,
            ..VehicleStatus::default()
        };
        v.tick(t, status, None, &s);
        for d in v.take_outgoing() {
            g.receive(&d, t);
        }
        g.counts.get(&HEARTBEAT_DATA::ID).copied().unwrap_or(0)
    };
    assert_eq!(beat(T0 + 10_000, BootstrapState::Idle), 1);
    assert_eq!(
        beat(T0 + 110_000, BootstrapState::Idle),
        1,
        "a second to the next beat"
    );
    assert_eq!(
        beat(T0 + 210_000, BootstrapState::Connected),
        2,
        "a change at once"
    );
    assert_eq!(beat(T0 + 310_000, BootstrapState::Connected), 2);
    assert_eq!(
        beat(T0 + 1_210_000, BootstrapState::Connected),
        3,
        "the beat goes on from it"
    );
}

#[test]
fn a_change_of_state_sends_the_sensors_state_at_once_too() {
    use crate::status::BootstrapState;
    let mut v = VehicleLink::new(None, T0);
    let mut g = GroundLink::new(None);
    let s = store();
    let mut tick = |t: u64, state: BootstrapState, tel: Option<&Telemetry>| {
        let status = VehicleStatus {
            state,
            ..VehicleStatus::default()
        };
        v.tick(t, status, tel, &s);
        for d in v.take_outgoing() {
            g.receive(&d, t);
        }
        let present = match g.latest.get(&SYS_STATUS_DATA::ID) {
            Some((_, MavMessage::SYS_STATUS(st))) => st.onboard_control_sensors_present,
            _ => MavSysStatusSensor::empty(),
        };
        (
            g.counts.get(&SYS_STATUS_DATA::ID).copied().unwrap_or(0),
            present,
        )
    };
    let flying = Telemetry {
        health: vec![crate::telemetry::DeviceHealth {
            device: "gps".into(),
            state: "ok".into(),
            lapses: 0,
        }],
        ..telemetry()
    };
    let gps = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
    let (first, present) = tick(T0 + 10_000, BootstrapState::Flying, Some(&flying));
    assert_eq!(first, 1, "the sensors' state streams");
    assert!(present.contains(gps));
    assert_eq!(
        tick(T0 + 20_000, BootstrapState::Flying, Some(&flying)).0,
        1
    );
    // The flight ends: the ground hears at once that the vehicle has no sensors to speak
    // for, not a stream period later.
    let (after, present) = tick(T0 + 30_000, BootstrapState::Idle, None);
    assert_eq!(after, 2, "at once");
    assert!(present.is_empty(), "{present:?}");
    // Nothing changed since: the stream's own cadence again.
    assert_eq!(tick(T0 + 40_000, BootstrapState::Idle, None).0, 2);
}
