//! The campaign's table: one row a trial, in Markdown (docs/robustness.md keeps the last
//! whole run's).

use crate::judge::LOSS_ALLOWED_MS;
use crate::trial::Outcome;

/// The helicopter's column: not lost, or the crash.
fn helicopter(o: &Outcome) -> String {
    match (o.truth_read, o.crash.is_null()) {
        (false, _) => "no truth".into(),
        (true, true) => "flying or landed softly".into(),
        (true, false) => format!("**lost**: {}", o.crash.as_str().unwrap_or("crashed")),
    }
}

/// The log's column: what the official reader opened and how much the fault cost.
fn log(o: &Outcome) -> String {
    let readable = o.logs.iter().filter(|c| c.readable()).count();
    let worst = o
        .at_fault
        .iter()
        .filter_map(|c| c.ends_before_fault_ms)
        .fold(f64::NEG_INFINITY, f64::max);
    let at_fault_ok = o.at_fault.iter().all(|c| c.readable());
    let lost = if worst.is_finite() {
        format!("{:.0} ms before the fault", worst.max(0.0))
    } else {
        "no log at the fault".into()
    };
    format!(
        "{readable}/{} open; at the fault {} (ends {lost})",
        o.logs.len(),
        if at_fault_ok {
            "opens"
        } else {
            "**does not open**"
        }
    )
}

/// The operator's column.
fn told(o: &Outcome) -> String {
    if o.untold.is_empty() {
        "told".into()
    } else {
        format!("**not told**: {}", o.untold.join(", "))
    }
}

/// The verdict's column.
fn verdict(o: &Outcome) -> String {
    match (&o.skipped, o.pass) {
        (Some(why), _) => format!("not run: {why}"),
        (None, true) if o.void_tries.is_empty() => "pass".into(),
        (None, true) => format!("pass ({})", o.void_tries.join("; ")),
        (None, false) if o.problems.is_empty() => "**fail**".into(),
        (None, false) => format!("**fail**: {}", o.problems.join("; ")),
    }
}

/// The Markdown table of `outcomes`.
pub fn table(outcomes: &[Outcome]) -> String {
    let mut text = String::from(
        "| fault | phase | injected | helicopter | logs (official Python reader) | operator | verdict |\n|---|---|---|---|---|---|---|\n",
    );
    for o in outcomes {
        let injected = match o.means {
            Some(means) => format!(
                "{} ({})",
                o.injected,
                serde_json::to_value(means)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default()
            ),
            None => o.injected.clone(),
        };
        text.push_str(&format!(
            "| {} | {} | {injected} | {} | {} | {} | {} |\n",
            o.fault,
            o.phase,
            helicopter(o),
            log(o),
            told(o),
            verdict(o)
        ));
    }
    for o in outcomes {
        if let Some([first, most, last]) = o.memory_mib {
            text.push_str(&format!(
                "\n{} while {}: the flight process's resident memory {first:.2} MiB when the disk filled, at most {most:.2} MiB through it, {last:.2} MiB at its end.\n",
                o.fault, o.phase
            ));
        }
    }
    let passed = outcomes.iter().filter(|o| o.pass).count();
    text.push_str(&format!(
        "\n{passed} of {} trials pass (a log may end at most {LOSS_ALLOWED_MS:.0} ms before the fault).\n",
        outcomes.len()
    ));
    text
}
