//! The autorotation suite (campaigns/autorotation, docs/autorotation.md): the engine quits
//! in a hover at 80 m, in a hover 1.5 m up, at 10 m/s 60 m up, at any moment of a roll at
//! 80 m and at its hardest, a quarter of the way round, 100 seeds each. What the requirement asks: at least 95 % of each land at most
//! 1.5 m/s down, near level, the rotor kept (but in the low hover, whose cushion spends
//! it), and none crashes. About 500 flights, 30 s of two cores.

use std::path::Path;
use std::process::Command;

#[test]
fn every_engine_failure_campaign_lands_softly_on_95_percent_of_100_seeds() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("campaigns/autorotation");
    let mut passed = 0;
    for name in ["hover", "low-hover", "forward", "roll", "quarter-roll"] {
        let file = dir.join(format!("{name}.toml"));
        let out = Command::new(env!("CARGO_BIN_EXE_heli"))
            .args(["campaign", &file.display().to_string(), "--json"])
            .output()
            .unwrap_or_else(|e| panic!("cannot run heli: {e}"));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
            panic!(
                "{name}: no report ({e}): {}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
        let totals = &report["totals"];
        assert_eq!(totals["flights"], 100, "{name}: {totals}");
        assert_eq!(
            totals["crash"], 0,
            "{name}: {totals}\n{:#}",
            report["worst"]
        );
        let pass = totals["pass"].as_u64().unwrap_or(0);
        assert!(pass >= 95, "{name}: {totals}\n{:#}", report["worst"]);
        passed += pass;
    }
    // The requirement above leaves room for 25 hard landings; the suite lands every one of
    // its 500 flights softly (docs/autorotation.md). A change that costs more than two of
    // them is a regression to look at, not noise: the flights are deterministic. (Home's
    // height taken from one of the estimate's readings on the skids cost five.)
    assert!(
        passed >= REGRESSION_FLOOR,
        "{passed} of 500 landed softly: fewer than the {REGRESSION_FLOOR} measured less two"
    );
}

/// Soft landings of the suite's 500 below which a change is a regression.
const REGRESSION_FLOOR: u64 = 498;
