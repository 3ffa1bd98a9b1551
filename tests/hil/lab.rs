//! The field flies what the lab tested (thesis §4.3): `heli certify` replays the regression
//! library (`flights/`) to the onboard program and flies a robustness suite with the
//! vehicle's parameters, and signs an attestation; the vehicle in the field (linked, keyed,
//! no bench override) says "lab-tested" and the operator's display shows it. One gain set
//! over the link flips it to "NOT lab-tested" naming the gain; an autonomous start then
//! needs the operator's override (the display asks), which the flight's log records, and
//! without it the vehicle refuses.

use std::path::Path;
use std::time::Duration;

use crate::display::{browser_test, run_page_script_env, tail};
use crate::procs::{Display, Hilsim, Vehicle, free_udp_port, ground, heli, log_info};

#[test]
fn a_certified_build_is_lab_tested_and_a_changed_gain_needs_the_override() {
    crate::procs::void_if_starved(|| {
        let Some((ui, _one)) = browser_test() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("key");
        assert!(
            heli(&["link", "keygen", "--out", &key.display().to_string()])
                .status
                .success()
        );
        let vehicle_dir = dir.path().join("vehicle");
        std::fs::create_dir_all(&vehicle_dir).unwrap();
        // A small suite: the test is of the attestation, not of the suite (docs/security.md).
        let suite = dir.path().join("suite");
        std::fs::create_dir_all(&suite).unwrap();
        std::fs::write(
        suite.join("hover.toml"),
        "name = \"hover\"\ndescription = \"two seeds\"\nbase = \"hover\"\nseed = 5\nsamples = 2\n",
    )
    .unwrap();
        let library = Path::new(env!("CARGO_MANIFEST_DIR")).join("flights");
        let out = heli(&[
            "certify",
            "--log-dir",
            &vehicle_dir.display().to_string(),
            "--key",
            &key.display().to_string(),
            "--library",
            &library.display().to_string(),
            "--suite",
            &suite.display().to_string(),
        ]);
        let said = String::from_utf8_lossy(&out.stdout).to_string();
        eprintln!("{said}{}", String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "certify failed:\n{said}");
        assert!(
            said.contains("accepted") && said.contains("outcome    certified"),
            "{said}"
        );

        let hil = Hilsim::start(dir.path(), "hover", 1.0, 120.0);
        let link = format!("udp:127.0.0.1:{}", free_udp_port());
        let vehicle = Vehicle::start_in_the_field(&vehicle_dir, &hil.dev, &link, &key);
        let status = vehicle.ctl(&["status"]);
        assert!(status.contains("\"lab\":\"lab-tested: build"), "{status}");
        let saves = dir.path().join("saves");
        let display = Display::start(&link, Some(&key), &saves);
        let page = |env: &[(&str, &str)]| {
            let (run, said, _) = run_page_script_env(&ui, "lab", "HELI_UI_URL", &display.url, env);
            assert!(
                run.success(),
                "the lab page failed:\n{}\nthe vehicle said:\n{}",
                tail(&said, 30),
                tail(&vehicle.output(), 30)
            );
            said
        };
        page(&[
            ("HELI_LAB_EXPECT", "lab-tested"),
            ("HELI_LAB_TAG", "tested"),
        ]);

        // One gain changed over the link's parameter protocol.
        let (ok, said) = ground(&link, Some(&key), &["params", "set", "HOV_VEL_P", "1.6"]);
        assert!(ok, "{said}");
        vehicle.wait_for_line(
            "NOT lab-tested: parameters changed",
            Duration::from_secs(10),
        );
        let said = page(&[
            ("HELI_LAB_EXPECT", "NOT lab-tested"),
            ("HELI_LAB_WHY", "HOV_VEL_P 1.6 (tested 1.4)"),
            ("HELI_LAB_START", "1"),
            ("HELI_LAB_TAG", "untested"),
        ]);
        assert!(
            said.contains("\"dialog\":\"NOT lab-tested: parameters changed"),
            "{said}"
        );
        vehicle.wait_for_line("by the operator's override", Duration::from_secs(10));
        vehicle.ctl(&["kill", "confirmed"]);
        // The flight's log records the statement and whose override it flew on.
        let info = log_info(&vehicle_dir.join("flight_untested1.mcap"));
        assert!(
            info.contains("lab_override               operator"),
            "{info}"
        );
        assert!(info.contains("HOV_VEL_P 1.6 (tested 1.4)"), "{info}");
        // Without the override the vehicle itself refuses, whatever the ground does.
        assert!(vehicle.ctl(&["connect"]).starts_with("ok connected"));
        let refused = vehicle.ctl(&["start-logging", "again", "autonomous", "hover"]);
        assert!(
            refused.contains("autonomous flight needs the operator's override"),
            "{refused}"
        );
        // Manual flight is the pilot's: flown, and said.
        let manual = vehicle.ctl(&["start-logging", "again", "manual"]);
        assert!(manual.starts_with("ok flying"), "{manual}");
        vehicle.ctl(&["kill", "confirmed"]);
        display.stop();
        vehicle.quit();
        drop(hil);
    });
}
