//! The simulator's flight logger: an observer of a [`crate::Simulation`]'s seven streams and
//! events that appends what is new to a [`heli_log::FlightLog`]. The conversion of records
//! and events into log messages is heli-log's ([`heli_log::records`], [`heli_log::events`]),
//! shared with the vehicle runtime.

use std::path::Path;

use heli_fsw::streams::Record;
use heli_log::records::record_time;
use heli_log::{FlightLog, LogError, LogFile};
use heli_scenario::{Scenario, ScenarioError};

use crate::lockstep::{RunOptions, Simulation};
use crate::summary::Summary;
use crate::truth_trace::TruthTrace;

/// Why a flight could not be flown or its log begun.
#[derive(Debug)]
pub enum FlyError {
    /// The scenario cannot be flown.
    Scenario(ScenarioError),
    /// The scenario cannot be written into the log's metadata.
    Toml(toml::ser::Error),
    /// The log could not be created or its metadata written.
    Log {
        /// The log file.
        path: std::path::PathBuf,
        /// What went wrong.
        error: LogError,
    },
    /// The truth trace could not be created.
    Truth {
        /// The trace's file.
        path: std::path::PathBuf,
        /// What went wrong.
        error: std::io::Error,
    },
}

impl std::fmt::Display for FlyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FlyError::Scenario(e) => write!(f, "{e}"),
            FlyError::Toml(e) => write!(f, "the scenario as TOML: {e}"),
            FlyError::Log { path, error } => {
                write!(f, "the flight log {}: {error}", path.display())
            }
            FlyError::Truth { path, error } => {
                write!(f, "the truth trace {}: {error}", path.display())
            }
        }
    }
}

impl std::error::Error for FlyError {}

/// Flies `scenario` in lockstep, logging to `log` when given — with the device inputs, so
/// that `heli log replay` and `heli hilsim --replay` can play it again, and the whole
/// scenario in the metadata, so that the flight can be flown again; and the truth beside
/// the estimate to `truth` when given ([`crate::truth_trace`]). `progress` is told the
/// simulated time and the scenario's length as it goes. A log or trace that fails part-way
/// is said on standard error (the log is left out of the summary); the flight goes on.
pub fn fly(
    scenario: Scenario,
    options: RunOptions,
    log: Option<&Path>,
    truth: Option<&Path>,
    mut progress: impl FnMut(f64, f64),
) -> Result<Summary, FlyError> {
    // The trace first: a path it cannot take leaves no half-begun log behind.
    let mut trace = match truth {
        Some(path) => Some(TruthTrace::create(path).map_err(|error| FlyError::Truth {
            path: path.to_path_buf(),
            error,
        })?),
        None => None,
    };
    let mut logger = match log {
        Some(path) => {
            let error = |error| FlyError::Log {
                path: path.to_path_buf(),
                error,
            };
            let mut log = FlightLog::create(path).map_err(error)?;
            // What flew, when, and the whole scenario, so that the flight can be flown again.
            let scenario_toml = toml::to_string(&scenario).map_err(FlyError::Toml)?;
            let parameters = [
                ("scenario".to_string(), scenario.name.clone()),
                ("seed".to_string(), scenario.seed.to_string()),
                ("scenario_toml".to_string(), scenario_toml),
            ];
            let software = concat!("heli ", env!("CARGO_PKG_VERSION"));
            let entries =
                heli_log::metadata::flight(software, std::time::SystemTime::now(), parameters);
            log.write_metadata(heli_log::metadata::FLIGHT, &entries)
                .map_err(error)?;
            Some(StreamLogger::new(log))
        }
        None => None,
    };
    let mut log_error = None;
    let mut trace_error = None;
    let mut simulation = Simulation::new(scenario).map_err(FlyError::Scenario)?;
    if logger.is_some() {
        // So that the log can be replayed (`heli log replay`).
        simulation.log_device_inputs();
    }
    let mut summary = simulation.run_observed(options, &mut progress, |sim| {
        if let (Some(l), None) = (logger.as_mut(), &log_error) {
            log_error = l.drain(sim).err();
        }
        if let (Some(t), None) = (trace.as_mut(), &trace_error) {
            trace_error = t.observe(sim).err();
        }
    });
    if let (Some(t), Some(path)) = (trace, truth)
        && let Err(e) = trace_error.map_or_else(|| t.finish().map(|_| ()), Err)
    {
        eprintln!(
            "heli: the truth trace {} is incomplete: {e}",
            path.display()
        );
    }
    if let (Some(l), Some(path)) = (logger, log) {
        match log_error.map_or_else(|| l.finish().map(|_| ()), Err) {
            Ok(()) => summary.log = Some(path.display().to_string()),
            // The flight went on; only its log is lost. Say so, never hide it.
            Err(e) => eprintln!("heli: the flight log {} is incomplete: {e}", path.display()),
        }
    }
    Ok(summary)
}

/// The flight logger. It only reads; it can fall behind by as much as the streams keep (10 s
/// here) before it misses anything, and counts what it missed. Each record keeps its
/// stream's sequence number in the log, so a record it missed is a gap in its channel.
pub struct StreamLogger<W: LogFile> {
    log: FlightLog<W>,
    cursors: [u64; 7],
    events: usize,
    /// Device inputs written so far (`None` until the start marker is written).
    inputs: Option<usize>,
    /// Restart markers written so far ([`Simulation::restarts`]).
    restarts: usize,
    /// Records the streams had overwritten before the logger read them.
    pub missed: u64,
}

impl<W: LogFile> StreamLogger<W> {
    /// A logger writing to `log`.
    pub fn new(log: FlightLog<W>) -> Self {
        Self {
            log,
            cursors: [0; 7],
            events: 0,
            inputs: None,
            restarts: 0,
            missed: 0,
        }
    }

    /// Writes the markers of the flight computers started again before the `index`th device
    /// input that are not written yet, each with the record it started from in the warm-start
    /// file's format (a replay starts a new computer there from it).
    fn write_restarts(&mut self, sim: &crate::Simulation, index: usize) -> Result<(), LogError> {
        while let Some(r) = sim
            .restarts()
            .get(self.restarts)
            .filter(|r| r.inputs_before <= index)
        {
            let text = r.warm.map(|warm| {
                heli_vehicle::warm::WarmFile {
                    warm,
                    // What the lockstep flies; the record's own lines are what a replay reads.
                    start: heli_link::StartParameters {
                        file_suffix: "sim".to_string(),
                        controller: sim.flight_software_setup().1.mode,
                        plan: None,
                        override_untested: false,
                    },
                    unix_times: false,
                }
                .to_text()
            });
            let value = heli_log::inputs::restart_json(text.as_deref());
            self.log.write(heli_log::inputs::CHANNEL, r.t_us, &value)?;
            self.restarts = self.restarts.saturating_add(1);
        }
        Ok(())
    }

    /// Appends everything published since the last call, and the device inputs when the
    /// simulation keeps them ([`crate::Simulation::log_device_inputs`]).
    pub fn drain(&mut self, sim: &crate::Simulation) -> Result<(), LogError> {
        let inputs = sim.device_inputs();
        if self.inputs.is_none() && !inputs.is_empty() {
            // The flight computer was started at 0 s (watchdogs armed, handshakes begun).
            self.log.write(
                heli_log::inputs::CHANNEL,
                0,
                &heli_log::inputs::start_json(),
            )?;
            self.inputs = Some(0);
        }
        if let Some(done) = self.inputs {
            for (i, (t_us, input)) in inputs.iter().enumerate().skip(done) {
                self.write_restarts(sim, i)?;
                let value = heli_log::inputs::input_json(input);
                self.log.write(heli_log::inputs::CHANNEL, *t_us, &value)?;
            }
            self.write_restarts(sim, inputs.len())?;
            self.inputs = Some(inputs.len());
        }
        let streams = sim.streams();
        let mut records: Vec<(Record, u64)> = Vec::new();
        macro_rules! take {
            ($i:expr, $stream:expr, $variant:path) => {{
                let (new, next, missed) = $stream.read_since(self.cursors[$i]);
                self.cursors[$i] = next;
                self.missed += missed;
                // The stream's sequence number of the first new record.
                let first = next.saturating_sub(new.len() as u64);
                records.extend(
                    new.into_iter()
                        .zip(first..)
                        .map(|(r, seq)| ($variant(r), seq)),
                );
            }};
        }
        take!(0, streams.imu, Record::Imu);
        take!(1, streams.state, Record::State);
        take!(2, streams.servo, Record::Servo);
        take!(3, streams.uplink, Record::Uplink);
        take!(4, streams.gps, Record::Gps);
        take!(5, streams.baro, Record::Baro);
        take!(6, streams.compass, Record::Compass);
        // Written in time order across streams, as a flight recorder would.
        records.sort_by_key(|(record, _)| record_time(record));
        for (record, sequence) in &records {
            self.log.write_record_sequenced(record, *sequence)?;
        }
        for e in sim.core_events().iter().skip(self.events) {
            self.log.write_event(e.t_us, &e.value)?;
        }
        self.events = sim.core_events().len();
        Ok(())
    }

    /// Messages written.
    pub fn messages(&self) -> u64 {
        self.log.messages()
    }

    /// The log, to record metadata or flush.
    pub fn log_mut(&mut self) -> &mut FlightLog<W> {
        &mut self.log
    }

    /// Closes the log.
    pub fn finish(self) -> Result<W, LogError> {
        self.log.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lockstep::{RunOptions, Simulation};
    use std::io::Cursor;

    #[test]
    fn every_stream_and_event_is_logged_with_its_streams_numbers() {
        let mut scenario = heli_scenario::builtins()
            .into_iter()
            .find(|s| s.name == "hover")
            .unwrap_or_default();
        scenario.duration_s = 90.0;
        let log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
        let mut logger = StreamLogger::new(log);
        let mut error = None;
        let sim = Simulation::new(scenario).unwrap_or_else(|e| panic!("{e}"));
        sim.run_observed(
            RunOptions {
                realtime: false,
                duration_s: Some(90.0),
            },
            |_, _| {},
            |sim| {
                if error.is_none() {
                    error = logger.drain(sim).err();
                }
            },
        );
        assert!(error.is_none(), "{error:?}");
        assert_eq!(logger.missed, 0);
        let bytes = logger
            .finish()
            .unwrap_or_else(|e| panic!("{e}"))
            .into_inner();
        let contents = heli_log::read(&bytes);
        assert_eq!(contents.stopped, None);
        let stats = heli_log::stats::channels(&contents);
        for topic in heli_log::STREAMS
            .iter()
            .chain(&["events", "foxglove/tf", "foxglove/log"])
        {
            let s = stats.iter().find(|s| s.topic == *topic);
            let s = s.unwrap_or_else(|| panic!("no {topic} channel"));
            // Nothing missed: the stream numbers run without a gap.
            assert_eq!((s.sequence_gaps, s.sequence_breaks), (0, 0), "{topic}");
        }
        // Calibration ends at 80 s: its event is there, with its level.
        let calibrated = contents.messages.iter().find(|m| {
            m.topic == "events"
                && m.value["text"]
                    .as_str()
                    .is_some_and(|t| t.contains("calibration done"))
        });
        assert_eq!(
            calibrated.map(|m| m.value["level"].clone()),
            Some("info".into())
        );
    }
}
