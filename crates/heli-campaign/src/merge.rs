//! Joining shard reports into the report of the whole campaign.

use std::collections::BTreeMap;

use super::CampaignError;
use super::report::{Header, Report, Wall};

/// Joins shard reports (`(name, report)`, the name used in errors) into the report of the
/// whole campaign. They must be of the same campaign file and software, share no flight,
/// and together hold every flight.
pub fn merge(reports: &[(String, Report)]) -> Result<Report, CampaignError> {
    let Some((first_name, first)) = reports.first() else {
        return Err(CampaignError("merge needs at least one report".into()));
    };
    let mut seen: BTreeMap<u64, &str> = BTreeMap::new();
    let mut flights = Vec::new();
    let mut wall = Wall::default();
    for (name, r) in reports {
        if r.fingerprint != first.fingerprint || r.campaign != first.campaign {
            return Err(CampaignError(format!(
                "{name}: campaign \"{}\" (fingerprint {}) is not {first_name}'s \"{}\" ({}): reports of different campaign files, or of two versions of one, cannot be merged",
                r.campaign, r.fingerprint, first.campaign, first.fingerprint
            )));
        }
        if r.software != first.software {
            return Err(CampaignError(format!(
                "{name} was flown by {}, {first_name} by {}: shards must be flown by the same software",
                r.software, first.software
            )));
        }
        if r.flights_total != first.flights_total {
            return Err(CampaignError(format!(
                "{name}: {} flights in the campaign, {first_name}: {}",
                r.flights_total, first.flights_total
            )));
        }
        for f in &r.flights {
            if f.index >= r.flights_total {
                return Err(CampaignError(format!(
                    "{name}: flight {} is beyond the campaign's {} flights",
                    f.index, r.flights_total
                )));
            }
            if let Some(other) = seen.insert(f.index, name) {
                return Err(CampaignError(format!(
                    "flight {} is in both {other} and {name}: the shards overlap",
                    f.index
                )));
            }
            flights.push(f.clone());
        }
        wall.elapsed_s += r.wall.elapsed_s;
        wall.flights_s += r.wall.flights_s;
        wall.jobs = wall.jobs.max(r.wall.jobs);
    }
    let missing: Vec<u64> = (0..first.flights_total)
        .filter(|i| !seen.contains_key(i))
        .collect();
    if !missing.is_empty() {
        let listed: Vec<String> = missing.iter().take(10).map(u64::to_string).collect();
        let more = if missing.len() > 10 {
            format!(" and {} more", missing.len() - 10)
        } else {
            String::new()
        };
        let shards = missing_shards(reports, &missing);
        return Err(CampaignError(format!(
            "{} of {} flights are in no report (flights {}{more}){shards}",
            missing.len(),
            first.flights_total,
            listed.join(", ")
        )));
    }
    let header = Header {
        campaign: first.campaign.clone(),
        file: first.file.clone(),
        fingerprint: first.fingerprint.clone(),
        software: first.software.clone(),
        flights_total: first.flights_total,
        keys: first.keys.clone(),
    };
    Ok(Report::assemble(header, None, flights, wall))
}

/// When every report is a shard of the same count: which shards the missing flights are
/// in.
fn missing_shards(reports: &[(String, Report)], missing: &[u64]) -> String {
    let counts: Vec<u64> = reports
        .iter()
        .filter_map(|(_, r)| r.shard.map(|s| s.count))
        .collect();
    let Some(&n) = counts.first() else {
        return String::new();
    };
    if counts.len() != reports.len() || counts.iter().any(|c| *c != n) {
        return String::new();
    }
    let mut shards: Vec<u64> = missing.iter().map(|i| i % n).collect();
    shards.dedup();
    shards.sort_unstable();
    shards.dedup();
    let names: Vec<String> = shards.iter().map(|i| format!("{i}/{n}")).collect();
    format!(": missing shard {}", names.join(", "))
}
