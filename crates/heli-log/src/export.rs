//! One channel's messages as CSV, for plotting elsewhere.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::LogContents;

/// Calls `leaf` with the flattened name (`a.b`, `v[2]`) and value of every scalar in `value`.
pub fn for_each_leaf(prefix: &str, value: &Value, leaf: &mut dyn FnMut(String, &Value)) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                for_each_leaf(&key, v, leaf);
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                for_each_leaf(&format!("{prefix}[{i}]"), v, leaf);
            }
        }
        scalar => leaf(prefix.to_string(), scalar),
    }
}

fn flatten(prefix: &str, value: &Value, out: &mut Vec<(String, String)>) {
    for_each_leaf(prefix, value, &mut |name, v| {
        let text = match v {
            Value::String(s) => quoted(s),
            Value::Null => String::new(),
            other => other.to_string(),
        };
        out.push((name, text));
    });
}

/// A text cell as CSV (RFC 4180): as it is, or in double quotes with its quotes doubled
/// when it holds a comma, a quote or a line break — the text comes back whole.
fn quoted(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The top-level field a flattened name belongs to (`target_ned_m` of `target_ned_m[2]`).
fn root(name: &str) -> &str {
    name.split(['.', '[']).next().unwrap_or(name)
}

/// Every flattened field of `rows`, in the order first seen: a field a later message has
/// and the first lacks (a null that became a vector, a list that grew) is a column too,
/// placed after the other columns of its top-level field.
fn columns(rows: &[(u64, Vec<(String, String)>)]) -> Vec<String> {
    let mut columns: Vec<String> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for (_, fields) in rows {
        for (name, _) in fields {
            if !seen.insert(name.clone()) {
                continue;
            }
            let at = columns
                .iter()
                .rposition(|c| root(c) == root(name))
                .map_or(columns.len(), |i| i + 1);
            columns.insert(at, name.clone());
        }
    }
    // A field that was null until it became a vector (the state's target before a plan
    // gives one) is its components' columns, not an empty column of its own too.
    let empty = |c: &str| {
        rows.iter()
            .all(|(_, fields)| fields.iter().all(|(n, v)| n != c || v.is_empty()))
    };
    let split: Vec<String> = columns
        .iter()
        .filter(|c| root(c) == c.as_str() && empty(c))
        .filter(|c| columns.iter().any(|o| o != *c && root(o) == c.as_str()))
        .cloned()
        .collect();
    columns.retain(|c| !split.contains(c));
    columns
}

/// One channel's messages as CSV: a `t_s` column, then one column per (flattened) field of
/// any of its messages; a message without a field leaves its cell empty. Text is quoted as
/// RFC 4180 asks where it must be, so a spreadsheet or Python's `csv` reads it back whole.
pub fn to_csv(contents: &LogContents, topic: &str) -> String {
    let rows: Vec<(u64, Vec<(String, String)>)> = contents
        .messages
        .iter()
        .filter(|m| m.topic == topic)
        .map(|m| {
            let mut fields = Vec::new();
            flatten("", &m.value, &mut fields);
            (m.t_us, fields)
        })
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    let columns = columns(&rows);
    let mut csv = String::from("t_s");
    for c in &columns {
        csv.push(',');
        csv.push_str(c);
    }
    csv.push('\n');
    for (t_us, fields) in &rows {
        let map: BTreeMap<&str, &str> = fields
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        csv.push_str(&format!("{:.6}", *t_us as f64 * 1e-6));
        for c in &columns {
            csv.push(',');
            csv.push_str(map.get(c.as_str()).copied().unwrap_or(""));
        }
        csv.push('\n');
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LoggedMessage;
    use serde_json::json;

    #[test]
    fn csv_export_flattens_fields() {
        let messages = (0..50)
            .map(|k| LoggedMessage {
                topic: "state".into(),
                t_us: k * 20_000,
                sequence: k as u32,
                value: json!({"phase": "hold", "pos_ned_m": [1.0, 2.0, -10.0]}),
            })
            .collect();
        let contents = LogContents {
            messages,
            ..Default::default()
        };
        let csv = to_csv(&contents, "state");
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some("t_s,phase,pos_ned_m[0],pos_ned_m[1],pos_ned_m[2]")
        );
        assert_eq!(lines.next(), Some("0.000000,hold,1.0,2.0,-10.0"));
        assert_eq!(csv.lines().count(), 51);
        assert_eq!(to_csv(&contents, "nothing"), "");
    }

    #[test]
    fn text_with_commas_quotes_or_lines_comes_back_whole() {
        let text = "calibration done, gyro bias [0.0029, -0.0135] \"rad/s\"\nnext";
        let contents = LogContents {
            messages: vec![LoggedMessage {
                topic: "events".into(),
                t_us: 85_000_000,
                sequence: 0,
                value: json!({"level": "info", "text": text, "plain": "hold"}),
            }],
            ..Default::default()
        };
        let csv = to_csv(&contents, "events");
        assert!(csv.contains(",hold,"), "{csv}");
        // Read back as a CSV reader does: the quoted cell, its doubled quotes undone.
        let start = csv
            .find(",\"")
            .map(|i| i + 2)
            .unwrap_or_else(|| panic!("{csv}"));
        let end = csv.rfind('"').unwrap_or(0);
        assert_eq!(csv[start..end].replace("\"\"", "\""), text);
        assert_eq!(quoted("plain"), "plain");
    }

    #[test]
    fn a_field_the_first_message_lacks_is_exported_too() {
        // The state's target is null until a plan gives one; a list grows.
        let values = [
            json!({"target_ned_m": null, "sats": [1], "alt_m": 0.5}),
            json!({"target_ned_m": [1.0, 2.0, -3.0], "sats": [1, 2], "alt_m": 0.75}),
        ];
        let messages = values
            .into_iter()
            .enumerate()
            .map(|(k, value)| LoggedMessage {
                topic: "state".into(),
                t_us: k as u64 * 1_000_000,
                sequence: k as u32,
                value,
            })
            .collect();
        let contents = LogContents {
            messages,
            ..Default::default()
        };
        let csv = to_csv(&contents, "state");
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines,
            [
                "t_s,alt_m,sats[0],sats[1],target_ned_m[0],target_ned_m[1],target_ned_m[2]",
                "0.000000,0.5,1,,,,",
                "1.000000,0.75,1,2,1.0,2.0,-3.0",
            ]
        );
    }
}
