//! The onboard program links only what flies: no simulator, ground station, web server,
//! plotting or campaign crate is in `heli-vehicle`'s dependency tree (what gets copied to
//! the flight computer).

#![allow(clippy::expect_used, clippy::panic)]

use std::process::Command;

/// Crates that must never be linked into the onboard program, and why.
const NEVER_ONBOARD: [(&str, &str); 10] = [
    ("heli-sim", "the simulator"),
    ("heli-model", "the helicopter model"),
    ("heli-scenario", "the scenarios"),
    ("heli-campaign", "the Monte Carlo campaigns"),
    ("heli-ground", "the ground station"),
    ("axum", "a web server"),
    ("tokio", "an async runtime"),
    ("plotters", "plotting"),
    ("rayon", "a work-stealing thread pool"),
    ("indicatif", "progress bars"),
];

#[test]
fn the_onboard_program_links_no_workstation_crate() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "--locked",
            "-p",
            "heli-vehicle",
            "-e",
            "normal,build",
            "--prefix",
            "none",
            "--format",
            "{p}",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    let crates: Vec<&str> = tree
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(crates.contains(&"heli-fsw"), "the tree was read: {tree}");
    for (name, what) in NEVER_ONBOARD {
        assert!(
            !crates.contains(&name),
            "{name} ({what}) is in the onboard program's dependency tree:\n{tree}"
        );
    }
}
