//! The campaign report and the suite as text tables, as `heli campaign` prints them.

use std::fmt::Write as _;

use crate::Report;

/// The varied values of a flight, `key = value` joined by `sep`.
pub fn values_text(
    values: &std::collections::BTreeMap<String, serde_json::Value>,
    sep: &str,
) -> String {
    let parts: Vec<String> = values
        .iter()
        .map(|(k, v)| match v.as_f64() {
            Some(x) if !v.is_i64() && !v.is_u64() => format!("{k} = {x:.3}"),
            _ => format!("{k} = {v}"),
        })
        .collect();
    parts.join(sep)
}

/// The report as the table `heli campaign` prints.
pub fn report_table(r: &Report) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "campaign   {} ({}, fingerprint {})",
        r.campaign, r.file, r.fingerprint
    );
    match r.shard {
        Some(s) => {
            let _ = writeln!(
                out,
                "flights    {} of {} (shard {s}: the flights whose index is {} modulo {})",
                r.totals.flights, r.flights_total, s.index, s.count
            );
        }
        None => {
            let _ = writeln!(
                out,
                "flights    {} of {}",
                r.totals.flights, r.flights_total
            );
        }
    }
    if r.wall.jobs > 0 {
        let _ = writeln!(
            out,
            "wall time  {:.1} s on {} thread{} ({:.1} s of flights)",
            r.wall.elapsed_s,
            r.wall.jobs,
            if r.wall.jobs == 1 { "" } else { "s" },
            r.wall.flights_s
        );
    }
    let t = &r.totals;
    let share = |n: u64| {
        if t.flights == 0 {
            0.0
        } else {
            100.0 * n as f64 / t.flights as f64
        }
    };
    let _ = writeln!(out);
    let _ = writeln!(out, "{:<10} {:>8} {:>8}", "outcome", "flights", "share");
    for (name, n) in [
        ("pass", t.pass),
        ("fail", t.fail),
        ("crash", t.crash),
        ("error", t.error),
    ] {
        let _ = writeln!(out, "{name:<10} {n:>8} {:>7.1}%", share(n));
    }
    if let (Some(rate), Some([lo, hi])) = (t.pass_rate, t.pass_rate_ci95) {
        let _ = writeln!(
            out,
            "pass rate  {:.1} % (95 % interval {:.1} to {:.1} %)",
            100.0 * rate,
            100.0 * lo,
            100.0 * hi
        );
    }
    if !r.criterion_failures.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(out, "{:<32} {:>8}", "criterion", "failed");
        for (name, n) in &r.criterion_failures {
            let _ = writeln!(out, "{name:<32} {n:>8}");
        }
    }
    if !r.worst.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(
            out,
            "worst cases (errors, crashes, then by score: worst criterion / its limit, above 1 fails)"
        );
        for w in &r.worst {
            let score = w.score.map_or("-".to_string(), |s| format!("{s:.2}"));
            let _ = writeln!(
                out,
                "  flight {:<6} {:<6} score {score:<6} {}",
                w.index,
                w.outcome.name(),
                values_text(&w.values, ", ")
            );
            let _ = writeln!(out, "    {}", w.why);
            let _ = writeln!(out, "    {}", w.reproduce);
        }
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "outcome    {}",
        if r.all_passed() {
            "every flight passed"
        } else {
            "NOT every flight passed"
        }
    );
    out
}
