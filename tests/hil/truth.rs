//! The operator's truth: what the ground display shows never contradicts the vehicle. Three
//! flights from the display in headless Chromium (`tests/ui/truth.mjs`) with faults from the
//! HILSim's trainer panel — a refused take-off, a GPS outage, an IMU stall, a draining pack —
//! while the page (what the operator sees) and the vehicle (its bootstrap's status and the
//! flight process's telemetry) are sampled every 0.5 s (the vehicle every 0.2 s). Every lamp, meter, verdict and header
//! state on the page must match what the vehicle was within 1 s: not one disagreement. The
//! three logs saved are the vehicle's three, byte for byte.

use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use heli_control::safety::{AUTOMATIC, Condition, Facts};
use serde_json::Value;

use crate::display::{browser_test, run_page_script_with, tail};
use crate::procs::{Display, Vehicle, free_udp_port, heli, vehicle_program};
use crate::view::hilsim_with_view;

/// The bootstrap's passing states, each with the state before it and the state after it.
const TRANSIT: [(&str, &str, &str); 3] = [
    ("connecting", "idle", "connected"),
    ("starting", "connected", "flying"),
    ("stopping", "flying", "idle"),
];

/// How far apart in time a page's state and the vehicle's may be and still agree.
const WITHIN_MS: u64 = 1000;

fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// The vehicle as it is: what each display element should say.
#[derive(Clone, Debug)]
struct Truth {
    /// When the status was asked for (Unix ms).
    asked_ms: u64,
    /// When its answer came back (Unix ms): the state held at some moment between the two.
    t_ms: u64,
    /// The bootstrap's state.
    state: String,
    /// The phase flown (none without a flight's telemetry).
    phase: Option<String>,
    /// The GPS lamp should be green: the GPS on time with five satellites or more.
    gps_green: bool,
    /// The battery meter should be green (None: no reading).
    battery_green: Option<bool>,
    /// The automatic rule on the vehicle's own facts, and no take-off refusal standing.
    automatic: bool,
    /// A take-off refusal stands.
    refused: bool,
}

/// The times `device`'s watchdog has found it late, silent or failed, as `status` says.
fn lapses(status: &Value, device: &str) -> u64 {
    status["telemetry"]["health"]
        .as_array()
        .and_then(|all| all.iter().find(|h| h["device"] == device))
        .and_then(|h| h["lapses"].as_u64())
        .unwrap_or(0)
}

/// The devices whose lapses rose from one status to the next: not on time at some moment
/// between the two, though each may say `ok` (an IMU late for 50 ms between two polls).
fn lapsed_between(before: &Value, after: &Value) -> Vec<String> {
    after["telemetry"]["health"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|h| h["device"].as_str())
        .filter(|d| lapses(after, d) > lapses(before, d))
        .map(str::to_string)
        .collect()
}

/// The vehicle's state from its status, with the devices in `lapsed` not on time.
fn truth_of(asked_ms: u64, t_ms: u64, status: &Value, lapsed: &[String]) -> Truth {
    let state = status["state"].as_str().unwrap_or("?").to_string();
    let tel = &status["telemetry"];
    let flying = state == "flying" && tel.is_object();
    // The flight core's phase now (the heartbeat's), whether or not an estimate is current.
    let phase = tel["phase"]
        .as_str()
        .or_else(|| tel["state"]["phase"].as_str())
        .filter(|_| flying)
        .map(str::to_string);
    let health = |device: &str| {
        !lapsed.iter().any(|d| d == device)
            && tel["health"].as_array().is_some_and(|all| {
                all.iter()
                    .any(|h| h["device"] == device && h["state"] == "ok")
            })
    };
    let satellites = tel["gps"]["satellites"].as_u64().unwrap_or(0);
    // The vehicle's own verdict on each pack: its gauge's level (latched: a warning is not
    // withdrawn by a charge that bounces back), not the charge judged again here.
    let packs = tel["power"]["batteries"].as_array();
    let packs_good = packs.is_none_or(|b| b.iter().all(|p| p["level"] == "good"));
    let battery_green = packs
        .and_then(|b| b.iter().find(|p| p["name"] == "flight"))
        .map(|p| p["level"] == "good")
        .filter(|_| flying);
    // The estimate runs: calibrated, current (the vehicle reports no estimate that has stopped
    // coming: an IMU stall in manual flight on the ground loses it for the flight), and not in
    // a failsafe of a lost estimate.
    let calibrated = tel["state"].is_object()
        && phase
            .as_deref()
            .is_some_and(|p| !matches!(p, "calibrating" | "blind-descent"));
    let refused = phase.as_deref() == Some("takeoff-refused");
    let facts = Facts::none()
        .with(Condition::Calibrated, calibrated)
        .with(Condition::Imu, flying && health("imu"))
        .with(Condition::Uplink, flying && health("uplink"))
        .with(Condition::Gps, flying && health("gps"))
        .with(Condition::Satellites, flying && satellites >= 5)
        .with(Condition::Altimeter, flying && health("baro"))
        .with(Condition::Compass, flying && health("compass"))
        .with(
            Condition::Battery,
            battery_green == Some(true) && packs_good,
        )
        .with(Condition::Link, true)
        .with(Condition::Bypass, tel["uplink"]["bypass"] == true);
    Truth {
        asked_ms,
        t_ms,
        state,
        phase,
        gps_green: flying && health("gps") && satellites >= 5,
        battery_green,
        automatic: AUTOMATIC.judge(facts).allowed && !refused,
        refused,
    }
}

/// The disagreements of one page sample with the vehicle's states around it: each element
/// must match one of the vehicle's states within [`WITHIN_MS`].
fn disagreements(page: &Value, near: &[&Truth]) -> Vec<String> {
    let header = page["header"].as_str().unwrap_or("");
    let any = |f: &dyn Fn(&Truth) -> bool| near.iter().any(|t| f(t));
    let mut wrong = Vec::new();
    // A passing state (connecting, starting, stopping) can fall between two of the
    // vehicle's samples: it agrees when the vehicle was in the state before it and then in
    // the state after it, within the window.
    let passed_through = TRANSIT.iter().any(|(passing, before, after)| {
        header.starts_with(&format!("vehicle: {passing}"))
            && near
                .iter()
                .enumerate()
                .any(|(i, a)| a.state == *before && near.iter().skip(i).any(|b| b.state == *after))
    });
    if !passed_through
        && !any(&|t| {
            header.contains(&format!("vehicle: {}", t.state))
                && t.phase.as_ref().is_none_or(|p| header.contains(p.as_str()))
        })
    {
        wrong.push(format!("header '{header}'"));
    }
    let lamp_green = page["lamp"] == "green";
    if !any(&|t| t.gps_green == lamp_green) {
        wrong.push(format!("GPS lamp {}", page["lamp"]));
    }
    let battery = match page["battery"].as_str() {
        Some("green") => Some(true),
        Some("red") => Some(false),
        _ => None,
    };
    // A meter with no reading, or a stale one (grey), agrees with a vehicle that sends none.
    if !any(&|t| t.battery_green == battery) {
        wrong.push(format!("battery meter {}", page["battery"]));
    }
    let automatic = page["automatic"] == true;
    if !any(&|t| t.automatic == automatic) {
        wrong.push(format!(
            "automatic verdict {automatic} (the page: {})",
            page["failing"]
        ));
    }
    let standing = page["standing"].is_string();
    if !any(&|t| t.refused == standing) {
        wrong.push(format!("standing refusal {}", page["standing"]));
    }
    wrong
}

/// The vehicle's answers (`asked_ms t_ms json` lines) told as the changes of its flight
/// process, state and phase: when (ms from the first answer), the process's own time and
/// how its predecessor ended — what a failed page wait needs to be explained.
fn phase_story(answers: &str) -> String {
    let mut story = String::new();
    let mut first_ms = None;
    let mut last = None;
    for line in answers.lines() {
        let mut words = line.splitn(3, ' ');
        let (Some(asked), Some(_), Some(json)) = (words.next(), words.next(), words.next()) else {
            continue;
        };
        let (Ok(asked_ms), Ok(v)) = (asked.parse::<u64>(), serde_json::from_str::<Value>(json))
        else {
            continue;
        };
        let at_ms = asked_ms.saturating_sub(*first_ms.get_or_insert(asked_ms));
        let telemetry = &v["telemetry"];
        let now = (
            v["pid"].clone(),
            v["state"].clone(),
            telemetry["phase"].clone(),
        );
        if last.as_ref() != Some(&now) {
            story.push_str(&format!(
                "{at_ms:>7} ms: pid {} {} {} (process t {} us, last exit {})\n",
                now.0, now.1, now.2, telemetry["t_us"], v["last_exit"]
            ));
            last = Some(now);
        }
    }
    story
}

#[test]
fn the_display_never_contradicts_the_vehicle_through_three_flights_with_faults() {
    crate::procs::void_if_starved(|| {
        let Some((ui, _one)) = browser_test() else {
            return;
        };
        let _ = std::fs::remove_dir_all(
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("ui-artifacts/truth"),
        );
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("link.key");
        assert!(
            heli(&["link", "keygen", "--out", &key.display().to_string()])
                .status
                .success()
        );
        let link = format!("udp:127.0.0.1:{}", free_udp_port());
        let dev = dir.path().join("dev");
        let scenario = ui.join("truth-flight.toml").display().to_string();
        let (hil, view_url) =
            hilsim_with_view(&dev.display().to_string(), &scenario, "400", &["--pilot"]);
        let logs = dir.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        let vehicle = Vehicle::start_linked(&logs, &dev, &link, Some(&key));
        let saved = dir.path().join("saved");
        let display = Display::start(&link, Some(&key), &saved);

        // The vehicle's side, sampled as the page is.
        let socket = logs.join("ctl.sock").display().to_string();
        let done = Arc::new(AtomicBool::new(false));
        let truths = Arc::new(Mutex::new(Vec::<Truth>::new()));
        // Every answer as it came, kept with the page's artifacts to explain a disagreement.
        let answers = Arc::new(Mutex::new(String::new()));
        let sampler = {
            let (done, truths) = (Arc::clone(&done), Arc::clone(&truths));
            let answers = Arc::clone(&answers);
            std::thread::spawn(move || {
                let mut previous: Option<(u64, Value)> = None;
                while !done.load(Ordering::Relaxed) {
                    let asked_ms = unix_ms();
                    let out = Command::new(vehicle_program())
                        .args(["ctl", "status", "--socket", &socket])
                        .output();
                    let t_ms = unix_ms();
                    if let Ok(out) = out {
                        let text = String::from_utf8_lossy(&out.stdout);
                        let json = text.trim().trim_start_matches("ok ");
                        answers
                            .lock()
                            .unwrap()
                            .push_str(&format!("{asked_ms} {t_ms} {json}\n"));
                        if let Ok(v) = serde_json::from_str::<Value>(json) {
                            let mut truths = truths.lock().unwrap();
                            // A device that lapsed between the last poll and this one was
                            // not on time at some moment between them, as the telemetry
                            // (sent at other moments) may have shown.
                            if let Some((before_ms, before)) = &previous {
                                let lapsed = lapsed_between(before, &v);
                                if !lapsed.is_empty() {
                                    truths.push(truth_of(*before_ms, asked_ms, before, &lapsed));
                                }
                            }
                            truths.push(truth_of(asked_ms, t_ms, &v, &[]));
                            previous = Some((t_ms, v));
                        }
                    }
                    std::thread::sleep(Duration::from_millis(200));
                }
            })
        };
        let (run, said, shots) = run_page_script_with(
            &ui,
            "truth",
            &view_url,
            &[("HELI_UI_URL", display.url.as_str())],
        );
        done.store(true, Ordering::Relaxed);
        sampler.join().unwrap();
        let vehicle_said = vehicle.output();
        display.stop();
        vehicle.quit();
        drop(hil);
        let answers = answers.lock().unwrap().clone();
        let _ = std::fs::write(
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("ui-artifacts/truth/vehicle-said.txt"),
            answers.as_bytes(),
        );
        assert!(
            run.success(),
            "the page script failed:\n{}\nthe vehicle's phases as sampled:\n{}\nthe vehicle said:\n{}",
            tail(&said, 30),
            phase_story(&answers),
            tail(&vehicle_said, 60)
        );

        let steps: Vec<Value> = said
            .lines()
            .filter_map(|l| l.strip_prefix("STEP "))
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        let step = |name: &str| {
            steps
                .iter()
                .find(|s| s["step"] == name)
                .unwrap_or_else(|| {
                    panic!("no step {name} in what the page said:\n{}", tail(&said, 30))
                })
                .clone()
        };
        // Page against vehicle, sample by sample.
        let truths = truths.lock().unwrap().clone();
        let pages: Vec<Value> = said
            .lines()
            .filter_map(|l| l.strip_prefix("SAMPLE "))
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        assert!(pages.len() > 200, "{} page samples", pages.len());
        assert!(truths.len() > 200, "{} vehicle samples", truths.len());
        let mut wrong = Vec::new();
        let mut compared = 0;
        for p in &pages {
            let t = p["t_ms"].as_u64().unwrap();
            let near: Vec<&Truth> = truths
                .iter()
                .filter(|v| v.t_ms + WITHIN_MS >= t && v.asked_ms <= t + WITHIN_MS)
                .collect();
            // Judged only where the vehicle's state is known on both sides of the page's sample:
            // one answer that came back before it and one asked for after it, within the window.
            // A starved host that answers no status for a second leaves a gap nothing can judge.
            let known_before = near.iter().any(|v| v.t_ms <= t);
            let known_after = near.iter().any(|v| v.asked_ms >= t);
            if !(known_before && known_after) {
                continue;
            }
            compared += 1;
            for w in disagreements(p, &near) {
                wrong.push(format!("at {t}: {w} (vehicle: {:?})", near.last()));
            }
        }
        assert!(compared > 200, "only {compared} samples compared");
        eprintln!(
            "operator truth: {compared} page samples compared with {} vehicle samples, {} disagreements",
            truths.len(),
            wrong.len()
        );
        assert!(
            wrong.is_empty(),
            "{} disagreements of {compared} samples:\n{}",
            wrong.len(),
            wrong.join("\n")
        );

        // The GPS lamp leaves green within 1.5 s of the GPS's last fix (half a second after the
        // next one was due): timed by the page from that fix's arrival, and by the fix's age.
        let lamp = step("gps-lamp");
        let after_fix_ms = lamp["after_last_fix_ms"].as_u64().unwrap();
        let age_s = lamp["fix_age_shown_s"].as_f64().unwrap();
        assert!(
            after_fix_ms <= 1500 && age_s <= 1.5,
            "the GPS lamp left green {after_fix_ms} ms after the last fix, at a fix age of {age_s} s: {lamp}"
        );
        // A refused take-off stands, and the verdict never says safe meanwhile.
        assert!(step("refused-after-satellites-back")["standing"].is_string());
        // The fatal event is above the fold a minute later.
        let fold = step("fatal-above-the-fold");
        assert!(
            fold["text"].as_str().unwrap().contains("imu silent"),
            "{fold}"
        );

        // Three flights, three saves: three different files, each the vehicle's own.
        for (saved_as, onboard) in [("one", "one"), ("two", "two"), ("three", "three")] {
            let downloaded = std::fs::read(saved.join(format!("truth/flight_{saved_as}.mcap")))
                .unwrap_or_else(|e| {
                    panic!(
                        "flight_{saved_as}.mcap was not saved ({e}):\n{}",
                        tail(&said, 30)
                    )
                });
            let log = std::fs::read(logs.join(format!("flight_{onboard}.mcap"))).unwrap();
            assert!(
                downloaded == log,
                "flight_{saved_as}.mcap is not the vehicle's log"
            );
        }
        for shot in [
            "01-takeoff-refused",
            "02-refusal-stands",
            "03-gps-silent",
            "04-fatal-pinned-after-notices",
        ] {
            assert!(
                shots.join(format!("{shot}.png")).exists(),
                "no screenshot {shot}"
            );
        }
    });
}
