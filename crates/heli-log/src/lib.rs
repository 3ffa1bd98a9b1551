//! Flight logs of the heli avionics.
//!
//! What it is: the in-flight writer of the flight software's streams — the thesis's chapter 4
//! recommendation, "write sensor data to the onboard non-volatile flash memory in flight", so
//! that a crash no longer loses the flight's data — and the tools that read it back.
//!
//! - Format ([`writer`]): [MCAP](https://mcap.dev), one channel per stream (`imu`, `state`,
//!   `servo`, `uplink`, `gps`, `baro`, `compass`) plus `events`, JSON-encoded messages stamped
//!   with the vehicle clock, each channel with a real JSON Schema ([`schema`]) and its own
//!   sequence numbers; `foxglove/tf`, `foxglove/fix` and `foxglove/log` repeat the pose, the
//!   GPS fix and the events in Foxglove's well-known schemas so its 3D, map and log panels
//!   show a flight with no configuration, and `foxglove/scene` ([`scene`]) puts the X-Cell's
//!   own shape on the body frame for the 3D panel. Metadata records hold the flight's parameters.
//! - Crash safety: the writer keeps the chunk it is filling in memory and, at least every
//!   100 ms of log time ([`FLUSH_EVERY_US`]) or of wall-clock time ([`FLUSH_EVERY_WALL`]),
//!   appends it to the file as complete records in one write, followed by a 50-byte
//!   provisional end (DataEnd, Footer, magic) that the next write replaces. After every flush
//!   the file is a complete MCAP file that the official readers open; a crash loses at most the
//!   chunk being filled. Flushed data is `sync_data`ed at most [`SYNC_EVERY_WALL`] apart.
//! - Reading ([`read`]) never panics on a damaged file: it returns what it could read and
//!   says why and where it stopped; [`stats`] gives per-channel rates, gaps and the warnings.
//! - Conversion ([`records`], [`events`]): the flight software's stream records and core
//!   events as log messages, shared by the simulator's logger and the vehicle runtime.
//! - Export ([`to_csv`]) flattens one channel's messages into CSV for plotting elsewhere.
//! - Small files kept beside the logs ([`replace`]) are replaced whole and synced, so that a
//!   power loss leaves the old one or the new one.
//!
//! What it is not: the stream buffers themselves (heli-fsw), or plots of a log (the
//! workstation's `heli-campaign`): the onboard program links this crate.

use std::fmt;

pub mod events;
pub mod export;
pub mod foxglove;
pub mod inputs;
pub mod metadata;
pub mod reader;
pub mod records;
pub mod replace;
pub mod scene;
pub mod schema;
pub mod stats;
pub mod writer;

pub use events::{EventLevel, event_json};
pub use export::for_each_leaf;
pub use export::to_csv;
pub use reader::{
    LogContents, LogMetadata, LoggedMessage, RECORD_LENGTH_SLACK, Stop, StopKind, read,
};
pub use records::record_json;
pub use writer::{
    FLUSH_EVERY_US, FLUSH_EVERY_WALL, FlightLog, LogFile, LogOptions, SYNC_EVERY_WALL, WriterStats,
};

/// The seven streams whose histories are logged, in the thesis's order.
pub const STREAMS: [&str; 7] = ["imu", "state", "servo", "uplink", "gps", "baro", "compass"];

/// Name of one stream's log file: `<stream>_<suffix>.<extension>`, as the thesis's cleanup
/// routine names one file per shared-memory buffer with the operator's suffix.
pub fn file_name(stream: &str, suffix: &str, extension: &str) -> String {
    format!("{stream}_{suffix}.{extension}")
}

/// Something went wrong writing or reading a log.
#[derive(Debug)]
pub enum LogError {
    /// The file could not be created, written or read.
    Io(std::io::Error),
    /// The file's data could not be synced to the storage (`sync_data`): what was written
    /// since the last sync that worked may not survive a power loss.
    Sync(std::io::Error),
    /// The MCAP layer refused.
    Mcap(mcap::McapError),
    /// A message could not be encoded.
    Encode(serde_json::Error),
    /// The log was already finished (or its writer failed while finishing).
    Finished,
    /// A message was dropped: the file has refused writes and the records kept for it fill
    /// the writer's backlog ([`writer::MAX_BACKLOG_BYTES`]).
    Dropped {
        /// Bytes of records waiting for the file.
        backlog_bytes: usize,
    },
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LogError::Io(e) => write!(f, "flight log: {e}"),
            LogError::Sync(e) => write!(
                f,
                "flight log: sync to the storage failed ({e}): what was written since the last \
                 sync that worked may not survive a power loss"
            ),
            LogError::Mcap(e) => write!(f, "flight log (MCAP): {e}"),
            LogError::Encode(e) => write!(f, "flight log message: {e}"),
            LogError::Finished => write!(f, "flight log: already finished"),
            LogError::Dropped { backlog_bytes } => write!(
                f,
                "flight log: message dropped (the storage refuses writes and {backlog_bytes} \
                 bytes wait for it)"
            ),
        }
    }
}

impl std::error::Error for LogError {}

impl From<std::io::Error> for LogError {
    fn from(e: std::io::Error) -> Self {
        LogError::Io(e)
    }
}

impl From<mcap::McapError> for LogError {
    fn from(e: mcap::McapError) -> Self {
        LogError::Mcap(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_per_stream_with_the_suffix() {
        let names: Vec<String> = STREAMS
            .iter()
            .map(|s| file_name(s, "nov18", "csv"))
            .collect();
        assert_eq!(names[0], "imu_nov18.csv");
        assert_eq!(names.len(), 7);
    }
}

#[cfg(test)]
pub(crate) mod testutil;
