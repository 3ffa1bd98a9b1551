//! Joining shard reports into the report of the whole campaign.

use std::collections::BTreeMap;

use super::CampaignError;
use super::report::{Header, Report, Wall};
use crate::error::MergeProblem;

/// Joins shard reports (`(name, report)`, the name used in errors) into the report of the
/// whole campaign. They must be of the same campaign file and software, share no flight,
/// and together hold every flight.
pub fn merge(reports: &[(String, Report)]) -> Result<Report, CampaignError> {
    let Some((first_name, first)) = reports.first() else {
        return Err(CampaignError::Merge(Box::new(MergeProblem::Nothing)));
    };
    let mut seen: BTreeMap<u64, &str> = BTreeMap::new();
    let mut flights = Vec::new();
    let mut wall = Wall::default();
    for (name, r) in reports {
        if r.fingerprint != first.fingerprint || r.campaign != first.campaign {
            return Err(CampaignError::Merge(Box::new(MergeProblem::Campaigns {
                name: name.clone(),
                campaign: (r.campaign.clone(), r.fingerprint.clone()),
                first_name: first_name.clone(),
                first: (first.campaign.clone(), first.fingerprint.clone()),
            })));
        }
        if r.software != first.software {
            return Err(CampaignError::Merge(Box::new(MergeProblem::Software {
                name: (name.clone(), r.software.clone()),
                first: (first_name.clone(), first.software.clone()),
            })));
        }
        if r.flights_total != first.flights_total {
            return Err(CampaignError::Merge(Box::new(MergeProblem::Totals {
                name: (name.clone(), r.flights_total),
                first: (first_name.clone(), first.flights_total),
            })));
        }
        for f in &r.flights {
            if f.index >= r.flights_total {
                return Err(CampaignError::Merge(Box::new(MergeProblem::Beyond {
                    name: name.clone(),
                    index: f.index,
                    total: r.flights_total,
                })));
            }
            if let Some(other) = seen.insert(f.index, name) {
                return Err(CampaignError::Merge(Box::new(MergeProblem::Overlap {
                    index: f.index,
                    reports: (other.to_string(), name.clone()),
                })));
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
        let shards = missing_shards(reports, &missing);
        return Err(CampaignError::Merge(Box::new(MergeProblem::Missing {
            missing,
            total: first.flights_total,
            shards,
        })));
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
