//! Reading a log back, as far as its bytes go, without ever panicking.
//!
//! Built on mcap's sans-I/O linear reader with a record length limit (`mcap::MessageStream`
//! sets none, and a corrupt length inside a chunk made it try to allocate the length it read:
//! found by the `log_reader` fuzz target, docs/fuzzing.md). Only the records a flight log
//! needs are parsed, each by a parser that checks every length field against the record
//! before trusting it: Schema (its name), Channel, Message, Metadata and Footer.

use std::collections::BTreeMap;
use std::fmt;

use serde_json::Value;

/// One message read back.
#[derive(Clone, Debug, PartialEq)]
pub struct LoggedMessage {
    /// Channel.
    pub topic: String,
    /// Vehicle time (µs).
    pub t_us: u64,
    /// The channel's sequence number of this message.
    pub sequence: u32,
    /// Content.
    pub value: Value,
}

/// One Metadata record read back.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LogMetadata {
    /// Its name (`flight` for [`crate::metadata::flight`]).
    pub name: String,
    /// Its key–value pairs.
    pub entries: BTreeMap<String, String>,
}

/// Why reading stopped before the end of a well-formed file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopKind {
    /// The bytes are not an MCAP file (no MCAP magic at the start, or too short for it).
    NotMcap,
    /// The file ends inside a record: cut off by a crash, a kill or a copy that stopped.
    Truncated,
    /// A record that is there could not be read: the file is damaged.
    Corrupt,
}

/// Where and why reading stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stop {
    /// What kind of stop.
    pub kind: StopKind,
    /// Bytes of the file handed to the reader when it stopped (the trouble is in the record
    /// that ends at or before this offset, or in the chunk that holds it).
    pub at_byte: u64,
    /// Length of the file (bytes).
    pub file_bytes: u64,
    /// The reader's own words.
    pub detail: String,
}

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (at, len) = (self.at_byte, self.file_bytes);
        match self.kind {
            StopKind::NotMcap => write!(f, "not an MCAP file ({})", self.detail),
            StopKind::Truncated => {
                write!(
                    f,
                    "the file ends inside a record at byte {len} ({})",
                    self.detail
                )
            }
            StopKind::Corrupt => write!(
                f,
                "corrupt record at or before byte {at} of {len} ({})",
                self.detail
            ),
        }
    }
}

/// What [`read`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LogContents {
    /// Every message that could be read, in file order.
    pub messages: Vec<LoggedMessage>,
    /// Why reading stopped early, if it did (a file cut off by a crash stops at the last
    /// whole chunk).
    pub stopped: Option<Stop>,
    /// Messages whose content was not valid JSON or whose channel was never announced
    /// (counted, skipped).
    pub bad_messages: u64,
    /// Schema name of each channel (`heli.state`, `foxglove.Log`, …).
    pub schemas: BTreeMap<String, String>,
    /// Metadata records, in file order.
    pub metadata: Vec<LogMetadata>,
    /// Whether the file ends with the summary [`crate::FlightLog::finish`] writes. `false`
    /// for a file whose writer never finished (crash, kill, power loss): it ends at the
    /// provisional end of its last flush, or is cut off.
    pub closed: bool,
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
pub fn read(bytes: &[u8]) -> LogContents {
    let mut contents = LogContents::default();
    let mut fed = 0usize;
    // mcap 0.26 subtracts a record's length from an uncompressed chunk's remaining size
    // unchecked, so a corrupt length panics where overflow checks are on (debug builds). What
    // was read before stays; the panic becomes the reason reading stopped.
    let finished = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_into(bytes, &mut contents, &mut fed)
    }));
    if finished.is_err() {
        contents.stopped = Some(stop(
            StopKind::Corrupt,
            fed,
            bytes,
            "the MCAP reader failed on a corrupt record",
        ));
    }
    contents
}

fn stop(kind: StopKind, fed: usize, bytes: &[u8], detail: impl Into<String>) -> Stop {
    Stop {
        kind,
        at_byte: fed as u64,
        file_bytes: bytes.len() as u64,
        detail: detail.into(),
    }
}

/// MCAP opcodes of the records read here.
mod op {
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const METADATA: u8 = 0x0c;
}

/// The MCAP magic, at both ends of a file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// A Chunk record whose length is still the all-ones placeholder that mcap's seeking writer
/// puts in the file before the chunk's data, to patch when the chunk is closed.
const UNFINISHED_CHUNK: [u8; 9] = [0x06, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff];

fn read_into(bytes: &[u8], contents: &mut LogContents, fed: &mut usize) {
    use mcap::McapError;
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

    if !bytes.starts_with(MAGIC) {
        let detail = if bytes.is_empty() {
            "the file is empty".to_string()
        } else if MAGIC.starts_with(bytes) {
            format!("only {} bytes, the start of the MCAP magic", bytes.len())
        } else {
            "it does not begin with the MCAP magic bytes".to_string()
        };
        contents.stopped = Some(stop(StopKind::NotMcap, 0, bytes, detail));
        return;
    }
    // Every chunk's CRC is checked before any of its records is taken (a damaged chunk
    // gives none, and reading stops there), and so are the data and summary sections' CRCs.
    let options = LinearReaderOptions::default()
        .with_record_length_limit(bytes.len().saturating_add(RECORD_LENGTH_SLACK))
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true);
    let mut reader = LinearReader::new_with_options(options);
    let mut rest = bytes;
    let mut topics: BTreeMap<u16, String> = BTreeMap::new();
    let mut schema_names: BTreeMap<u16, String> = BTreeMap::new();
    while let Some(event) = reader.next_event() {
        let (opcode, data) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
                *fed += n;
                continue;
            }
            Ok(LinearReadEvent::Record { data, opcode }) => (opcode, data),
            Err(e) => {
                // The reader wanted bytes past the end: the file was cut off, unless it ends
                // with the closing magic (then a length field inside it is wrong).
                let past_end = matches!(
                    e,
                    McapError::UnexpectedEof
                        | McapError::UnexpectedEoc
                        | McapError::RecordTooLarge { .. }
                        | McapError::BadChunkLength { .. }
                );
                let cut_off = past_end && *fed == bytes.len() && !bytes.ends_with(MAGIC);
                contents.stopped = Some(if let McapError::BadChunkCrc { saved, calculated } = e {
                    let detail = format!(
                        "the chunk ending at byte {fed} fails its CRC (stored {saved:#010x}, \
                         computed {calculated:#010x}): none of its messages is used",
                        fed = *fed
                    );
                    stop(StopKind::Corrupt, *fed, bytes, detail)
                } else if let McapError::DecompressionError(why) = e {
                    // The CRC is of the uncompressed bytes: a damaged compressed chunk may
                    // fail to decompress before its CRC can be computed.
                    let detail = format!(
                        "the chunk ending at byte {fed} does not decompress ({why}): none of \
                         its messages is used",
                        fed = *fed
                    );
                    stop(StopKind::Corrupt, *fed, bytes, detail)
                } else if !cut_off {
                    stop(StopKind::Corrupt, *fed, bytes, e.to_string())
                } else if bytes.windows(9).any(|w| w == UNFINISHED_CHUNK) {
                    let detail = "a chunk that was never finished: its length is still the \
                                  writer's placeholder";
                    stop(StopKind::Truncated, *fed, bytes, detail)
                } else {
                    stop(StopKind::Truncated, *fed, bytes, e.to_string())
                });
                return;
            }
        };
        let parsed = match opcode {
            op::SCHEMA => parse_schema(data).map(|(id, name)| {
                schema_names.insert(id, name);
            }),
            op::CHANNEL => parse_channel(data).map(|(id, schema_id, topic)| {
                if let Some(name) = schema_names.get(&schema_id) {
                    contents.schemas.insert(topic.clone(), name.clone());
                }
                topics.insert(id, topic);
            }),
            op::MESSAGE => parse_message(data).map(|(channel_id, sequence, log_time, payload)| {
                let topic = topics.get(&channel_id);
                match (topic, serde_json::from_slice::<Value>(payload)) {
                    (Some(topic), Ok(value)) => contents.messages.push(LoggedMessage {
                        topic: topic.clone(),
                        t_us: log_time / 1000,
                        sequence,
                        value,
                    }),
                    _ => contents.bad_messages += 1,
                }
            }),
            op::METADATA => parse_metadata(data).map(|m| contents.metadata.push(m)),
            op::FOOTER => parse_u64(data, 0).map(|summary_start| {
                contents.closed = summary_start != 0;
            }),
            _ => Some(()),
        };
        if parsed.is_none() {
            let detail = format!("a record (opcode {opcode:#04x}) with a corrupt length field");
            contents.stopped = Some(stop(StopKind::Corrupt, *fed, bytes, detail));
            return;
        }
    }
}

/// The little-endian `u64` at `at`.
fn parse_u64(body: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        body.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

/// The little-endian `u16` at `at`.
fn parse_u16(body: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(
        body.get(at..at.checked_add(2)?)?.try_into().ok()?,
    ))
}

/// The `u32`-length-prefixed field at `at`: its contents' range, if it fits in `end`.
fn field(body: &[u8], at: usize, end: usize) -> Option<(usize, usize)> {
    let len_bytes: [u8; 4] = body.get(at..at.checked_add(4)?)?.try_into().ok()?;
    let start = at + 4;
    let stop = start.checked_add(u32::from_le_bytes(len_bytes) as usize)?;
    (stop <= end && end <= body.len()).then_some((start, stop))
}

/// The `u32`-length-prefixed UTF-8 string at `at`, and where it ends.
fn string(body: &[u8], at: usize, end: usize) -> Option<(String, usize)> {
    let (start, stop) = field(body, at, end)?;
    let text = std::str::from_utf8(body.get(start..stop)?).ok()?;
    Some((text.to_string(), stop))
}

/// A `u32`-byte-length map of string keys to string values at `at`, and where it ends.
fn string_map(body: &[u8], at: usize) -> Option<(BTreeMap<String, String>, usize)> {
    let (mut at, map_end) = field(body, at, body.len())?;
    let mut map = BTreeMap::new();
    while at < map_end {
        let (key, after_key) = string(body, at, map_end)?;
        let (value, after_value) = string(body, after_key, map_end)?;
        map.insert(key, value);
        at = after_value;
    }
    Some((map, map_end))
}

/// Schema record: id and name (the schema's text is not needed).
fn parse_schema(body: &[u8]) -> Option<(u16, String)> {
    let id = parse_u16(body, 0)?;
    let (name, _) = string(body, 2, body.len())?;
    Some((id, name))
}

/// Channel record: id, schema id and topic, every length field checked (mcap's own parser
/// reserves a string's stated length before reading it, so a corrupt length would ask for up
/// to 4 GiB: found by the `log_reader` fuzz target).
fn parse_channel(body: &[u8]) -> Option<(u16, u16, String)> {
    let id = parse_u16(body, 0)?;
    let schema_id = parse_u16(body, 2)?;
    let (topic, after_topic) = string(body, 4, body.len())?;
    let (_encoding, after_encoding) = string(body, after_topic, body.len())?;
    string_map(body, after_encoding)?;
    Some((id, schema_id, topic))
}

/// Message record: channel id, sequence, log time and payload.
fn parse_message(body: &[u8]) -> Option<(u16, u32, u64, &[u8])> {
    let channel_id = parse_u16(body, 0)?;
    let sequence = u32::from_le_bytes(body.get(2..6)?.try_into().ok()?);
    let log_time = parse_u64(body, 6)?;
    Some((channel_id, sequence, log_time, body.get(22..)?))
}

/// Metadata record: name and map.
fn parse_metadata(body: &[u8]) -> Option<LogMetadata> {
    let (name, after_name) = string(body, 0, body.len())?;
    let (entries, _) = string_map(body, after_name)?;
    Some(LogMetadata { name, entries })
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod damage_tests {
    use super::*;
    use crate::testutil::write_flight;

    /// Every byte of a finished log, flipped one at a time (one bit of each), is noticed:
    /// the reader never calls a damaged file complete, and never returns a message that
    /// is not the one written.
    #[test]
    fn one_flipped_byte_anywhere_is_never_read_as_a_complete_log() {
        let good = write_flight(2);
        let original = read(&good);
        assert_eq!((original.stopped.clone(), original.closed), (None, true));
        let mut unnoticed = Vec::new();
        for at in 0..good.len() {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            let contents = read(&bad);
            for m in &contents.messages {
                assert!(
                    original.messages.contains(m),
                    "byte {at}: a message never written"
                );
            }
            if contents.stopped.is_none() && contents.messages == original.messages {
                unnoticed.push(at);
            }
        }
        assert!(
            unnoticed.is_empty(),
            "flips not noticed at bytes {unnoticed:?} of {}",
            good.len()
        );
    }
}
