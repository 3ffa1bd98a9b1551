//! Every message of every built-in scenario's log conforms to its channel's JSON Schema.
//!
//! `heli sim --library` flies every built-in scenario and keeps its log; each message is
//! checked against the schema of its channel with heli-log's own checker. The official
//! validator (Python's `jsonschema`, which knows nothing of this project, reading the
//! schemas stored in the file through the official MCAP reader: `tests/schemas/validate.py`)
//! checks the battery swap's log here when `HELI_MCAP_PYTHON` names a Python with
//! `mcap` and `jsonschema`, and every log in CI (`scripts/check-log-schemas`, a few minutes).

use std::process::Command;

#[test]
fn every_message_of_every_built_in_scenario_conforms_to_its_channels_schema() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_heli"))
        .args(["sim", "--library"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut logs: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    logs.sort();
    assert!(logs.len() >= 20, "{} logs", logs.len());
    let mut checked = 0u64;
    let mut kinds = std::collections::BTreeSet::new();
    for log in &logs {
        let contents = heli_log::read(&std::fs::read(log).unwrap());
        assert_eq!(contents.stopped, None, "{}", log.display());
        for m in &contents.messages {
            let schema = heli_log::schema::for_topic(&m.topic);
            if let Err(e) = heli_log::schema::validate(&schema.json, &m.value, &m.topic) {
                panic!(
                    "{}: {} message at {} µs: {e}: {}",
                    log.display(),
                    m.topic,
                    m.t_us,
                    m.value
                );
            }
            if m.topic == "device"
                && let Some(kind) = m.value["kind"].as_str()
            {
                kinds.insert(kind.to_string());
            }
            checked += 1;
        }
    }
    // The device channel's kinds the simulation writes, the power line among them.
    for kind in ["start", "bytes", "compass", "tick", "battery", "power_line"] {
        assert!(
            kinds.contains(kind),
            "no '{kind}' input in any log: {kinds:?}"
        );
    }
    println!("{checked} messages of {} logs conform", logs.len());

    let Some(python) = std::env::var_os("HELI_MCAP_PYTHON") else {
        println!("HELI_MCAP_PYTHON is not set: the official JSON Schema validator was not run");
        return;
    };
    let has_jsonschema = Command::new(&python)
        .args(["-c", "import jsonschema"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_jsonschema {
        println!("{python:?} has no jsonschema package: the official validator was not run");
        return;
    }
    // The battery swap: both states of the power line among the device inputs.
    let out = Command::new(&python)
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/schemas/validate.py"
        ))
        .arg(dir.path().join("battery-swap.mcap"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    print!("{said}");
}
