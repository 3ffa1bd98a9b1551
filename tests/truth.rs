//! The truth trace's command-line contract (`heli sim --truth`, `heli campaign --flight I
//! --truth`): the simulator's truth beside the flight software's estimate, as CSV.

use std::process::Command;

fn heli(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"))
}

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("heli-truth-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    dir
}

/// Flies `args` with `--json --truth path` (a pass or a fail, never an error) and reads the
/// trace it wrote.
fn traced(args: &[&str], path: &std::path::Path) -> String {
    let path_s = path.to_string_lossy();
    let mut all = args.to_vec();
    all.extend(["--json", "--truth", &path_s]);
    let out = heli(&all);
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn sim_writes_the_truth_beside_the_estimate_and_names_a_file_it_cannot_write() {
    let dir = scratch("sim");
    let path = dir.join("truth.csv");
    let path_s = path.to_string_lossy().to_string();
    let out = heli(&[
        "sim",
        "--scenario",
        "hover",
        "--duration",
        "30",
        "--json",
        "--truth",
        &path_s,
    ]);
    // 30 s is still calibrating: the flight fails its criteria, the trace is written anyway.
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    for column in [
        "t_s",
        "phase",
        "true_roll_rad",
        "est_roll_rad",
        "att_err_rad",
        "rotor_rpm",
    ] {
        assert!(header.contains(&column), "{column} missing: {header:?}");
    }
    let rows: Vec<&str> = lines.collect();
    assert!((1499..=1501).contains(&rows.len()), "{} rows", rows.len());
    assert!(rows[0].starts_with("0.000,calibrating,"), "{}", rows[0]);
    // A file that cannot be created: said with its path, exit 2, no flight.
    let bad = dir.join("no-such-dir").join("truth.csv");
    let out = heli(&[
        "sim",
        "--scenario",
        "hover",
        "--duration",
        "1",
        "--truth",
        &bad.to_string_lossy(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the truth trace") && err.contains("no-such-dir"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_campaign_s_flight_writes_its_truth_trace_too() {
    let dir = scratch("campaign");
    let path = dir.join("truth.csv");
    let campaign = concat!(env!("CARGO_MANIFEST_DIR"), "/campaigns/example.toml");
    let text = traced(&["campaign", campaign, "--flight", "0"], &path);
    // The hover's take-off and hold: rows with the estimate running and the helicopter up.
    let flying = text.lines().filter(|l| l.contains(",hold,")).count();
    assert!(flying > 100, "{flying} rows in the hold");
    // Without --flight the option is refused.
    let out = heli(&["campaign", campaign, "--truth", &path.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn while_the_computer_is_browned_out_the_trace_shows_no_estimate() {
    let dir = scratch("brownout");
    let path = dir.join("truth.csv");
    let text = traced(&["sim", "--scenario", "brownout"], &path);
    let off: Vec<&str> = text
        .lines()
        .filter(|l| l.contains(",browned-out,"))
        .collect();
    assert!(!off.is_empty(), "no browned-out row");
    // No phase and no estimate while nothing runs: the last ones in memory are nobody's.
    for row in &off {
        let cells: Vec<&str> = row.split(',').collect();
        assert!(cells[11..21].iter().all(|c| c.is_empty()), "{row}");
    }
    // The truth goes on: the helicopter is in the air through it.
    let down: f64 = off[0]
        .split(',')
        .nth(4)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0.0);
    assert!(down < -2.0, "{}", off[0]);
    // And --truth where there is no one flight to trace is refused.
    let out = heli(&["sim", "--list", "--truth", &path.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(dir);
}
