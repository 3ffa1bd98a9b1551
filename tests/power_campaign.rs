//! The fast part of the power campaign (campaigns/power/time-left.toml, docs/power.md): the
//! file loads, and a twenty-fifth of its flights (four, the same ones on every machine) fly
//! with the gauge's time left within the campaign's limit of the truth. The whole campaign
//! is `heli campaign campaigns/power/time-left.toml`.

use std::path::Path;
use std::process::Command;

#[test]
fn a_twenty_fifth_of_the_time_left_campaign_flies_within_its_limit() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("campaigns/power/time-left.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_heli"))
        .args([
            "campaign",
            &file.display().to_string(),
            "--shard",
            "0/25",
            "--json",
        ])
        .output()
        .unwrap_or_else(|e| panic!("cannot run heli: {e}"));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("no report ({e}): {}", String::from_utf8_lossy(&out.stderr)));
    let totals = &report["totals"];
    assert_eq!(totals["flights"], 4, "{totals}");
    assert_eq!(totals["pass"], 4, "{totals}\n{:#}", report["worst"]);
}
