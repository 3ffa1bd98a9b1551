//! `heli log replay`: a flight log's recorded device inputs, fed to a fresh flight computer,
//! give the logged servo commands and state estimates bit for bit; one corrupted byte is
//! found and located.

use std::path::Path;
use std::process::Command;

fn heli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"))
}

/// Copies a log, changing one byte of the first IMU input at or after `at_us`.
fn corrupt_one_byte(from: &Path, to: &Path, at_us: u64) -> u64 {
    let contents = heli_log::read(&std::fs::read(from).unwrap());
    let mut log = heli_log::FlightLog::create(to).unwrap();
    for m in &contents.metadata {
        log.write_metadata(&m.name, &m.entries).unwrap();
    }
    let mut corrupted_at = None;
    for m in &contents.messages {
        let mut value = m.value.clone();
        if corrupted_at.is_none()
            && m.topic == "device"
            && m.t_us >= at_us
            && value["port"] == "imu"
            && value["hex"].as_str().is_some_and(|h| h.len() >= 12)
        {
            let hex = value["hex"].as_str().unwrap().to_string();
            // The sixth byte (a gyro byte): flip its low bit.
            let byte = u8::from_str_radix(&hex[10..12], 16).unwrap() ^ 0x01;
            let changed = format!("{}{byte:02x}{}", &hex[..10], &hex[12..]);
            value["hex"] = changed.into();
            corrupted_at = Some(m.t_us);
        }
        log.write(&m.topic, m.t_us, &value).unwrap();
    }
    log.finish().unwrap();
    corrupted_at.expect("no IMU input to corrupt")
}

#[test]
fn a_lockstep_log_replays_exactly_and_a_corrupted_byte_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("hover.mcap");
    let log_s = log.display().to_string();
    let out = heli(&[
        "sim",
        "--scenario",
        "hover",
        "--duration",
        "100",
        "--log",
        &log_s,
    ]);
    assert!(out.status.success() || out.status.code() == Some(1));

    let out = heli(&["log", "replay", &log_s]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("EXACT MATCH"), "{stdout}");

    let bad = dir.path().join("corrupt.mcap");
    let at_us = corrupt_one_byte(&log, &bad, 95_000_000);
    let out = heli(&["log", "replay", &bad.display().to_string()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    let line = stdout
        .lines()
        .find(|l| l.contains("FIRST DIFFERENCE"))
        .unwrap_or_else(|| panic!("no difference reported: {stdout}"));
    // "FIRST DIFFERENCE  servo message N at t=T s": at or just after the corrupted packet.
    let t_s: f64 = line
        .split("t=")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no time in {line}"));
    let corrupted_s = at_us as f64 * 1e-6;
    assert!(
        t_s >= corrupted_s && t_s < corrupted_s + 0.1,
        "difference at {t_s} s, byte corrupted at {corrupted_s} s"
    );
}

#[test]
fn a_lockstep_log_with_a_brown_out_replays_exactly_through_the_restart() {
    // The brown-out scenario's flight computer is powered off in the hover and a new one
    // resumes from its predecessor's record: the one log holds both, and the replay must
    // start a new computer from that record where the flight did.
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("brownout.mcap");
    let log_s = log.display().to_string();
    let out = heli(&["sim", "--scenario", "brownout", "--log", &log_s]);
    assert!(out.status.success() || out.status.code() == Some(1));
    let contents = heli_log::read(&std::fs::read(&log).unwrap());
    let restarts: Vec<&serde_json::Value> = contents
        .messages
        .iter()
        .filter(|m| m.topic == "device" && m.value["kind"] == "restart")
        .map(|m| &m.value)
        .collect();
    assert_eq!(restarts.len(), 1, "one brown-out, one restart marker");
    let record = restarts[0]["warm_start"].as_str().unwrap_or_default();
    assert!(
        record.contains("airborne = true") && record.contains("trim = "),
        "the record the new process resumed from: {record}"
    );

    let out = heli(&["log", "replay", &log_s]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("EXACT MATCH"),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // Without the marker the replay flies on with the first computer, and differs.
    let cut = dir.path().join("no-marker.mcap");
    let mut copy = heli_log::FlightLog::create(&cut).unwrap();
    for m in &contents.metadata {
        copy.write_metadata(&m.name, &m.entries).unwrap();
    }
    for m in &contents.messages {
        if !(m.topic == "device" && m.value["kind"] == "restart") {
            copy.write(&m.topic, m.t_us, &m.value).unwrap();
        }
    }
    copy.finish().unwrap();
    let out = heli(&["log", "replay", &cut.display().to_string()]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn replay_of_a_log_without_device_inputs_or_not_a_log_fails_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.mcap");
    std::fs::write(&junk, b"definitely not mcap").unwrap();
    let out = heli(&["log", "replay", &junk.display().to_string()]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("not an MCAP file") || stderr.contains("not MCAP"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"));

    // A log with streams but no device inputs cannot be replayed, and says why.
    let plain = dir.path().join("plain.mcap");
    let mut log = heli_log::FlightLog::create(&plain).unwrap();
    let mut entries = std::collections::BTreeMap::new();
    entries.insert("mode".to_string(), "autonomous".to_string());
    entries.insert("plan".to_string(), "hover".to_string());
    entries.insert("calibration_s".to_string(), "80".to_string());
    entries.insert("warm_up_s".to_string(), "5".to_string());
    entries.insert("baro_rate_hz".to_string(), "5".to_string());
    entries.insert(
        "compass_bias_gauss".to_string(),
        "[0.0, 0.0, 0.0]".to_string(),
    );
    entries.insert("compass_scale".to_string(), "[1.0, 1.0, 1.0]".to_string());
    log.write_metadata("flight", &entries).unwrap();
    log.write("servo", 10, &serde_json::json!({"aileron": 0.0}))
        .unwrap();
    log.finish().unwrap();
    let out = heli(&["log", "replay", &plain.display().to_string()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no device inputs"), "{stderr}");
}

#[test]
fn a_cut_or_damaged_log_is_never_an_exact_match() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("rolls.mcap");
    let out = heli(&[
        "sim",
        "--scenario",
        "rolls",
        "--duration",
        "130",
        "--log",
        &log.display().to_string(),
    ]);
    assert!(out.status.success() || out.status.code() == Some(1));
    let whole = heli(&["log", "replay", &log.display().to_string()]);
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stdout)
    );
    let good = std::fs::read(&log).unwrap();
    // Copies cut at 24 places and copies with one byte flipped at 24 others, spread over
    // the file (past its first tenth, where the setup is).
    let mut damaged = Vec::new();
    for k in 0..48usize {
        let at = good.len() / 10 + k * (good.len() * 9 / 10 - 1) / 48;
        let mut bytes = good.clone();
        let kind = if k % 2 == 0 {
            bytes.truncate(at);
            "cut"
        } else {
            bytes[at] ^= 0x20;
            "flipped"
        };
        let path = dir.path().join(format!("{kind}{k}.mcap"));
        std::fs::write(&path, &bytes).unwrap();
        damaged.push((kind, at, path));
    }
    let mut verdicts = std::collections::BTreeMap::new();
    for (kind, at, path) in &damaged {
        let out = heli(&["log", "replay", &path.display().to_string()]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let code = out.status.code();
        assert_ne!(code, Some(0), "{kind} at byte {at}: {stdout}");
        assert!(
            !stdout.contains("EXACT MATCH"),
            "{kind} at byte {at}: {stdout}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
        if code == Some(3) {
            // How much was compared, and of what.
            assert!(
                stdout.contains("s of flight that could be read match")
                    && stdout.contains("% of the file read"),
                "{stdout}"
            );
        }
        *verdicts.entry((*kind, code)).or_insert(0) += 1;
    }
    eprintln!("verdicts on damaged copies: {verdicts:?}");
    assert!(verdicts.keys().any(|(k, c)| *k == "cut" && *c == Some(3)));
    assert!(
        verdicts
            .keys()
            .any(|(k, c)| *k == "flipped" && *c == Some(3))
    );

    // The readers of a damaged log say so: info names the damaged chunk, export refuses
    // without --partial and exports what is readable with it.
    let (_, _, flipped) = &damaged[25];
    let file = flipped.display().to_string();
    let info = heli(&["log", "info", &file]);
    let said = String::from_utf8_lossy(&info.stderr);
    assert_eq!(info.status.code(), Some(2));
    assert!(
        // A flipped byte of a compressed chunk fails its CRC, or its decompression first.
        (said.contains("fails its CRC") || said.contains("does not decompress"))
            && said.contains("the chunk ending at byte"),
        "{said}"
    );
    let export = heli(&["log", "export", "--channel", "state", &file]);
    assert_eq!(export.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&export.stderr).contains("--partial"));
    let export = heli(&["log", "export", "--channel", "state", "--partial", &file]);
    assert!(export.status.success());
    assert!(String::from_utf8_lossy(&export.stderr).contains("is damaged"));
    assert!(String::from_utf8_lossy(&export.stdout).lines().count() > 10);
}
