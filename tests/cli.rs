//! The command-line contract of docs/scenarios.md, run as a user would.

use std::process::Command;

fn heli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"))
}

#[test]
fn sim_hover_json_passes_and_has_the_documented_fields() {
    let out = heli(&["sim", "--scenario", "hover", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert_eq!(v["outcome"], "pass");
    assert_eq!(v["scenario"], "hover");
    for key in [
        "seed",
        "sim_time_s",
        "wall_time_s",
        "realtime_factor",
        "criteria",
        "estimator",
        "loop",
        "maneuvers",
        "log",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    for key in [
        "att_err_rms_deg",
        "att_err_max_deg",
        "pos_err_rms_m",
        "vel_err_rms_mps",
    ] {
        assert!(v["estimator"][key].is_number(), "estimator.{key}");
    }
    for key in [
        "imu_samples",
        "watchdog_fires",
        "control_steps",
        "step_time_max_us",
    ] {
        assert!(v["loop"][key].is_number(), "loop.{key}");
    }
    assert!(v["maneuvers"]["rolls_completed"].is_number());
    for c in v["criteria"].as_array().into_iter().flatten() {
        assert!(
            c["name"].is_string()
                && c["value"].is_number()
                && c["limit"].is_number()
                && c["pass"].is_boolean()
        );
    }
}

#[test]
fn sim_list_names_the_builtin_scenarios() {
    let out = heli(&["sim", "--list"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("hover"));
    // One column of names, as wide as the longest: every description starts at one place.
    let starts: std::collections::BTreeSet<usize> = text
        .lines()
        .filter_map(|l| {
            l.find("  ")
                .map(|i| i + l[i..].len() - l[i..].trim_start().len())
        })
        .collect();
    assert_eq!(starts.len(), 1, "{text}");
    let out = heli(&["sim", "--list", "--json"]);
    assert!(out.status.success());
    let list: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        list.as_array().is_some_and(|a| a
            .iter()
            .any(|s| s["name"] == "hover" && s["description"].is_string())),
        "{list}"
    );
}

#[test]
fn scenario_file_sets_seed_wind_and_imu_drops() {
    let dir = std::env::temp_dir().join(format!("heli-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_default();
    let file = dir.join("drops.toml");
    std::fs::write(&file, "name = \"drops\"\nseed = 9\nwind_ned_mps = [1.0, 0.5, 0.0]\n[faults]\nimu_drop_rate = 0.01\n")
        .unwrap_or_default();
    let out = heli(&[
        "sim",
        "--scenario",
        file.to_str().unwrap_or_default(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert_eq!(v["scenario"], "drops");
    assert_eq!(v["seed"], 9);
    assert!(v["loop"]["watchdog_fires"].as_u64().unwrap_or(0) > 0);
    assert_eq!(v["loop"]["watchdog_fires"], v["loop"]["imu_dropped"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn a_nonsense_number_is_refused_by_its_option_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let ptys = dir.path().display().to_string();
    let flight = dir.path().join("none.mcap").display().to_string();
    let replay = |share| {
        vec![
            "hilsim",
            "--ptys",
            &ptys,
            "--replay",
            &flight,
            "--tolerance-share",
            share,
        ]
    };
    // A negative value reaches the option's own check, which names it (not clap's
    // "unexpected argument '-3'").
    for (args, named) in [
        (vec!["sim", "--duration", "-3"], "--duration"),
        // An address is checked before any process starts.
        (vec!["sim", "--ui", "--http", "bogus"], "--http"),
        (vec!["model", "trim", "--speed", "-3"], "--speed"),
        (vec!["hilsim", "--ptys", &ptys, "--speed", "-3"], "--speed"),
        (replay("2"), "--tolerance-share"),
        (replay("NaN"), "--tolerance-share"),
    ] {
        let out = heli(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was taken");
        assert!(
            err.contains(named) && !err.contains("unexpected argument"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn a_cpu_the_machine_has_not_is_said_by_the_hilsim() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(["hilsim", "--ptys"])
        .arg(dir.path())
        .args(["--cpu", "4095", "--duration", "1"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let first = std::io::BufReader::new(stderr).lines().next();
    let _ = child.kill();
    let _ = child.wait();
    let line = first.unwrap().unwrap();
    assert!(
        line.starts_with("hilsim: loop and device readers ")
            && line.contains("CPU 4095")
            && (line.contains("refused") || line.contains("not pinned")),
        "{line}"
    );
}

#[test]
fn the_lab_tools_say_how_to_build_the_onboard_program_where_it_is_missing() {
    // `cargo build --release` builds `heli` alone: a copy of it with no `heli-vehicle`
    // beside it, as on a fresh clone.
    let dir = tempfile::tempdir().unwrap();
    let alone = dir.path().join("heli");
    std::fs::copy(env!("CARGO_BIN_EXE_heli"), &alone).unwrap();
    let key = dir.path().join("link.key");
    let out = Command::new(&alone)
        .args(["link", "keygen", "--out"])
        .arg(&key)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let run = |args: &[&str]| {
        let out = Command::new(&alone)
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "an error, not a run: {out:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let missing = dir.path().join("heli-vehicle").display().to_string();
    let certify = run(&["certify", "--log-dir", ".", "--key", "link.key"]);
    assert!(
        certify.contains(&format!("the onboard program {missing} is not built"))
            && certify.contains("cargo build --release --workspace")
            && certify.contains("--vehicle"),
        "{certify}"
    );
    // With the onboard program there, directories that are not are said before anything
    // is flown: the defaults are the repository's, relative to where heli runs.
    let onboard = dir.path().join("heli-vehicle");
    std::fs::write(&onboard, b"#!/bin/sh\nexit 1\n").unwrap();
    let suite = run(&["certify", "--log-dir", ".", "--key", "link.key"]);
    assert!(
        suite.contains("--library flights: not a directory") && suite.contains("run from its root"),
        "{suite}"
    );
    std::fs::create_dir(dir.path().join("flights")).unwrap();
    let suite = run(&["certify", "--log-dir", ".", "--key", "link.key"]);
    assert!(
        suite.contains("--suite campaigns/robustness: not a directory"),
        "{suite}"
    );
    std::fs::remove_file(&onboard).unwrap();
    let field_day = run(&["field-day", "--out", "fd"]);
    assert!(
        field_day.contains(&format!("the onboard program {missing} is not built"))
            && field_day.contains("cargo build --release --workspace"),
        "{field_day}"
    );
    assert!(!dir.path().join("fd").exists(), "nothing flown");
}

#[test]
fn unknown_scenario_is_a_clear_error() {
    let out = heli(&["sim", "--scenario", "no-such-flight"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no-such-flight") && err.contains("--list"),
        "{err}"
    );
}

#[test]
fn failed_flight_exits_nonzero_with_a_table() {
    let out = heli(&["sim", "--scenario", "hover", "--duration", "30"]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("hold_duration_s") && text.contains("FAIL"),
        "{text}"
    );
}

#[test]
fn model_trim_modes_and_governor_step_answer_in_json() {
    let out = heli(&["model", "trim", "--speed", "0", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    let collective = v["collective_deg"].as_f64().unwrap_or(0.0);
    assert!((collective - 5.65).abs() <= 0.3, "{v}");
    let out = heli(&["model", "modes", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert!(
        v["roll"]["natural_frequency_rps"].as_f64().unwrap_or(0.0) > 18.0,
        "{v}"
    );
    let out = heli(&["model", "governor-step", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert!(
        v["damping"].is_number() && v["natural_frequency_rps"].is_number(),
        "{v}"
    );
}

#[test]
fn model_rejects_a_speed_outside_the_envelope_and_a_bad_airframe_file() {
    let out = heli(&["model", "trim", "--speed", "60"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("between 0 and 25"));
    let file = std::env::temp_dir().join(format!("heli-airframe-{}.toml", std::process::id()));
    std::fs::write(&file, "mass_kgs = 9.0\n").unwrap_or_default();
    let out = heli(&[
        "model",
        "trim",
        "--airframe",
        file.to_str().unwrap_or_default(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("mass_kgs"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn sim_writes_a_flight_log_that_reads_back_and_survives_being_cut_off() {
    let dir = std::env::temp_dir().join(format!("heli-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_default();
    let log = dir.join("hover.mcap");
    let out = heli(&[
        "sim",
        "--scenario",
        "hover",
        "--json",
        "--log",
        log.to_str().unwrap_or_default(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    assert_eq!(v["log"], log.to_str().unwrap_or_default());

    let info = heli(&["log", "info", log.to_str().unwrap_or_default()]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success() && text.contains("complete"), "{text}");
    for channel in [
        "imu", "state", "servo", "uplink", "gps", "baro", "compass", "events",
    ] {
        assert!(text.contains(channel), "{channel} missing: {text}");
    }
    // As many IMU packets in the log as the main loop handled (received + repeated).
    let imu_logged: u64 = text
        .lines()
        .find(|l| l.trim_start().starts_with("imu"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    let handled = v["loop"]["imu_samples"].as_u64().unwrap_or(0)
        + v["loop"]["watchdog_fires"].as_u64().unwrap_or(0);
    assert_eq!(imu_logged, handled);

    let csv = heli(&[
        "log",
        "export",
        log.to_str().unwrap_or_default(),
        "--channel",
        "state",
    ]);
    let csv = String::from_utf8_lossy(&csv.stdout);
    assert!(csv.starts_with("t_s,") && csv.contains("phase") && csv.lines().count() > 3000);
    // A channel the log lacks: refused with the channels it has.
    let none = heli(&[
        "log",
        "export",
        log.to_str().unwrap_or_default(),
        "--channel",
        "nope",
    ]);
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(
        !none.status.success() && err.contains("its channels: ") && err.contains("state"),
        "{err}"
    );

    // Plots: the default SVG beside the log, a PNG of chosen fields, a clear refusal of an
    // unknown field and of an unknown image format.
    let plot = heli(&[
        "log",
        "plot",
        log.to_str().unwrap_or_default(),
        "--channel",
        "servo",
    ]);
    assert!(
        plot.status.success(),
        "{}",
        String::from_utf8_lossy(&plot.stderr)
    );
    let svg = std::fs::read_to_string(dir.join("hover_servo.svg")).unwrap_or_default();
    assert!(svg.starts_with("<svg") && svg.contains("collective") && svg.contains("rotor_rpm"));
    let log_path = log.to_str().unwrap_or_default();
    let plot_state =
        |extra: &[&str]| heli(&[&["log", "plot", log_path, "--channel", "state"], extra].concat());
    let png = dir.join("attitude.png");
    let png_path = png.to_str().unwrap_or_default();
    let plot = plot_state(&[
        "--field",
        "roll_rad",
        "--field",
        "pos_ned_m",
        "--from",
        "100",
        "--out",
        png_path,
    ]);
    let text = String::from_utf8_lossy(&plot.stdout);
    assert!(plot.status.success() && text.contains("2 panels"), "{text}");
    let bytes = std::fs::read(&png).unwrap_or_default();
    assert!(bytes.starts_with(b"\x89PNG"));
    for (field, out, complaint) in [
        ("rol", "x.svg", "roll_rad"),
        ("roll_rad", "x.jpg", ".svg or .png"),
    ] {
        let out = dir.join(out);
        let refused = plot_state(&["--field", field, "--out", out.to_str().unwrap_or_default()]);
        let why = String::from_utf8_lossy(&refused.stderr);
        assert!(
            refused.status.code() == Some(2) && why.contains(complaint),
            "{why}"
        );
    }

    // A crash cuts the file: what was written before the last closed chunk is still there.
    let bytes = std::fs::read(&log).unwrap_or_default();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap_or_default();
    let info = heli(&["log", "info", cut.to_str().unwrap_or_default()]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.status.success() && text.contains("cut off") && text.contains("state"),
        "{text}"
    );
    let missing = heli(&[
        "log",
        "export",
        cut.to_str().unwrap_or_default(),
        "--channel",
        "nothing",
    ]);
    assert_eq!(missing.status.code(), Some(2));
}

#[test]
fn bench_measures_parsers_control_step_speed_and_memory() {
    let out = heli(&["bench", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    let parsers = v["parsers"].as_array().cloned().unwrap_or_default();
    assert_eq!(parsers.len(), 3);
    for p in &parsers {
        // Every frame of the 8 MB stream was delivered: the parser kept up and lost nothing.
        let frames = p["frames"].as_u64().unwrap_or(0);
        assert!(frames > 200_000, "{p}");
        assert!(p["mb_per_s"].as_f64().unwrap_or(0.0) > 0.0);
    }
    assert!(v["control_step"]["steps"].as_u64().unwrap_or(0) > 3000);
    assert_eq!(v["realtime_factor"].as_array().map(Vec::len), Some(2));
}

fn log_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("heli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_default();
    dir
}

#[test]
fn log_info_gives_rates_gaps_metadata_and_the_faults() {
    let dir = log_dir("log-info");
    let log = dir.join("gps-outage.mcap");
    let log_path = log.to_str().unwrap_or_default();
    let out = heli(&[
        "sim",
        "--scenario",
        "gps-outage",
        "--json",
        "--log",
        log_path,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info = heli(&["log", "info", log_path]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{text}");
    let line = |channel: &str| {
        text.lines()
            .find(|l| l.trim_start().starts_with(&format!("{channel} ")))
            .unwrap_or_default()
            .to_string()
    };
    // Rates per stream, and the foxglove views with their well-known schemas.
    assert!(
        line("imu").contains("100.0 Hz") && line("imu").contains("no gaps"),
        "{text}"
    );
    assert!(line("state").contains("50.0 Hz"), "{text}");
    assert!(
        line("foxglove/tf").contains("[foxglove.FrameTransform]"),
        "{text}"
    );
    assert!(
        line("foxglove/fix").contains("[foxglove.LocationFix]"),
        "{text}"
    );
    assert!(line("foxglove/log").contains("[foxglove.Log]"), "{text}");
    // The 10 s outage is the GPS channel's largest interval.
    let gps = line("gps");
    let gap_s: f64 = gps
        .split(" s before ")
        .next()
        .and_then(|before| before.split_whitespace().last())
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    assert!((9.0..13.0).contains(&gap_s), "{gps}");
    // The metadata, and the outage among the faults with its level.
    assert!(
        text.contains("metadata 'flight'")
            && text.contains("scenario                   gps-outage"),
        "{text}"
    );
    assert!(text.contains("software                   heli "), "{text}");
    assert!(text.contains("wall_clock_start_utc"), "{text}");
    let faults = text.split("faults").nth(1).unwrap_or_default();
    assert!(
        faults.contains("error    t=") && faults.contains("GPS lost"),
        "{text}"
    );
    assert!(
        !faults.contains("phase hold"),
        "routine events are not faults: {text}"
    );
    assert!(text.contains("complete: closed by its writer"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn log_info_refuses_what_is_not_a_log_and_a_log_without_messages() {
    let dir = log_dir("log-refuse");
    let mut empty_mcap = b"\x89MCAP0\r\n".to_vec();
    // Header record (empty profile and library), DataEnd, Footer, magic.
    empty_mcap.extend_from_slice(&[0x01, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    empty_mcap.extend_from_slice(&[0x0f, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    empty_mcap.extend_from_slice(&[0x02, 20, 0, 0, 0, 0, 0, 0, 0]);
    empty_mcap.extend_from_slice(&[0; 20]);
    empty_mcap.extend_from_slice(b"\x89MCAP0\r\n");
    for (name, bytes, complaint) in [
        (
            "text.mcap",
            &b"flight notes, not a log\n"[..],
            "not an MCAP file",
        ),
        ("empty.mcap", &b""[..], "the file is empty"),
        ("no-messages.mcap", &empty_mcap[..], "holds no messages"),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap_or_default();
        let out = heli(&["log", "info", path.to_str().unwrap_or_default()]);
        let why = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {why}");
        assert!(
            why.contains(complaint) && why.contains(name),
            "{name}: {why}"
        );
        let export = heli(&[
            "log",
            "export",
            path.to_str().unwrap_or_default(),
            "--channel",
            "imu",
        ]);
        assert_eq!(export.status.code(), Some(2), "{name}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn log_info_on_a_damaged_log_shows_what_it_read_then_fails_without_panicking() {
    let dir = log_dir("log-damaged");
    let log = dir.join("hover.mcap");
    let log_path = log.to_str().unwrap_or_default();
    let out = heli(&[
        "sim",
        "--scenario",
        "hover",
        "--duration",
        "30",
        "--log",
        log_path,
    ]);
    assert!(
        out.status.code().is_some(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut bytes = std::fs::read(&log).unwrap_or_default();
    let middle = bytes.len() / 2;
    for b in bytes.iter_mut().skip(middle).take(200) {
        *b ^= 0xa5;
    }
    let damaged = dir.join("damaged.mcap");
    std::fs::write(&damaged, &bytes).unwrap_or_default();
    let info = heli(&["log", "info", damaged.to_str().unwrap_or_default()]);
    let (text, why) = (
        String::from_utf8_lossy(&info.stdout),
        String::from_utf8_lossy(&info.stderr),
    );
    assert_eq!(info.status.code(), Some(2), "{text}{why}");
    assert!(why.contains("damaged") && why.contains("byte"), "{why}");
    assert!(text.contains("imu "), "what was read is shown: {text}");
    assert!(!why.contains("panicked"), "{why}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_sim_leaves_a_log_that_reads_to_its_last_flush() {
    let dir = log_dir("log-killed");
    let log = dir.join("demo.mcap");
    let mut child = Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(["sim", "--log", log.to_str().unwrap_or_default()])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"));
    // Kill it mid-flight, once the log holds a few hundred kilobytes.
    let start = std::time::Instant::now();
    while std::fs::metadata(&log).map_or(0, |m| m.len()) < 300_000
        && start.elapsed() < std::time::Duration::from_secs(60)
    {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let _ = child.kill();
    let finished = child.wait().is_ok_and(|s| s.success());
    let info = heli(&["log", "info", log.to_str().unwrap_or_default()]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&info.stderr)
    );
    assert!(text.contains("imu "), "{text}");
    if !finished {
        // Between flushes the file is whole up to its last one.
        assert!(
            text.contains("not closed by its writer") || text.contains("cut off"),
            "{text}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_reader_that_stops_early_is_no_crash() {
    use std::io::{BufRead, BufReader};
    // `heli sim --list | head -1`: the rest of the output meets a closed pipe.
    let mut child = Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(["sim", "--list"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"));
    let stdout = child.stdout.take().unwrap_or_else(|| panic!("no stdout"));
    let mut first = String::new();
    let _ = BufReader::new(stdout).read_line(&mut first);
    // The pipe closes here, with most of the list unread.
    let out = child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("heli did not end: {e}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(first.starts_with("demo"), "{first}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.status.success(), "{:?} {stderr}", out.status);
}

#[test]
fn field_day_refuses_unknown_faults_phases_and_a_python_without_the_reader() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().display().to_string();
    let cases: [(&[&str], &str); 3] = [
        (
            &["--faults", "meteor"],
            "no fault 'meteor': the faults are kill-flight",
        ),
        (&["--phases", "loop"], "no phase 'loop'"),
        (
            &["--faults", "stall-1", "--python", "/nonexistent/python"],
            "cannot import the official MCAP reader",
        ),
    ];
    for (extra, says) in cases {
        let mut args = vec!["field-day", "--out", &out_dir];
        args.extend_from_slice(extra);
        let out = heli(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} ran");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}
