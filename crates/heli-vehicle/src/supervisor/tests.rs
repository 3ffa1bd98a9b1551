use heli_types::FlightMode;
use proptest::prelude::*;
use serde_json::json;

use super::*;

fn params(suffix: &str, mode: &str, plan: Option<&str>) -> StartParameters {
    let mut p = StartParameters::new(suffix, mode).unwrap();
    p.plan = plan.map(str::to_string);
    p
}

#[test]
fn every_message_to_the_flight_process_round_trips() {
    let cases = [
        (
            ToFlight::Start(params("nov18", "autonomous", Some("rolls"))),
            "start nov18 autonomous rolls",
        ),
        (
            ToFlight::Start(params("f2", "manual", None)),
            "start f2 manual",
        ),
        (
            ToFlight::Restart(params("nov18", "velocity", Some("hover"))),
            "restart nov18 velocity hover",
        ),
        (
            ToFlight::Start(StartParameters {
                override_untested: true,
                ..params("u1", "autonomous", Some("rolls"))
            }),
            "start u1 autonomous rolls override-untested",
        ),
        (
            ToFlight::Start(StartParameters {
                override_untested: true,
                ..params("u2", "velocity", None)
            }),
            "start u2 velocity override-untested",
        ),
        (ToFlight::Link { fresh: true }, "link fresh"),
        (ToFlight::Link { fresh: false }, "link lost"),
        (ToFlight::Stop, "stop"),
        (ToFlight::Kill, "kill"),
    ];
    for (message, line) in cases {
        assert_eq!(message.to_line(), line);
        assert_eq!(message.to_string(), line);
        assert_eq!(ToFlight::parse(line).unwrap(), message, "{line}");
        assert_eq!(ToFlight::parse(&format!("{line}\n")).unwrap(), message);
    }
    let restart = ToFlight::parse("restart a rate").unwrap();
    assert_eq!(
        restart,
        ToFlight::Restart(StartParameters {
            file_suffix: "a".into(),
            controller: FlightMode::Augmented(heli_types::AugmentedMode::Rate),
            plan: None,
            override_untested: false,
        })
    );
}

#[test]
fn every_message_from_the_flight_process_round_trips() {
    let cases = [
        (FromFlight::Ready { version: VERSION }, "ready 4"),
        (
            FromFlight::Landing("stop in the air: landing where it is first".into()),
            "landing stop in the air: landing where it is first",
        ),
        (
            FromFlight::Started {
                log: Some("/var/log/heli/flight_a b.mcap".into()),
            },
            "started /var/log/heli/flight_a b.mcap",
        ),
        (FromFlight::Started { log: None }, "started (no log)"),
        (
            FromFlight::Refused("flight plan 'x': unknown".into()),
            "error flight plan 'x': unknown",
        ),
        (
            FromFlight::Note("SCHED_FIFO refused".into()),
            "note SCHED_FIFO refused",
        ),
        (
            FromFlight::Event {
                severity: Severity::Fatal,
                text: "imu silent".into(),
            },
            "event fatal imu silent",
        ),
        (
            FromFlight::Telemetry(json!({"phase": "hover", "alt_m": 10.5})),
            r#"telemetry {"alt_m":10.5,"phase":"hover"}"#,
        ),
        (
            FromFlight::Plan(vec![
                heli_types::Leg::Takeoff { alt_m: 5.0 },
                heli_types::Leg::Land,
            ]),
            r#"plan [{"leg":"takeoff","alt_m":5.0},{"leg":"land"}]"#,
        ),
        (FromFlight::Stopped(json!({})), "stopped {}"),
        (
            FromFlight::Adopted {
                pid: 4242,
                start: params("t1", "autonomous", Some("rolls")),
            },
            "adopted 4242 t1 autonomous rolls",
        ),
        (
            FromFlight::Adopted {
                pid: 7,
                start: params("t2", "manual", None),
            },
            "adopted 7 t2 manual",
        ),
    ];
    for (message, line) in cases {
        assert_eq!(message.to_line(), line);
        assert_eq!(FromFlight::parse(line).unwrap(), message, "{line}");
    }
}

#[test]
fn text_with_a_line_break_stays_one_line() {
    let note = FromFlight::Note("two\nlines\r".into()).to_line();
    assert_eq!(note, "note two lines ");
    let event = FromFlight::Event {
        severity: Severity::WarningLo,
        text: "a\nb".into(),
    };
    assert_eq!(event.to_line(), "event warning-lo a b");
    assert_eq!(FromFlight::Refused("x\ny".into()).to_line(), "error x y");
}

#[test]
fn what_is_not_the_protocol_is_refused_with_the_reason() {
    let to_flight = [
        ("", ProtocolError::Empty),
        (" start", ProtocolError::Empty),
        ("fly", ProtocolError::Unknown("fly".into())),
        ("stop now", malformed("stop", "takes nothing")),
        ("kill now", malformed("kill", "takes nothing")),
        ("link maybe", malformed("link", "expected fresh or lost")),
        (
            "start a",
            malformed("start", "expected SUFFIX MODE [PLAN] [override-untested]"),
        ),
        (
            "start a manual hover x",
            malformed("start", "expected SUFFIX MODE [PLAN] [override-untested]"),
        ),
        (
            "restart a manual ",
            malformed("restart", "an empty plan name"),
        ),
    ];
    for (line, error) in to_flight {
        assert_eq!(ToFlight::parse(line), Err(error), "{line:?}");
    }
    for line in ["start ../x manual", "start a loop", "start a  manual"] {
        let e = ToFlight::parse(line).unwrap_err();
        assert!(
            matches!(e, ProtocolError::Malformed { word: "start", .. }),
            "{line}: {e}"
        );
    }
    let long = "x".repeat(MAX_LINE + 1);
    assert_eq!(
        ToFlight::parse(&long),
        Err(ProtocolError::TooLong(MAX_LINE + 1))
    );
    assert_eq!(
        FromFlight::parse(&long),
        Err(ProtocolError::TooLong(MAX_LINE + 1))
    );
    // A line of exactly the most is still a line: a note that long is taken.
    let longest = format!("note {}", "x".repeat(MAX_LINE - 5));
    assert_eq!(longest.len(), MAX_LINE);
    assert!(matches!(
        FromFlight::parse(&longest),
        Ok(FromFlight::Note(_))
    ));
    let from_flight = [
        ("ready", "'ready': expected the protocol version"),
        ("ready one", "'ready': expected the protocol version"),
        ("started", "'started': expected the log"),
        ("event loud boom", "'event': no severity 'loud'"),
        (
            "telemetry {",
            "'telemetry': EOF while parsing an object at line 1 column 1",
        ),
        ("telemetry [1]", "'telemetry': expected a JSON object"),
        (
            "plan {}",
            "'plan': invalid type: map, expected a sequence at line 1 column 0",
        ),
        ("stopped 3", "'stopped': expected a JSON object"),
        ("hello there", "unknown message 'hello'"),
        ("adopted", "'adopted': expected PID SUFFIX MODE [PLAN]"),
        (
            "adopted x t1 manual",
            "'adopted': expected PID SUFFIX MODE [PLAN]",
        ),
        (
            "adopted 12 t1",
            "'adopted': expected SUFFIX MODE [PLAN] [override-untested]",
        ),
    ];
    for (line, error) in from_flight {
        assert_eq!(
            FromFlight::parse(line).unwrap_err().to_string(),
            error,
            "{line}"
        );
    }
    assert_eq!(ProtocolError::Empty.to_string(), "an empty line");
    assert_eq!(
        ProtocolError::TooLong(70_000).to_string(),
        "a line of 70000 bytes (at most 65536)"
    );
}

proptest! {
    #[test]
    fn no_line_makes_either_side_panic(line in ".{0,200}") {
        let _ = ToFlight::parse(&line);
        let _ = FromFlight::parse(&line);
    }

    #[test]
    fn notes_and_events_round_trip(text in "[ -~]{0,80}", severity in 0usize..5) {
        let note = FromFlight::Note(text.clone());
        prop_assert_eq!(FromFlight::parse(&note.to_line()).unwrap(), note);
        let event = FromFlight::Event { severity: Severity::ALL[severity], text };
        prop_assert_eq!(FromFlight::parse(&event.to_line()).unwrap(), event);
    }

    #[test]
    fn starts_round_trip(suffix in "[A-Za-z0-9_-]{1,15}", mode in 0usize..5, plan in proptest::option::of("[a-z0-9-]{1,20}")) {
        let p = params(&suffix, FlightMode::ALL[mode].name(), plan.as_deref());
        for message in [ToFlight::Start(p.clone()), ToFlight::Restart(p.clone())] {
            prop_assert_eq!(ToFlight::parse(&message.to_line()).unwrap(), message);
        }
    }
}
