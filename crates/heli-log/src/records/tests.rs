//! Tests of the conversion: every kind of record, its schema and its Foxglove view.

use super::*;
use crate::schema::{for_topic, validate};
use crate::{EventLevel, read};
use heli_control::Target;
use heli_fsw::core::CoreEvent;
use heli_fsw::phase::Phase;
use heli_fsw::streams::{BaroRecord, CompassRecord, ImuRecord, ServoRecord, Stamped, StateRecord};
use heli_nav::NavState;
use heli_proto::compass::{CompassAdc, MagField};
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink};
use nalgebra::{UnitQuaternion, Vector3};
use std::io::Cursor;

fn stamped<T>(t_us: u64, value: T) -> Stamped<T> {
    Stamped { t_us, value }
}

fn nav() -> NavState {
    NavState {
        t_us: 1_000,
        att: UnitQuaternion::from_euler_angles(0.1, -0.05, 1.2),
        vel_ned_mps: Vector3::new(1.0, 0.5, -0.2),
        pos_ned_m: Vector3::new(10.0, -4.0, -12.0),
        rate_body_rps: Vector3::new(0.01, 0.02, 0.03),
        accel_body_mps2: Vector3::new(0.0, 0.0, -9.81),
        gyro_bias_rps: Vector3::new(0.001, 0.0, -0.001),
        accel_bias_mps2: Vector3::new(0.01, 0.0, 0.0),
    }
}

/// One record of every stream, with the variants of the optional fields.
fn every_kind() -> Vec<Record> {
    let gps = GpsNav {
        tow_ms: 86_400_000,
        lat_deg: 42.36,
        lon_deg: -71.09,
        alt_m: 12.0,
        vel_ned_mps: [0.1, 0.2, 0.0],
        satellites: 7,
        fix: FixType::Fix3D,
    };
    vec![
        Record::Imu(stamped(
            0,
            ImuRecord {
                imu: ImuRepr {
                    rate_rps: [0.1, 0.0, -0.1],
                    accel_mps2: [0.0, 0.0, -9.8],
                    temp_c: 25.0,
                },
                repeated: true,
            },
        )),
        Record::State(stamped(
            20_000,
            StateRecord {
                nav: nav(),
                phase: Phase::Manual,
                target: None,
            },
        )),
        Record::State(stamped(
            40_000,
            StateRecord {
                nav: nav(),
                phase: Phase::Manual,
                target: Some(Target::hold(Vector3::new(0.0, 0.0, -10.0), 0.0)),
            },
        )),
        Record::Servo(stamped(
            40_000,
            ServoRecord {
                controls: Controls {
                    aileron: 0.1,
                    elevator: -0.1,
                    rudder: 0.0,
                    collective: 0.3,
                    throttle: 0.8,
                },
                rotor_rpm: 1600,
            },
        )),
        Record::Uplink(stamped(
            40_000,
            PilotUplink {
                rotor_rpm: 1600,
                auto_mode: true,
                receiver_batt_v: 4.8,
                ..Default::default()
            },
        )),
        Record::Gps(stamped(1_000_000, gps)),
        Record::Gps(stamped(
            2_000_000,
            GpsNav {
                fix: FixType::NoFix,
                ..gps
            },
        )),
        Record::Gps(stamped(
            3_000_000,
            GpsNav {
                fix: FixType::Unknown(1),
                ..gps
            },
        )),
        Record::Baro(stamped(
            200_000,
            BaroRecord {
                pressure_mbar: 1013.0,
                alt_m: None,
            },
        )),
        Record::Baro(stamped(
            400_000,
            BaroRecord {
                pressure_mbar: 1012.0,
                alt_m: Some(8.0),
            },
        )),
        Record::Compass(stamped(
            50_000,
            CompassRecord {
                adc: CompassAdc {
                    counts: [2048, 2000, 2100],
                },
                field: MagField {
                    field_gauss: [0.2, 0.0, 0.4],
                },
                heading_rad: Some(0.3),
            },
        )),
        Record::Compass(stamped(
            100_000,
            CompassRecord {
                adc: CompassAdc::default(),
                field: MagField::default(),
                heading_rad: None,
            },
        )),
    ]
}

#[test]
fn every_message_matches_its_channels_schema() {
    for record in every_kind() {
        let (topic, t_us, value) = record_json(&record);
        assert_eq!(t_us, record_time(&record));
        let schema = for_topic(topic);
        validate(&schema.json, &value, topic).unwrap_or_else(|e| panic!("{e}"));
        if let Some((view, value)) = foxglove_views(&record) {
            validate(&for_topic(view).json, &value, view).unwrap_or_else(|e| panic!("{e}"));
        }
    }
    for e in [CoreEvent::GpsLost, CoreEvent::PhaseChanged(Phase::Landed)] {
        let message = crate::event_json(5_000_000, &e);
        validate(&for_topic("events").json, &message, "events").unwrap_or_else(|e| panic!("{e}"));
        let log = crate::foxglove::log(5_000_000, crate::events::event_level(&e), "x");
        validate(&for_topic("foxglove/log").json, &log, "log").unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn records_go_to_their_channels_with_their_foxglove_views() {
    let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
    for (i, record) in every_kind().iter().enumerate() {
        log.write_record_sequenced(record, 100 + i as u64)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    log.write_event(2_000_000, &CoreEvent::GpsLost)
        .unwrap_or_else(|e| panic!("{e}"));
    log.write_event_text("t=3.00 s watchdog fired", 0)
        .unwrap_or_else(|e| panic!("{e}"));
    log.write_event_text("no time here", 7)
        .unwrap_or_else(|e| panic!("{e}"));
    let bytes = log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner();
    let contents = read(&bytes);
    let counts = contents.counts();
    assert_eq!(counts.get("state"), Some(&2));
    assert_eq!(counts.get("foxglove/tf"), Some(&2));
    // Only the 3D fix is a location on the map.
    assert_eq!(
        (counts.get("gps"), counts.get("foxglove/fix")),
        (Some(&3), Some(&1))
    );
    assert_eq!(
        (counts.get("events"), counts.get("foxglove/log")),
        (Some(&3), Some(&3))
    );
    assert_eq!(
        contents.schemas.get("foxglove/tf").map(String::as_str),
        Some("foxglove.FrameTransform")
    );
    assert_eq!(
        contents.schemas.get("foxglove/fix").map(String::as_str),
        Some("foxglove.LocationFix")
    );
    assert_eq!(
        contents.schemas.get("foxglove/log").map(String::as_str),
        Some("foxglove.Log")
    );
    // The stream's own numbers, so that a record the logger never saw is a gap.
    let imu = contents
        .messages
        .iter()
        .find(|m| m.topic == "imu")
        .map(|m| m.sequence);
    assert_eq!(imu, Some(100));
    let events: Vec<_> = contents
        .messages
        .iter()
        .filter(|m| m.topic == "events")
        .collect();
    assert_eq!(events[0].value["level"], "error");
    assert_eq!(
        (events[1].t_us, events[1].value["level"].as_str()),
        (3_000_000, Some("warning"))
    );
    assert_eq!(
        (events[2].t_us, events[2].value["level"].as_str()),
        (7, Some("unknown"))
    );
    let logs: Vec<_> = contents
        .messages
        .iter()
        .filter(|m| m.topic == "foxglove/log")
        .collect();
    assert_eq!(logs[1].value["level"], EventLevel::Warning.foxglove());
    assert_eq!(logs[1].value["message"], "t=3.00 s watchdog fired");
}

/// A flight of `seconds` of state records at 50 Hz, as a finished log.
fn states_log(seconds: u64) -> Vec<u8> {
    let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
    for k in 0..seconds * 50 {
        let record = Record::State(stamped(
            1_000_000 + k * 20_000,
            StateRecord {
                nav: nav(),
                phase: Phase::Manual,
                target: None,
            },
        ));
        log.write_record(&record).unwrap_or_else(|e| panic!("{e}"));
    }
    log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner()
}

#[test]
fn the_helicopter_s_scene_comes_with_the_first_pose_and_every_ten_seconds() {
    let contents = read(&states_log(25));
    let scenes: Vec<u64> = contents
        .messages
        .iter()
        .filter(|m| m.topic == crate::scene::SCENE_TOPIC)
        .map(|m| m.t_us)
        .collect();
    assert_eq!(scenes, [1_000_000, 11_000_000, 21_000_000]);
    assert_eq!(
        contents
            .schemas
            .get(crate::scene::SCENE_TOPIC)
            .map(String::as_str),
        Some("foxglove.SceneUpdate")
    );
}

/// Foxglove's published schema, checked by Python's `jsonschema` (which knows nothing of
/// heli) on the scene messages the official MCAP reader reads from a log: runs where
/// `HELI_MCAP_PYTHON` names a Python with `mcap` and `jsonschema` (CI's), else says so.
#[test]
fn the_scene_validates_against_foxglove_s_published_schema_in_the_official_validator() {
    let Some(python) = std::env::var_os("HELI_MCAP_PYTHON") else {
        println!("HELI_MCAP_PYTHON is not set: the official validator was not run");
        return;
    };
    let dir = std::env::temp_dir().join(format!("heli-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let log = dir.join("scene.mcap");
    std::fs::write(&log, states_log(12)).unwrap_or_else(|e| panic!("{e}"));
    let schema = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/schemas/foxglove/SceneUpdate.json"
    );
    const SCRIPT: &str = "import json, sys, jsonschema\nfrom mcap.reader import make_reader\nschema = json.load(open(sys.argv[2]))\nn = 0\nwith open(sys.argv[1], 'rb') as f:\n    for s, c, m in make_reader(f).iter_messages(topics=['foxglove/scene']):\n        assert json.loads(s.data) == schema, 'the channel schema is not the published one'\n        jsonschema.validate(json.loads(m.data), schema)\n        n += 1\nprint(n)\n";
    let out = std::process::Command::new(&python)
        .args(["-c", SCRIPT])
        .arg(&log)
        .arg(schema)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "2");
}
