//! The whole system over the MAVLink link: `heli hilsim --ptys`, `heli vehicle --link` and
//! `heli ground` as separate processes on loopback, signed with a key made by
//! `heli link keygen`; and pymavlink, a client that knows nothing of this project.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use super::shared;
use crate::procs::{Hilsim, Vehicle, free_udp_port, ground, heli};

fn keygen(path: &Path) {
    let out = heli(&["link", "keygen", "--out", &path.display().to_string()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_ground_flies_a_signed_hover_over_the_link_and_saves_its_log_by_the_final_parameters() {
    crate::procs::void_if_starved(|| {
        let _one = shared();
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("link.key");
        let wrong = dir.path().join("wrong.key");
        keygen(&key);
        keygen(&wrong);
        let link = format!("udp:127.0.0.1:{}", free_udp_port());
        let hil = Hilsim::start(dir.path(), "hover", 1.0, 42.0);
        let logs = dir.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        let vehicle = Vehicle::start_linked(&logs, &hil.dev, &link, Some(&key));
        // A gain set over the link, and a value out of its range refused.
        let (ok, text) = ground(
            &link,
            Some(&key),
            &["params", "set", "HOV_MAX_SPEED", "1.5"],
        );
        assert!(ok, "{text}");
        let (ok, text) = ground(&link, Some(&key), &["params", "set", "HOV_MAX_SPEED", "99"]);
        assert!(!ok && text.contains("HOV_MAX_SPEED: 99 refused"), "{text}");
        let (ok, text) = ground(&link, Some(&key), &["connect"]);
        assert!(ok && text.contains("connect: accepted"), "{text}");
        let (ok, text) = ground(
            &link,
            Some(&key),
            &["start", "linked1", "autonomous", "hover"],
        );
        assert!(ok && text.contains("start logging: accepted"), "{text}");
        // While it flies: no ground for 12 s (the link is lost: nothing changes on board). Then,
        // while the operator's ground listens, a Stop without the key and one with the wrong
        // key are refused, a signed command sent twice (a replay) is refused, and garbage is
        // dropped; the operator's ground is told; the flight goes on (the truth decides below).
        std::thread::sleep(Duration::from_secs(12));
        let listener = {
            let (link, key) = (link.clone(), key.clone());
            std::thread::spawn(move || ground(&link, Some(&key), &["status", "--seconds", "8"]))
        };
        std::thread::sleep(Duration::from_millis(1500));
        for bad_key in [None, Some(wrong.as_path())] {
            let (ok, text) = ground(&link, bad_key, &["stop", "--timeout", "2"]);
            assert!(!ok, "a stop with {bad_key:?} was obeyed: {text}");
            // A refused ground is sent nothing, not even why.
            assert!(!text.contains("vehicle ["), "{text}");
        }
        replay_and_garbage(&link, &key);
        let (ok, told) = listener.join().unwrap();
        assert!(ok, "{told}");
        for kind in [
            "refused unsigned",
            "refused wrongly signed",
            "refused replayed",
            "refused stamped in the future",
        ] {
            assert!(
                told.contains(kind),
                "the operator's ground is told '{kind}': {told}"
            );
        }
        let (ok, status) = ground(&link, Some(&key), &["status", "--seconds", "1.5"]);
        assert!(ok, "{status}");
        assert!(
            status.contains("bootstrap flying, mode autonomous"),
            "{status}"
        );
        assert!(status.contains("ATTITUDE"), "{status}");
        let summary = hil.wait_json(Duration::from_secs(90));
        let saved = dir.path().join("ground");
        // The simulated world ended (the helicopter may be blind in the air): the flight is
        // killed, confirmed beforehand; the Stop that follows finds it ended and saves its log.
        let (ok, text) = ground(&link, Some(&key), &["kill", "--confirm"]);
        assert!(ok && text.contains("kill: accepted"), "{text}");
        let (ok, text) = ground(
            &link,
            Some(&key),
            &[
                "--link-id",
                "1",
                "stop",
                "--base-dir",
                &saved.display().to_string(),
                "--suffix",
                "mine",
            ],
        );
        let said = vehicle.output();
        vehicle.quit();
        assert!(
            ok && text.contains("stop: accepted"),
            "{text}\nvehicle:\n{said}"
        );
        assert_eq!(
            summary["outcome"], "pass",
            "{summary:#}\nthe vehicle said:\n{said}"
        );
        assert!(said.contains("refused a frame, unsigned"), "{said}");
        assert!(said.contains("refused a frame, replayed"), "{said}");
        // No ground spoke for 12 s after Start Logging: the link was lost and found again, and
        // the flight went on (the truth passed above).
        assert!(said.contains("link: lost"), "{said}");
        assert!(said.contains("link: ground heard again"), "{said}");
        let downloaded = std::fs::read(saved.join("flight_mine.mcap")).unwrap();
        let onboard = std::fs::read(logs.join("flight_linked1.mcap")).unwrap();
        assert!(downloaded == onboard, "the download is not byte-exact");
        // The flight software heard of the link as the bootstrap did (fresh, lost during the
        // 12 s of silence, fresh again), once per change, and read the battery: device inputs for the safety rule.
        let contents = heli_log::read(&onboard);
        let device: Vec<&serde_json::Value> = contents
            .messages
            .iter()
            .filter(|m| m.topic == "device")
            .map(|m| &m.value)
            .collect();
        let link_states: Vec<bool> = device
            .iter()
            .filter(|v| v["kind"] == "ground_link")
            .filter_map(|v| v["fresh"].as_bool())
            .collect();
        // (It may be lost again while the test waits for the HILSim's end before its Stop.)
        assert!(
            link_states.starts_with(&[true, false, true])
                && link_states.windows(2).all(|w| w[0] != w[1]),
            "ground_link inputs, one per change: {link_states:?}"
        );
        let batteries = device.iter().filter(|v| v["kind"] == "battery").count();
        assert!(
            batteries > 10,
            "{batteries} battery readings in the flight's inputs"
        );
        let replay = heli(&[
            "log",
            "replay",
            &saved.join("flight_mine.mcap").display().to_string(),
        ]);
        assert!(
            replay.status.success(),
            "{}",
            String::from_utf8_lossy(&replay.stdout)
        );
    });
}

/// Sends a signed, harmless command (a message interval) twice over, then random bytes.
fn replay_and_garbage(link: &str, key_path: &Path) {
    use heli_link::ground::GroundLink;
    use heli_link::signing::Key;
    use mavlink::dialects::common::{COMMAND_LONG_DATA, MavCmd};
    let key = Key::from_text(&std::fs::read_to_string(key_path).unwrap()).unwrap();
    let addr = link.trim_start_matches("udp:");
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut g = GroundLink::new(Some(key));
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_micros() as u64;
    let frame = g.command_frame(
        COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: 30.0,
            param2: 0.0,
            ..Default::default()
        },
        now,
    );
    socket.send_to(&frame, addr).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    socket.send_to(&frame, addr).unwrap();
    // A ground whose clock is an hour fast, on link 1: refused, it must lock out no one (the
    // operator's Stop below signs on link 1 too).
    let mut fast = GroundLink::on_link(
        Some(Key::from_text(&std::fs::read_to_string(key_path).unwrap()).unwrap()),
        1,
    );
    let ahead = fast.command_frame(
        COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: 30.0,
            param2: 0.0,
            ..Default::default()
        },
        now + 3_600_000_000,
    );
    socket.send_to(&ahead, addr).unwrap();
    let mut x = 0x9e37_79b9_u32;
    for len in [0usize, 1, 7, 64, 280, 1400] {
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x & 0xFF) as u8
            })
            .collect();
        socket.send_to(&bytes, addr).unwrap();
    }
    std::thread::sleep(Duration::from_millis(200));
}

/// The Python in `.ci/run`'s virtual environment, if there is one (`HELI_PYTHON`).
fn python() -> Option<String> {
    std::env::var("HELI_PYTHON").ok()
}

#[test]
fn pymavlink_talks_to_the_vehicle() {
    crate::procs::void_if_starved(|| {
        let Some(python) = python() else {
            eprintln!(
                "HELI_PYTHON not set: the pymavlink check needs .ci/run's venv; skipped here"
            );
            return;
        };
        let _one = shared();
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("link.key");
        keygen(&key);
        let port = free_udp_port();
        let link = format!("udp:127.0.0.1:{port}");
        let hil = Hilsim::start(dir.path(), "hover", 1.0, 30.0);
        let logs = dir.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        // A log to list and download.
        std::fs::write(
            logs.join("flight_old.mcap"),
            (0..5000u32).map(|i| (i % 251) as u8).collect::<Vec<_>>(),
        )
        .unwrap();
        let vehicle = Vehicle::start_linked(&logs, &hil.dev, &link, Some(&key));
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hil/pymavlink_client.py");
        let out = Command::new(python)
            .arg(&script)
            .args([
                port.to_string(),
                key.display().to_string(),
                logs.join("flight_old.mcap").display().to_string(),
            ])
            .output()
            .unwrap();
        let said = vehicle.output();
        vehicle.quit();
        drop(hil);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "pymavlink client failed:\n{stdout}\n{}\nvehicle:\n{said}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.contains("ALL OK"), "{stdout}");
    });
}
