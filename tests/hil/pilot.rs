//! Pilot in the loop (`heli hilsim --view --pilot`): a person's sticks and switches from the
//! view's page reach the simulated receiver and servo controller board, and the vehicle's
//! flight software flies on them. Driven in headless Chromium (`tests/ui/pilot.mjs`): in
//! manual with a synthetic gamepad (lift-off on the collective, a roll to the right on the
//! right cyclic), then in the augmented velocity mode with the keyboard (a climb, forward
//! flight), the bypass switch handing the servos to the sticks and back, the trainer's
//! panel, the stick settings kept across a reload. Both flights are logged by the vehicle.

use crate::display::{browser_test, run_page_script_with, tail};
use crate::procs::Vehicle;
use crate::view::hilsim_with_view;
use std::path::Path;
use std::time::Duration;

fn steps(said: &str) -> Vec<serde_json::Value> {
    said.lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

fn step<'a>(all: &'a [serde_json::Value], name: &str, said: &str) -> &'a serde_json::Value {
    all.iter()
        .find(|v| v["step"] == name)
        .unwrap_or_else(|| panic!("no {name} step in\n{}", tail(said, 30)))
}

#[test]
fn a_person_flies_the_simulated_helicopter_from_the_page_in_manual_augmented_and_bypass() {
    crate::procs::void_if_starved(|| {
        let Some((ui, _one)) = browser_test() else {
            return;
        };
        let _ = std::fs::remove_dir_all(
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("ui-artifacts/pilot"),
        );
        let dir = tempfile::tempdir().unwrap();
        let dev = dir.path().join("dev");
        let dev_s = dev.display().to_string();
        let (hil, url) = hilsim_with_view(&dev_s, "hover", "400", &["--pilot"]);
        let vehicle = Vehicle::start(dir.path(), &dev);
        assert!(vehicle.ctl(&["connect"]).starts_with("ok connected"));

        let reply = vehicle.ctl(&["start-logging", "pilot-manual", "manual", "hover"]);
        assert!(reply.starts_with("ok flying"), "{reply}");
        // The flight software flies manual (not the board passing the receiver through while
        // the flight process starts).
        vehicle.wait_for_line("phase manual", Duration::from_secs(30));
        let (run, said, _) =
            run_page_script_with(&ui, "pilot", &url, &[("HELI_PILOT_PHASE", "manual")]);
        assert!(
            run.success(),
            "the manual phase failed:\n{}",
            tail(&said, 30)
        );
        let manual = steps(&said);
        // One transmitter: a second page could not take it, and its sticks never reached the
        // simulator's receiver (checked on the ground after the manual flight).
        let second = step(&manual, "second-pilot-refused", &said);
        assert!(
            second["max_collective_stick"].as_f64().unwrap() < 0.2,
            "{second}"
        );
        assert!(
            second["refusal"]
                .as_str()
                .unwrap()
                .contains("holds the transmitter"),
            "{second}"
        );
        assert!(
            step(&manual, "manual-holding", &said)["source"]
                .as_str()
                .unwrap()
                .starts_with("gamepad")
        );
        let roll = &step(&manual, "manual-roll-right", &said)["roll_change_deg"];
        assert!(roll.as_f64().unwrap() > 5.0, "{roll}");
        vehicle.ctl(&["kill", "confirmed"]);

        assert!(vehicle.ctl(&["connect"]).starts_with("ok connected"));
        let reply = vehicle.ctl(&["start-logging", "pilot-velocity", "velocity", "hover"]);
        assert!(reply.starts_with("ok flying"), "{reply}");
        // The transmitter is the page's, and no page holds it now: once calibrated, the flight
        // waits on the ground with the signal lost until the page takes it. (Before the flight
        // process flies, the board passes the sticks straight through: no collective then.)
        let end = std::time::Instant::now() + Duration::from_secs(30);
        while !vehicle
            .output()
            .rsplit("flight_pilot-velocity")
            .next()
            .unwrap_or_default()
            .contains("phase ground-failsafe")
        {
            assert!(std::time::Instant::now() < end, "{}", vehicle.output());
            std::thread::sleep(Duration::from_millis(100));
        }
        let (run, said, shots) =
            run_page_script_with(&ui, "pilot", &url, &[("HELI_PILOT_PHASE", "augmented")]);
        std::thread::sleep(Duration::from_millis(500));
        let flown = vehicle.output();
        vehicle.ctl(&["kill", "confirmed"]);
        vehicle.quit();
        drop(hil);
        assert!(
            run.success(),
            "the augmented phase failed:\n{}\nthe vehicle said:\n{}",
            tail(&said, 30),
            tail(&flown, 30)
        );
        // The flight software flew the augmented mode, and the bypass made it stand aside.
        let velocity_flight = flown
            .rsplit("flight_pilot-velocity")
            .next()
            .unwrap_or_default();
        let augmented = velocity_flight
            .find("phase augmented-velocity")
            .unwrap_or_else(|| panic!("no augmented flight in\n{flown}"));
        assert!(
            velocity_flight[augmented..].contains("phase manual"),
            "the bypass did not show in\n{velocity_flight}"
        );
        let aug = steps(&said);
        assert_eq!(step(&aug, "augmented-holding", &said)["source"], "keyboard");
        assert!(
            step(&aug, "augmented-forward", &said)["forward_mps"]
                .as_f64()
                .unwrap()
                > 1.0
        );
        let direct = step(&aug, "bypass-direct", &said);
        let (stick, servo) = (
            direct["aileron_stick"].as_f64().unwrap(),
            direct["aileron_servo"].as_f64().unwrap(),
        );
        assert!(stick > 0.4 && (stick - servo).abs() < 0.02, "{direct}");
        let trainer = step(&aug, "trainer", &said)["trainer"].to_string();
        assert!(trainer.contains("GPS outage for 15 s"), "{trainer}");
        assert!(trainer.contains("refused: seconds -3"), "{trainer}");
        // The first page closed holding the transmitter: the signal was lost, and came back
        // with the second.
        assert!(trainer.contains("transmitter signal lost"), "{trainer}");
        assert!(trainer.contains("transmitter signal back"), "{trainer}");
        for shot in [
            "02-augmented-forward",
            "02-second-pilot-refused",
            "03-bypass",
        ] {
            assert!(shots.join(format!("{shot}.png")).exists(), "no {shot}");
        }
        // Both flights were logged like any other.
        let logs: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().to_string())
            .filter(|n| n.ends_with(".mcap"))
            .collect();
        for suffix in ["pilot-manual", "pilot-velocity"] {
            assert!(
                logs.iter().any(|n| n.contains(suffix)),
                "no log of {suffix} in {logs:?}"
            );
        }
    });
}
