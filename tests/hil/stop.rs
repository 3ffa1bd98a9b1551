//! Stop in the air (issue: a Stop during a hover used to kill the flight process and drop the
//! helicopter): the vehicle lands where it is first and the flight ends on the skids; the
//! bootstrap does not quit meanwhile; the truth sees no crash; the log records the Stop as an
//! input, and its replay answers it the same way.

use std::time::Duration;

use crate::procs::{Hilsim, Vehicle, heli};

#[test]
fn a_stop_in_a_hover_lands_first_and_ends_the_flight_on_the_ground() {
    crate::procs::void_if_starved(|| {
        let _one = crate::shared();
        let dir = tempfile::tempdir().unwrap();
        // At four times real time: the subject is what the vehicle does, not its timing.
        let hil = Hilsim::start_with(dir.path(), "hover", 4.0, 80.0);
        let vehicle = Vehicle::start_with(dir.path(), &hil.dev, 4.0);
        assert!(vehicle.ctl(&["connect"]).starts_with("ok connected"));
        let reply = vehicle.ctl(&["start-logging", "stopair", "autonomous", "hover"]);
        assert!(reply.starts_with("ok flying"), "{reply}");
        vehicle.wait_for_line("phase hold", Duration::from_secs(30));
        std::thread::sleep(Duration::from_secs(1));
        let reply = vehicle.ctl(&["stop"]);
        assert!(
            reply.starts_with("ok landing first: the flight ends on the ground"),
            "{reply}\n{}",
            vehicle.output()
        );
        // The bootstrap does not quit under a helicopter in the air, and says why.
        let reply = vehicle.ctl(&["quit"]);
        assert!(
            reply.contains("not quitting: the helicopter is in the air"),
            "{reply}"
        );
        // A kill without its confirmation is refused and says what it would do.
        let reply = vehicle.ctl(&["kill"]);
        assert!(reply.contains("the helicopter falls"), "{reply}");
        vehicle.wait_for_line("phase land", Duration::from_secs(5));
        vehicle.wait_for_line(
            "stop: on the ground, the flight ends",
            Duration::from_secs(40),
        );
        vehicle.wait_for_line("flight process stopped cleanly", Duration::from_secs(10));
        let summary = hil.wait_json(Duration::from_secs(60));
        let said = vehicle.output();
        vehicle.quit();
        assert!(
            summary["crash"].is_null(),
            "the truth saw a crash: {summary:#}\nthe vehicle said:\n{said}"
        );
        // The Stop is an input of the flight's log; the replay answers it the same way.
        let log = dir.path().join("flight_stopair.mcap");
        let replay = heli(&["log", "replay", &log.display().to_string()]);
        let text = String::from_utf8_lossy(&replay.stdout);
        assert!(replay.status.success(), "{text}");
        assert!(text.contains("EXACT MATCH"), "{text}");
        let contents = heli_log::read(&std::fs::read(&log).unwrap());
        let stops = contents
            .messages
            .iter()
            .filter(|m| m.topic == "device" && m.value["kind"] == "stop_requested")
            .count();
        // The operator's Stop, and the one the refused quit asked first.
        assert_eq!(stops, 2, "the Stops among the flight's inputs");
    });
}
