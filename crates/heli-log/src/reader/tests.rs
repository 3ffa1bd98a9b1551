//! Tests of the reader: whole, cut and damaged files.

use super::*;
use crate::testutil::write_flight;
use std::io::Cursor;

#[test]
fn a_complete_log_reads_back_every_message() {
    let bytes = write_flight(20);
    let contents = read(&bytes);
    assert_eq!(contents.stopped, None);
    assert!(contents.closed);
    assert_eq!(contents.counts().get("imu"), Some(&2000));
    assert_eq!(contents.counts().get("state"), Some(&1000));
    assert_eq!(contents.span_us(), Some((0, 19_990_000)));
    assert_eq!(
        contents.schemas.get("imu").map(String::as_str),
        Some("heli.imu")
    );
}

#[test]
fn a_log_cut_off_by_a_crash_reads_back_up_to_its_last_whole_chunk() {
    let bytes = write_flight(20);
    for cut in [0.3, 0.55, 0.8, 0.97] {
        let cut_at = (bytes.len() as f64 * cut) as usize;
        let contents = read(&bytes[..cut_at]);
        let stop = contents
            .stopped
            .clone()
            .unwrap_or_else(|| panic!("cut at {cut}"));
        assert_eq!(stop.kind, StopKind::Truncated, "{stop}");
        assert!(!contents.closed);
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
        // Chunks are closed every 100 ms of log time: the cut loses at most the unfinished
        // chunk, so the recovered time is close to the cut's share.
        let last_s = imu.last().copied().unwrap_or(0) as f64 * 1e-6;
        assert!(
            last_s >= 20.0 * cut - 1.0,
            "cut at {cut}: recovered up to {last_s} s"
        );
    }
}

#[test]
fn a_chunk_that_mcaps_own_writer_never_finished_reads_as_cut_off() {
    // mcap's seeking writer puts an all-ones placeholder chunk header in the file and patches
    // it when the chunk closes; a process killed in between leaves it there.
    let mut w = mcap::WriteOptions::new()
        .create(Cursor::new(Vec::new()))
        .unwrap_or_else(|e| panic!("{e}"));
    let schema = w
        .add_schema("heli.state", "jsonschema", b"{}")
        .unwrap_or_default();
    let channel = w
        .add_channel(schema, "state", "json", &BTreeMap::new())
        .unwrap_or_default();
    for i in 0..10u32 {
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: i,
            log_time: u64::from(i) * 1000,
            publish_time: u64::from(i) * 1000,
        };
        w.write_to_known_channel(&header, br#"{"n":1}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        if i == 4 {
            w.flush().unwrap_or_else(|e| panic!("{e}"));
        }
    }
    let bytes = w.into_inner().into_inner();
    let contents = read(&bytes);
    let stop = contents.stopped.unwrap_or_else(|| panic!("not finished"));
    assert_eq!(stop.kind, StopKind::Truncated, "{stop}");
    assert!(stop.detail.contains("never finished"), "{stop}");
    assert_eq!(contents.messages.len(), 5);
}

#[test]
fn a_corrupt_record_length_is_an_error_not_an_allocation() {
    // Found by the log_reader fuzz target: the start of a real log with one length field
    // inside a chunk corrupted to 8.2e18 bytes. mcap's MessageStream tried to allocate it
    // and the process aborted; read() bounds record lengths and stops with a reason.
    let bytes = include_bytes!("../../tests/data/corrupt_record_length.mcap");
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
        .unwrap_or_else(|e| panic!("{e}"));
    let schema = w
        .add_schema("heli.state", "jsonschema", b"{}")
        .unwrap_or_default();
    let channel = w
        .add_channel(schema, "state", "json", &BTreeMap::new())
        .unwrap_or_default();
    for i in 0..3u32 {
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: i,
            log_time: u64::from(i) * 1000,
            publish_time: u64::from(i) * 1000,
        };
        let data = format!(r#"{{"n":{i},"mark":"message{i}"}}"#);
        w.write_to_known_channel(&header, data.as_bytes())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
    let mut bytes = w.into_inner().into_inner();
    assert_eq!(read(&bytes).messages.len(), 3);
    // The third message record's length field: 8 bytes before its 22-byte header.
    let at = bytes
        .windows(17)
        .position(|x| x.starts_with(br#"{"n":2,"#))
        .unwrap_or_default();
    let length_at = at - 22 - 8;
    // Longer than what is left of the chunk, but not than the file: the reader takes the
    // bytes after the chunk as part of the record.
    let length = u64::from_le_bytes(
        bytes[length_at..length_at + 8]
            .try_into()
            .unwrap_or_default(),
    );
    bytes[length_at..length_at + 8].copy_from_slice(&(length + 20).to_le_bytes());
    let contents = read(&bytes);
    assert_eq!(contents.stopped.map(|s| s.kind), Some(StopKind::Corrupt));
    // The chunk's CRC is checked before any of its records is taken: a damaged chunk gives
    // none (never a message read through a corrupt length).
    assert_eq!(contents.messages.len(), 0);
}

fn prefixed(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(bytes);
}

#[test]
fn channel_record_lengths_are_checked_before_parsing() {
    let mut map = Vec::new();
    prefixed(&mut map, b"unit");
    prefixed(&mut map, b"SI");
    let mut body = vec![1, 0, 0, 0];
    prefixed(&mut body, b"state");
    prefixed(&mut body, b"json");
    prefixed(&mut body, &map);
    assert_eq!(parse_channel(&body), Some((1, 0, "state".to_string())));
    assert!(matches!(
        mcap::parse_record(op::CHANNEL, &body),
        Ok(mcap::records::Record::Channel(c)) if c.topic == "state"
    ));
    // Any length field made too long, or the body cut short, is refused.
    for at in [4, 13, 21, 25, 33] {
        let mut bad = body.clone();
        bad[at + 3] = 0xff;
        assert_eq!(parse_channel(&bad), None, "length at {at}");
    }
    for cut in 0..body.len() {
        assert_eq!(parse_channel(&body[..cut]), None, "cut at {cut}");
    }
}

#[test]
fn metadata_record_lengths_are_checked_too() {
    let mut map = Vec::new();
    prefixed(&mut map, b"software");
    prefixed(&mut map, b"heli 0.1.0");
    let mut body = Vec::new();
    prefixed(&mut body, b"flight");
    prefixed(&mut body, &map);
    let parsed = parse_metadata(&body).unwrap_or_default();
    assert_eq!(parsed.name, "flight");
    assert_eq!(
        parsed.entries.get("software").map(String::as_str),
        Some("heli 0.1.0")
    );
    for at in [0, 10, 14, 26] {
        let mut bad = body.clone();
        bad[at + 3] = 0xff;
        assert_eq!(parse_metadata(&bad), None, "length at {at}");
    }
    for cut in 0..body.len() {
        assert_eq!(parse_metadata(&body[..cut]), None, "cut at {cut}");
    }
}

#[test]
fn garbage_and_empty_input_are_reported_not_panicked_on() {
    for (bytes, words) in [
        (&b""[..], "empty"),
        (&b"\x89MCA"[..], "only 4 bytes"),
        (&b"not an mcap file at all"[..], "MCAP magic"),
    ] {
        let contents = read(bytes);
        let stop = contents.stopped.unwrap_or_else(|| panic!("{bytes:?}"));
        assert_eq!(stop.kind, StopKind::NotMcap);
        assert!(stop.to_string().contains(words), "{stop}");
    }
    let mut bytes = write_flight(2);
    let middle = bytes.len() / 2;
    for b in bytes.iter_mut().skip(middle).take(64) {
        *b ^= 0x5a;
    }
    let contents = read(&bytes);
    assert!(contents.messages.len() < 300);
    let stop = contents.stopped.unwrap_or_else(|| panic!("damaged"));
    assert!(stop.at_byte <= bytes.len() as u64 && stop.file_bytes == bytes.len() as u64);
    assert!(stop.to_string().contains("byte"), "{stop}");
}
