//! Flying a campaign's flights: all of them or one shard, on a rayon pool.
//!
//! Shards serve a batch system that already exists: `--shard I/N` flies the flights whose
//! index is `I` modulo `N`, with `I` from 0, so a Slurm array's `$SLURM_ARRAY_TASK_ID`
//! (`--array=0-N-1`), a Kubernetes indexed Job's `$JOB_COMPLETION_INDEX` or GNU parallel's
//! `{}` over `seq 0 N-1` can be passed as they are; `heli campaign merge` joins
//! the reports.
//!
//! A flight whose scenario is refused, or whose simulation panics, is recorded as an
//! `error` with the reason (a panic's message and place) and the campaign goes on.

use std::cell::{Cell, RefCell};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Once;
use std::time::Instant;

use rayon::prelude::*;

use super::report::{FlightRecord, Report, Wall};
pub use super::shard::Shard;
use super::{Campaign, CampaignError};
use crate::error::FlightError;
use heli_fsw::CoreConfig;
use heli_scenario::Scenario;
use heli_sim::lockstep::{RunOptions, Simulation};
use heli_sim::summary::Summary;

/// How to fly a campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunConfig {
    /// Worker threads (`None`: one per core).
    pub jobs: Option<usize>,
    /// Which flights.
    pub shard: Shard,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            jobs: None,
            shard: Shard::ALL,
        }
    }
}

/// Flies the shard's flights of `campaign` in parallel, calling `on_flight` as each ends
/// (from the worker threads, in no set order), and reports them.
pub fn run(
    campaign: &Campaign,
    config: RunConfig,
    on_flight: impl Fn(&FlightRecord) + Sync,
) -> Result<Report, CampaignError> {
    run_with_software(campaign, config, &CoreConfig::default(), on_flight)
}

/// As [`run`], with the flight software configured as `software` (a vehicle's parameter
/// set applied to it: `heli campaign --params`, `heli certify`).
pub fn run_with_software(
    campaign: &Campaign,
    config: RunConfig,
    software: &CoreConfig,
    on_flight: impl Fn(&FlightRecord) + Sync,
) -> Result<Report, CampaignError> {
    if config.jobs == Some(0) {
        return Err(CampaignError::NoJobs);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(config.jobs.unwrap_or(0))
        .build()
        .map_err(CampaignError::Workers)?;
    let indexes: Vec<u64> = (0..campaign.flights_total())
        .filter(|i| config.shard.contains(*i))
        .collect();
    let start = Instant::now();
    let results: Vec<(FlightRecord, f64)> = pool.install(|| {
        indexes
            .par_iter()
            .map(|&i| {
                let flight_start = Instant::now();
                let record = fly_with_software(campaign, i, software);
                on_flight(&record);
                (record, flight_start.elapsed().as_secs_f64())
            })
            .collect()
    });
    let wall = Wall {
        elapsed_s: start.elapsed().as_secs_f64(),
        flights_s: results.iter().map(|(_, s)| s).sum(),
        jobs: pool.current_num_threads(),
    };
    let flights = results.into_iter().map(|(r, _)| r).collect();
    let shard = (config.shard != Shard::ALL).then_some(config.shard);
    Ok(Report::new(campaign, shard, flights, wall))
}

/// Flies flight `index` alone: its record, an error one when the flight cannot be built or
/// panics.
pub fn fly(campaign: &Campaign, index: u64) -> FlightRecord {
    fly_with_software(campaign, index, &CoreConfig::default())
}

/// Flies flight `index` alone with the flight software configured as `software`.
pub fn fly_with_software(campaign: &Campaign, index: u64, software: &CoreConfig) -> FlightRecord {
    fly_with(campaign, index, |scenario| {
        let simulation = Simulation::with_flight_software(scenario, *software)
            .map_err(|error| FlightError::Simulation { index, error })?;
        Ok(simulation.run(RunOptions::default(), |_, _| {}))
    })
}

/// Flight `index` flown by `fly`, which gets the flight's scenario (tests give a `fly` that
/// panics).
pub(crate) fn fly_with(
    campaign: &Campaign,
    index: u64,
    fly: impl FnOnce(Scenario) -> Result<Summary, FlightError>,
) -> FlightRecord {
    let flight = match campaign.flight(index) {
        Ok(f) => f,
        Err(e) => return FlightRecord::error(index, 0, Default::default(), e.to_string()),
    };
    record_panics();
    IN_FLIGHT.with(|f| f.set(true));
    let result = catch_unwind(AssertUnwindSafe(|| {
        let scenario = flight.scenario()?;
        fly(scenario)
    }));
    IN_FLIGHT.with(|f| f.set(false));
    let error = |why| FlightRecord::error(index, flight.seed, flight.values.clone(), why);
    match result {
        Ok(Ok(summary)) => FlightRecord::flown(&flight, &summary),
        Ok(Err(why)) => error(why.to_string()),
        Err(payload) => {
            let message = LAST_PANIC
                .with(|p| p.borrow_mut().take())
                .unwrap_or_else(|| panic_text(payload.as_ref()));
            error(format!("panic: {message}"))
        }
    }
}

thread_local! {
    /// Set while this thread flies a campaign flight: its panics are recorded, not printed.
    static IN_FLIGHT: Cell<bool> = const { Cell::new(false) };
    /// The last panic of a flight on this thread, with its place.
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Installs (once) a panic hook that records a flight's panic, message and place, for its
/// report instead of printing it; other panics go to the hook that was there before.
fn record_panics() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_FLIGHT.with(Cell::get) {
                let place = info
                    .location()
                    .map(|l| format!(" at {}:{}:{}", l.file(), l.line(), l.column()))
                    .unwrap_or_default();
                let text = format!("{}{place}", panic_text(info.payload()));
                LAST_PANIC.with(|p| *p.borrow_mut() = Some(text));
            } else {
                previous(info);
            }
        }));
    });
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "(no message)".into())
}
