//! `heli campaign` as a user runs it (docs/campaigns.md): shards merged give the whole run's
//! report, a worst case flies again as `heli sim`, bad files are refused by key.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn heli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn json(out: &Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "not JSON ({e}): {}\n{}",
            text(&out.stdout),
            text(&out.stderr)
        )
    })
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

/// Flights of a few simulated seconds on the skids, manual sticks: some pass, some end
/// before the event they expect (fail), some roll the helicopter over (crash).
const GROUND: &str = r#"
name = "ground"
description = "on the skids with manual sticks"
base = "no-gps-takeoff"
seed = 3
samples = 5
[scenario]
duration_s = 8.0
mode = "manual"
expect_events = ["gps silent"]
[scenario.pilot]
auto = false
hovers_in_manual = false
[[vary]]
key = "pilot.aileron"
uniform = [0.1, 0.5]
[[vary]]
key = "pilot.collective"
grid = [0.0, 0.7]
[[vary]]
key = "duration_s"
uniform = [1.0, 8.0]
"#;

fn setup(body: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let file = dir.path().join("ground.toml");
    std::fs::write(&file, body).unwrap_or_else(|e| panic!("{e}"));
    (dir, file)
}

/// The report without its host timing, as merge promises to reproduce it.
fn without_wall(mut v: Value) -> Value {
    if let Some(map) = v.as_object_mut() {
        map.remove("wall");
    }
    v
}

#[test]
fn shards_merged_equal_the_whole_run() {
    let (dir, file) = setup(GROUND);
    let whole = heli(&["campaign", path(&file), "--jobs", "2", "--json"]);
    let report = json(&whole);
    assert_eq!(report["flights_total"], 10);
    assert_eq!(report["totals"]["flights"], 10);
    assert!(report["shard"].is_null());
    let totals = &report["totals"];
    for outcome in ["pass", "fail", "crash"] {
        assert!(
            totals[outcome].as_u64().unwrap_or(0) > 0,
            "the test campaign shows every outcome: {totals}"
        );
    }
    assert_eq!(
        whole.status.code(),
        Some(1),
        "not every flight passed: exit 1"
    );
    assert!(report["criterion_failures"]["event 'gps silent'"].as_u64() > Some(0));
    assert!(report["wall"]["elapsed_s"].is_number());

    let mut shard_reports = Vec::new();
    for shard in ["0/2", "1/2"] {
        let out_dir = dir.path().join(format!("shard{}", &shard[..1]));
        let out = heli(&[
            "campaign",
            path(&file),
            "--shard",
            shard,
            "--out",
            path(&out_dir),
        ]);
        assert!(
            out.status.code() == Some(0) || out.status.code() == Some(1),
            "{}",
            text(&out.stderr)
        );
        let shown = text(&out.stdout);
        assert!(shown.contains(&format!("shard {shard}")), "{shown}");
        let written = out_dir.join("report.json");
        let r: Value = serde_json::from_str(&std::fs::read_to_string(&written).unwrap_or_default())
            .unwrap_or_default();
        let i: u64 = shard[..1].parse().unwrap_or(9);
        let indexes: Vec<u64> = r["flights"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|f| f["index"].as_u64())
            .collect();
        assert_eq!(indexes.len(), 5);
        assert!(indexes.iter().all(|x| x % 2 == i), "{indexes:?}");
        shard_reports.push(written);
    }
    let merged_dir = dir.path().join("merged");
    let merged = heli(&[
        "campaign",
        "merge",
        path(&shard_reports[1]),
        path(&shard_reports[0]),
        "--json",
        "--out",
        path(&merged_dir),
    ]);
    assert_eq!(merged.status.code(), Some(1), "{}", text(&merged.stderr));
    assert_eq!(without_wall(json(&merged)), without_wall(report.clone()));
    for name in ["report.json", "outcomes.svg", "outcomes.png"] {
        assert!(merged_dir.join(name).is_file(), "{name} written");
    }
    let svg = std::fs::read_to_string(merged_dir.join("outcomes.svg")).unwrap_or_default();
    assert!(svg.contains("pilot.aileron") && svg.contains("duration_s"));

    // A missing shard, a shard twice, or another campaign's report: refused, by name.
    let missing = heli(&["campaign", "merge", path(&shard_reports[0])]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(
        text(&missing.stderr).contains("missing shard 1/2"),
        "{}",
        text(&missing.stderr)
    );
    let twice = heli(&[
        "campaign",
        "merge",
        path(&shard_reports[0]),
        path(&shard_reports[1]),
        path(&shard_reports[0]),
    ]);
    assert_eq!(twice.status.code(), Some(2));
    assert!(
        text(&twice.stderr).contains("overlap"),
        "{}",
        text(&twice.stderr)
    );
    let other = dir.path().join("other.toml");
    std::fs::write(&other, GROUND.replace("seed = 3", "seed = 4")).unwrap_or_default();
    let other_out = dir.path().join("other");
    heli(&[
        "campaign",
        path(&other),
        "--shard",
        "1/2",
        "--out",
        path(&other_out),
    ]);
    let foreign = other_out.join("report.json");
    let mixed = heli(&["campaign", "merge", path(&shard_reports[0]), path(&foreign)]);
    assert_eq!(mixed.status.code(), Some(2));
    let e = text(&mixed.stderr);
    assert!(
        e.contains(path(&foreign)) && e.contains("different campaign files"),
        "{e}"
    );
}

#[test]
fn a_worst_case_flies_again_as_heli_sim() {
    let (dir, file) = setup(GROUND);
    let report = json(&heli(&["campaign", path(&file), "--json"]));
    let worst = &report["worst"][0];
    assert_eq!(worst["outcome"], "crash", "crashes rank first: {worst}");
    let index = worst["index"].as_u64().unwrap_or(99);
    assert_eq!(
        worst["reproduce"],
        format!("heli campaign {} --flight {index}", path(&file))
    );
    let record = &report["flights"][index as usize];
    assert_eq!(record["index"], index);

    let scenario = dir.path().join("worst.toml");
    let index_text = index.to_string();
    let again = heli(&[
        "campaign",
        path(&file),
        "--flight",
        &index_text,
        "--write-scenario",
        path(&scenario),
        "--json",
    ]);
    assert_eq!(again.status.code(), Some(1), "a crash exits 1");
    let summary = json(&again);
    assert_eq!(summary["outcome"], record["outcome"]);
    assert_eq!(summary["seed"], record["seed"]);
    assert_eq!(summary["sim_time_s"], record["sim_time_s"]);
    assert_eq!(summary["crash"], record["crash"]);

    let sim = heli(&["sim", "--scenario", path(&scenario), "--json"]);
    let flown = json(&sim);
    assert_eq!(flown["outcome"], record["outcome"], "{}", text(&sim.stderr));
    assert_eq!(flown["seed"], record["seed"]);
    assert_eq!(flown["crash"], record["crash"]);
    assert_eq!(flown["criteria"], summary["criteria"]);

    // The table of --flight is heli sim's.
    let table = heli(&["campaign", path(&file), "--flight", &index_text]);
    let shown = text(&table.stdout);
    assert!(
        shown.contains(&format!("flight     {index} of campaign ground")),
        "{shown}"
    );
    assert!(shown.contains("outcome    CRASH"), "{shown}");
}

#[test]
fn every_flight_passing_exits_zero() {
    let body = GROUND
        .replace("uniform = [0.1, 0.5]", "uniform = [0.0, 0.05]")
        .replace("grid = [0.0, 0.7]", "grid = [0.0]")
        .replace("uniform = [1.0, 8.0]", "uniform = [4.0, 6.0]")
        .replace("samples = 5", "samples = 3");
    let (_dir, file) = setup(&body);
    let out = heli(&["campaign", path(&file)]);
    let shown = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{shown}{}", text(&out.stderr));
    assert!(shown.contains("every flight passed"), "{shown}");
}

#[test]
fn a_malformed_campaign_is_refused_with_its_key() {
    let cases = [
        (
            GROUND.replace("uniform = [1.0, 8.0]", "uniform = [8.0, 1.0]"),
            vec!["vary[2]", "duration_s", "min < max"],
        ),
        (
            GROUND.replace("key = \"pilot.aileron\"", "key = \"pilot.ailerons\""),
            vec!["pilot.ailerons", "no field \"ailerons\""],
        ),
        (
            GROUND.replace("uniform = [0.1, 0.5]", "uniform = [0.1, 3.0]"),
            vec!["pilot.aileron", "-1 to 1"],
        ),
        (
            GROUND.replace("samples = 5", "samples = 0"),
            vec!["samples = 0"],
        ),
    ];
    for (body, needles) in cases {
        let (_dir, file) = setup(&body);
        let out = heli(&["campaign", path(&file)]);
        let e = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{e}");
        assert!(e.contains(path(&file)), "names the file: {e}");
        for needle in needles {
            assert!(e.contains(needle), "'{needle}' not in: {e}");
        }
    }
    let (_dir, file) = setup(GROUND);
    let out = heli(&["campaign", path(&file), "--shard", "3/2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("from 0 to 1"),
        "{}",
        text(&out.stderr)
    );
    let out = heli(&["campaign", path(&file), "--flight", "10"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("10 flights"),
        "{}",
        text(&out.stderr)
    );
}
