//! How much of a log its indexes take, for chunks closed every 100 ms, 1 s, 10 s or once,
//! with mcap's message and chunk indexes and without: the numbers in docs/logging.md.
//!
//! ```sh
//! cargo run --release -- sim --scenario hover --log /tmp/x.mcap
//! cargo run --release -p heli-log --example chunking -- /tmp/x.mcap
//! ```
//!
//! Rewrites the log's messages (same channels, schemas, sequence numbers and times) with
//! mcap's writer at each setting and counts the bytes of each record type.

use std::collections::BTreeMap;
use std::io::Cursor;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: chunking <log.mcap>");
        std::process::exit(2);
    };
    let bytes = std::fs::read(&path).unwrap_or_else(|e| {
        eprintln!("chunking: {path}: {e}");
        std::process::exit(2)
    });
    let contents = heli_log::read(&bytes);
    if contents.messages.is_empty() {
        eprintln!("chunking: {path}: no messages");
        std::process::exit(2);
    }
    println!(
        "{path}: {} messages, {} bytes as written",
        contents.messages.len(),
        bytes.len()
    );
    println!("chunk every  indexes   file bytes  index bytes  index share");
    for (label, every_us) in [
        ("100 ms", 100_000u64),
        ("1 s", 1_000_000),
        ("10 s", 10_000_000),
        ("never", u64::MAX),
    ] {
        for indexed in [true, false] {
            match rewrite(&contents, every_us, indexed) {
                Ok(file) => {
                    let index = index_bytes(&file);
                    println!(
                        "{label:>11}  {:<7} {:>11}  {:>11}  {:>10.1} %",
                        if indexed { "yes" } else { "no" },
                        file.len(),
                        index,
                        100.0 * index as f64 / file.len() as f64
                    );
                }
                Err(e) => eprintln!("chunking: {e}"),
            }
        }
    }
}

fn rewrite(
    contents: &heli_log::LogContents,
    every_us: u64,
    indexed: bool,
) -> Result<Vec<u8>, mcap::McapError> {
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .chunk_size(None)
        .emit_message_indexes(indexed)
        .emit_chunk_indexes(indexed)
        .create(Cursor::new(Vec::new()))?;
    let mut channels: BTreeMap<String, u16> = BTreeMap::new();
    let mut chunk_start: Option<u64> = None;
    for m in &contents.messages {
        let id = match channels.get(&m.topic) {
            Some(id) => *id,
            None => {
                let schema = heli_log::schema::for_topic(&m.topic);
                let text = serde_json::to_vec(&schema.json).unwrap_or_default();
                let schema_id = w.add_schema(&schema.name, "jsonschema", &text)?;
                let id = w.add_channel(schema_id, &m.topic, "json", &BTreeMap::new())?;
                channels.insert(m.topic.clone(), id);
                id
            }
        };
        let data = serde_json::to_vec(&m.value).unwrap_or_default();
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.t_us * 1000,
            publish_time: m.t_us * 1000,
        };
        w.write_to_known_channel(&header, &data)?;
        let start = *chunk_start.get_or_insert(m.t_us);
        if m.t_us.saturating_sub(start) >= every_us {
            w.flush()?;
            chunk_start = None;
        }
    }
    w.finish()?;
    Ok(w.into_inner().into_inner())
}

/// Bytes of MessageIndex and ChunkIndex records (walking the top-level records).
fn index_bytes(file: &[u8]) -> u64 {
    let mut at = 8;
    let mut total = 0;
    while at + 9 <= file.len() {
        let opcode = file[at];
        let len = u64::from_le_bytes(file[at + 1..at + 9].try_into().unwrap_or_default());
        if opcode == 0x07 || opcode == 0x08 {
            total += 9 + len;
        }
        if opcode == 0x02 {
            break;
        }
        at += 9 + len as usize;
    }
    total
}
