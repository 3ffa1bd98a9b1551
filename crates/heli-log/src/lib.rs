//! Flight logs of the heli avionics.
//!
//! What it is: the in-flight writer of the flight software's streams — the thesis's chapter 4
//! recommendation, "write sensor data to the onboard non-volatile flash memory in flight", so
//! that a crash no longer loses the flight's data — and the tools that read it back.
//!
//! - Format: [MCAP](https://mcap.dev), one channel per stream (`imu`, `state`, `servo`,
//!   `uplink`, `gps`, `baro`, `compass`) plus `events`, JSON-encoded messages stamped with
//!   the vehicle clock. Foxglove Studio and the `mcap` tools open it as it is.
//! - Crash safety: chunks are zstd-compressed and closed at least every 100 ms of log time
//!   ([`FLUSH_EVERY_US`]), so a file cut off anywhere — power lost, process killed — reads back
//!   up to its last closed chunk: at most the last 100 ms and the unfinished chunk are lost.
//! - Reading ([`read`]) never panics on a damaged file: it returns what it could read and
//!   says why it stopped.
//! - Export ([`to_csv`]) flattens one channel's messages into CSV for plotting elsewhere;
//!   [`plot`] draws a channel's fields against time as SVG or PNG, with the flight's events.
//!
//! What it is not: the stream buffers themselves (heli-fsw) or the conversion of flight
//! records to JSON (done by whoever owns the records).

use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

use serde_json::Value;

pub mod plot;

/// The seven streams whose histories are logged, in the thesis's order.
pub const STREAMS: [&str; 7] = ["imu", "state", "servo", "uplink", "gps", "baro", "compass"];

/// Longest stretch of log time between two closed chunks (µs).
pub const FLUSH_EVERY_US: u64 = 100_000;

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
    /// The MCAP layer refused.
    Mcap(mcap::McapError),
    /// A message could not be encoded.
    Encode(serde_json::Error),
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LogError::Io(e) => write!(f, "flight log: {e}"),
            LogError::Mcap(e) => write!(f, "flight log (MCAP): {e}"),
            LogError::Encode(e) => write!(f, "flight log message: {e}"),
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

/// The writer.
pub struct FlightLog<W: Write + Seek> {
    writer: mcap::Writer<W>,
    channels: BTreeMap<String, u16>,
    sequence: u32,
    last_flush_us: Option<u64>,
    messages: u64,
}

impl FlightLog<BufWriter<File>> {
    /// Creates a log file at `path` (replacing one that is there).
    pub fn create(path: &Path) -> Result<Self, LogError> {
        let file = File::create(path)?;
        Self::new(BufWriter::new(file))
    }
}

impl<W: Write + Seek> FlightLog<W> {
    /// A log written to `w`.
    pub fn new(w: W) -> Result<Self, LogError> {
        let options = mcap::WriteOptions::new()
            .profile("heli")
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(256 * 1024));
        Ok(Self {
            writer: options.create(w)?,
            channels: BTreeMap::new(),
            sequence: 0,
            last_flush_us: None,
            messages: 0,
        })
    }

    fn channel(&mut self, topic: &str) -> Result<u16, LogError> {
        if let Some(id) = self.channels.get(topic) {
            return Ok(*id);
        }
        let schema = self.writer.add_schema(
            &format!("heli.{topic}"),
            "jsonschema",
            br#"{"type":"object"}"#,
        )?;
        let id = self
            .writer
            .add_channel(schema, topic, "json", &BTreeMap::new())?;
        self.channels.insert(topic.to_string(), id);
        Ok(id)
    }

    /// Appends one message to `topic`, stamped `t_us` (vehicle clock). Closes the current
    /// chunk when [`FLUSH_EVERY_US`] of log time has passed since the last one.
    pub fn write(&mut self, topic: &str, t_us: u64, value: &Value) -> Result<(), LogError> {
        let channel_id = self.channel(topic)?;
        let data = serde_json::to_vec(value).map_err(LogError::Encode)?;
        let time_ns = t_us.saturating_mul(1000);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        self.writer.write_to_known_channel(&header, &data)?;
        self.sequence = self.sequence.wrapping_add(1);
        self.messages += 1;
        let last = *self.last_flush_us.get_or_insert(t_us);
        if t_us.saturating_sub(last) >= FLUSH_EVERY_US {
            self.writer.flush()?;
            self.last_flush_us = Some(t_us);
        }
        Ok(())
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// Closes the log (summary and footer) and returns the underlying writer.
    pub fn finish(mut self) -> Result<W, LogError> {
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }
}

/// One message read back.
#[derive(Clone, Debug, PartialEq)]
pub struct LoggedMessage {
    /// Channel.
    pub topic: String,
    /// Vehicle time (µs).
    pub t_us: u64,
    /// Content.
    pub value: Value,
}

/// What [`read`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct LogContents {
    /// Every message that could be read, in file order.
    pub messages: Vec<LoggedMessage>,
    /// Why reading stopped early, if it did (a file cut off by a crash stops at the last
    /// closed chunk).
    pub stopped: Option<String>,
    /// Messages whose content was not valid JSON or whose channel was never announced
    /// (counted, skipped).
    pub bad_messages: u64,
}

impl LogContents {
    /// Messages per channel.
    pub fn counts(&self) -> BTreeMap<String, u64> {
        let mut counts = BTreeMap::new();
        for m in &self.messages {
            *counts.entry(m.topic.clone()).or_insert(0) += 1;
        }
        counts
    }

    /// First and last message time (µs).
    pub fn span_us(&self) -> Option<(u64, u64)> {
        let first = self.messages.iter().map(|m| m.t_us).min()?;
        let last = self.messages.iter().map(|m| m.t_us).max()?;
        Some((first, last))
    }
}

/// Longest record the reader accepts beyond the file's own length (bytes). A record inside a
/// compressed chunk may be longer than the file, but the flight software's messages are a few
/// hundred bytes; the bound stops a corrupt length field from asking for exabytes.
pub const RECORD_LENGTH_SLACK: usize = 16 << 20;

/// Reads a log's bytes, as far as they go.
///
/// Built on mcap's sans-I/O reader with a record length limit: `mcap::MessageStream` sets
/// none, and a corrupt length inside a chunk made it try to allocate the length it read
/// (found by the `log_reader` fuzz target, docs/fuzzing.md).
pub fn read(bytes: &[u8]) -> LogContents {
    let mut contents = LogContents {
        messages: Vec::new(),
        stopped: None,
        bad_messages: 0,
    };
    // mcap 0.26 subtracts a record's length from an uncompressed chunk's remaining size
    // unchecked, so a corrupt length panics where overflow checks are on (debug builds). What
    // was read before stays; the panic becomes the reason reading stopped.
    let finished = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_into(bytes, &mut contents)
    }));
    if finished.is_err() {
        contents.stopped = Some("the MCAP reader failed on a corrupt record".into());
    }
    contents
}

fn read_into(bytes: &[u8], contents: &mut LogContents) {
    use mcap::records::Record;
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

    let options = LinearReaderOptions::default()
        .with_record_length_limit(bytes.len().saturating_add(RECORD_LENGTH_SLACK));
    let mut reader = LinearReader::new_with_options(options);
    let mut rest = bytes;
    let mut topics: BTreeMap<u16, String> = BTreeMap::new();
    while let Some(event) = reader.next_event() {
        let record = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
                continue;
            }
            // Only channels and messages are needed; other records are not parsed at all.
            Ok(LinearReadEvent::Record { data, opcode }) => match opcode {
                OP_CHANNEL if !channel_lengths_fit(data) => {
                    contents.stopped = Some("channel record with a corrupt length".into());
                    break;
                }
                OP_CHANNEL | OP_MESSAGE => mcap::parse_record(opcode, data),
                _ => continue,
            },
            Err(e) => Err(e),
        };
        match record {
            Ok(Record::Channel(channel)) => {
                topics.insert(channel.id, channel.topic);
            }
            Ok(Record::Message { header, data }) => {
                let topic = topics.get(&header.channel_id);
                match (topic, serde_json::from_slice::<Value>(&data)) {
                    (Some(topic), Ok(value)) => contents.messages.push(LoggedMessage {
                        topic: topic.clone(),
                        t_us: header.log_time / 1000,
                        value,
                    }),
                    _ => contents.bad_messages += 1,
                }
            }
            Ok(_) => {}
            Err(e) => {
                contents.stopped = Some(e.to_string());
                break;
            }
        }
    }
}

/// MCAP opcode of a Channel record.
const OP_CHANNEL: u8 = 0x04;
/// MCAP opcode of a Message record.
const OP_MESSAGE: u8 = 0x05;

/// Whether every length field of a Channel record body fits inside it: topic, message
/// encoding, and the metadata map with each of its keys and values. mcap's parser reserves a
/// string's stated length before reading it, so a corrupt length would ask for up to 4 GiB
/// (found by the `log_reader` fuzz target).
fn channel_lengths_fit(body: &[u8]) -> bool {
    /// The `u32`-length-prefixed field at `at`: its contents' range, if it fits in `end`.
    fn field(body: &[u8], at: usize, end: usize) -> Option<(usize, usize)> {
        let len_bytes: [u8; 4] = body.get(at..at.checked_add(4)?)?.try_into().ok()?;
        let start = at + 4;
        let stop = start.checked_add(u32::from_le_bytes(len_bytes) as usize)?;
        (stop <= end).then_some((start, stop))
    }
    let end = body.len();
    // id (u16) and schema id (u16), then topic and message encoding.
    let Some((_, after_topic)) = field(body, 4, end) else {
        return false;
    };
    let Some((_, after_encoding)) = field(body, after_topic, end) else {
        return false;
    };
    let Some((mut at, map_end)) = field(body, after_encoding, end) else {
        return false;
    };
    while at < map_end {
        let Some((_, after_key)) = field(body, at, map_end) else {
            return false;
        };
        let Some((_, after_value)) = field(body, after_key, map_end) else {
            return false;
        };
        at = after_value;
    }
    true
}

/// Calls `leaf` with the flattened name (`a.b`, `v[2]`) and value of every scalar in `value`.
fn for_each_leaf(prefix: &str, value: &Value, leaf: &mut dyn FnMut(String, &Value)) {
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
            Value::String(s) => s.replace([',', '\n'], " "),
            Value::Null => String::new(),
            other => other.to_string(),
        };
        out.push((name, text));
    });
}

/// One channel's messages as CSV: a `t_s` column, then one column per (flattened) field,
/// named after the first message.
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
    let Some((_, first)) = rows.first() else {
        return String::new();
    };
    let columns: Vec<String> = first.iter().map(|(k, _)| k.clone()).collect();
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
    use serde_json::json;
    use std::io::Cursor;

    fn write_flight(seconds: u64) -> Vec<u8> {
        let mut log = FlightLog::new(Cursor::new(Vec::new())).unwrap_or_else(|e| panic!("{e}"));
        for k in 0..seconds * 100 {
            let t = k * 10_000;
            log.write(
                "imu",
                t,
                &json!({"rate_rps": [0.01, 0.0, k as f64], "temp_c": 25.0}),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            if k % 2 == 0 {
                log.write(
                    "state",
                    t,
                    &json!({"phase": "hold", "pos_ned_m": [1.0, 2.0, -10.0]}),
                )
                .unwrap_or_else(|e| panic!("{e}"));
            }
        }
        log.finish().unwrap_or_else(|e| panic!("{e}")).into_inner()
    }

    #[test]
    fn one_file_per_stream_with_the_suffix() {
        let names: Vec<String> = STREAMS
            .iter()
            .map(|s| file_name(s, "nov18", "csv"))
            .collect();
        assert_eq!(names[0], "imu_nov18.csv");
        assert_eq!(names.len(), 7);
    }

    #[test]
    fn a_complete_log_reads_back_every_message() {
        let bytes = write_flight(20);
        let contents = read(&bytes);
        assert_eq!(contents.stopped, None);
        assert_eq!(contents.counts().get("imu"), Some(&2000));
        assert_eq!(contents.counts().get("state"), Some(&1000));
        assert_eq!(contents.span_us(), Some((0, 19_990_000)));
    }

    #[test]
    fn a_log_cut_off_by_a_crash_reads_back_up_to_its_last_closed_chunk() {
        let bytes = write_flight(20);
        for cut in [0.3, 0.55, 0.8, 0.97] {
            let cut_at = (bytes.len() as f64 * cut) as usize;
            let contents = read(&bytes[..cut_at]);
            assert!(contents.stopped.is_some(), "a cut file says it stopped");
            // What was read is exactly the start of the flight, in order.
            let imu: Vec<u64> = contents
                .messages
                .iter()
                .filter(|m| m.topic == "imu")
                .map(|m| m.t_us)
                .collect();
            assert!(
                imu.iter().enumerate().all(|(i, t)| *t == i as u64 * 10_000),
                "a prefix"
            );
            // Chunks are closed every 100 ms of log time; compressed, the cut loses at most
            // the unfinished chunk: the recovered time is close to the cut's share.
            let last_s = imu.last().copied().unwrap_or(0) as f64 * 1e-6;
            assert!(
                last_s >= 20.0 * cut - 1.0,
                "cut at {cut}: recovered up to {last_s} s"
            );
        }
    }

    #[test]
    fn a_corrupt_record_length_is_an_error_not_an_allocation() {
        // Found by the log_reader fuzz target: the start of a real log with one length field
        // inside a chunk corrupted to 8.2e18 bytes. mcap's MessageStream tried to allocate it
        // and the process aborted; read() bounds record lengths and stops with a reason.
        let bytes = include_bytes!("../tests/data/corrupt_record_length.mcap");
        let contents = read(bytes);
        assert!(contents.stopped.is_some());
        assert!(contents.messages.len() < 200);
    }

    #[test]
    fn a_corrupt_length_in_an_uncompressed_chunk_stops_reading() {
        // mcap subtracts a record's length from an uncompressed chunk's remaining size without
        // a check (a panic where overflow checks are on); read() must stop with a reason and
        // keep the messages before it, in any build.
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .create(Cursor::new(Vec::new()))
            .unwrap();
        let schema = w.add_schema("heli.state", "jsonschema", b"{}").unwrap();
        let channel = w
            .add_channel(schema, "state", "json", &BTreeMap::new())
            .unwrap();
        for i in 0..3u32 {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: i,
                log_time: u64::from(i) * 1000,
                publish_time: u64::from(i) * 1000,
            };
            let data = format!(r#"{{"n":{i},"mark":"message{i}"}}"#);
            w.write_to_known_channel(&header, data.as_bytes()).unwrap();
        }
        w.finish().unwrap();
        let mut bytes = w.into_inner().into_inner();
        assert_eq!(read(&bytes).messages.len(), 3);
        // The third message record's length field: 8 bytes before its 22-byte header.
        let at = bytes
            .windows(17)
            .position(|x| x.starts_with(br#"{"n":2,"#))
            .unwrap();
        let length_at = at - 22 - 8;
        // Longer than what is left of the chunk, but not than the file: the reader takes the
        // bytes after the chunk as part of the record.
        let length = u64::from_le_bytes(bytes[length_at..length_at + 8].try_into().unwrap());
        bytes[length_at..length_at + 8].copy_from_slice(&(length + 20).to_le_bytes());
        let contents = read(&bytes);
        assert!(contents.stopped.is_some());
        assert_eq!(contents.messages.len(), 2);
    }

    #[test]
    fn channel_record_lengths_are_checked_before_parsing() {
        fn prefixed(out: &mut Vec<u8>, bytes: &[u8]) {
            out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
            out.extend_from_slice(bytes);
        }
        let mut map = Vec::new();
        prefixed(&mut map, b"unit");
        prefixed(&mut map, b"SI");
        let mut body = vec![1, 0, 0, 0];
        prefixed(&mut body, b"state");
        prefixed(&mut body, b"json");
        prefixed(&mut body, &map);
        assert!(channel_lengths_fit(&body));
        assert!(matches!(
            mcap::parse_record(OP_CHANNEL, &body),
            Ok(mcap::records::Record::Channel(c)) if c.topic == "state"
        ));
        // Any length field made too long, or the body cut short, is refused.
        for at in [4, 13, 21, 25, 33] {
            let mut bad = body.clone();
            bad[at + 3] = 0xff;
            assert!(!channel_lengths_fit(&bad), "length at {at}");
        }
        for cut in 0..body.len() {
            assert!(!channel_lengths_fit(&body[..cut]), "cut at {cut}");
        }
    }

    #[test]
    fn garbage_and_empty_input_are_reported_not_panicked_on() {
        assert!(read(&[]).stopped.is_some());
        assert!(read(b"not an mcap file at all").stopped.is_some());
        let mut bytes = write_flight(2);
        let middle = bytes.len() / 2;
        for b in bytes.iter_mut().skip(middle).take(64) {
            *b ^= 0x5a;
        }
        let contents = read(&bytes);
        assert!(contents.messages.len() < 300);
    }

    #[test]
    fn csv_export_flattens_fields() {
        let contents = read(&write_flight(1));
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
}
