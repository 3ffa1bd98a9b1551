//! The fast part of the robustness suite (campaigns/robustness, docs/robustness.md): every
//! campaign file of the suite loads, and a fiftieth of each (two flights, the same ones on
//! every machine: the flights are a pure function of the file and their index) flies and
//! passes. The whole suite is `heli campaign suite campaigns/robustness`.

use std::path::Path;
use std::process::Command;

#[test]
fn a_fiftieth_of_every_robustness_campaign_flies_and_passes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("campaigns/robustness");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 8, "the suite's campaigns: {files:?}");
    for file in &files {
        let out = Command::new(env!("CARGO_BIN_EXE_heli"))
            .args([
                "campaign",
                &file.display().to_string(),
                "--shard",
                "0/50",
                "--json",
            ])
            .output()
            .unwrap_or_else(|e| panic!("cannot run heli: {e}"));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
            panic!(
                "{}: no report ({e}): {}",
                file.display(),
                String::from_utf8_lossy(&out.stderr)
            )
        });
        let totals = &report["totals"];
        assert_eq!(totals["flights"], 2, "{}: {totals}", file.display());
        assert_eq!(
            totals["pass"],
            2,
            "{}: {totals}\n{:#}",
            file.display(),
            report["worst"]
        );
        assert!(out.status.success(), "{}", file.display());
    }
}
