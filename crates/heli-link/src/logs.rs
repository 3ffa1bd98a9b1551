//! The log protocol on the vehicle's side (`LOG_REQUEST_LIST` → `LOG_ENTRY`,
//! `LOG_REQUEST_DATA` → `LOG_DATA`, `LOG_REQUEST_END`), as ArduPilot serves it: the flight
//! logs are numbered from 1 in the order of their names; a data request streams 90-byte
//! `LOG_DATA` packets from an offset, paced by [`LogServer::next_packets`]; the ground asks
//! again for what it did not receive (a lost packet costs only itself). The files are read
//! through [`LogStore`], so this side has no file I/O of its own. What the store cannot do —
//! a directory it cannot list, a log it cannot read — comes back as text for the vehicle to
//! say to the ground (a `STATUSTEXT`), since the log protocol has no word for it: a log that
//! cannot be read (a read that fails, an id the vehicle does not have) is said once, with its
//! cause, however often the ground asks again, until a read of it works again; a failing log
//! after another is said anew.

use heli_types::Spell;
use mavlink::dialects::common::*;

/// Bytes of log per `LOG_DATA` packet.
pub const LOG_DATA_LEN: usize = 90;

/// One log the vehicle holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogInfo {
    /// Id on the link (from 1).
    pub id: u16,
    /// File name.
    pub name: String,
    /// Size (bytes).
    pub size: u32,
    /// Last change, Unix time (s).
    pub time_utc: u32,
}

/// The logs a store holds, and what it could not look at.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Listing {
    /// The logs, by id.
    pub logs: Vec<LogInfo>,
    /// What could not be listed (a directory or a file the store could not read), each
    /// with where and why: the logs there are missing from `logs`.
    pub problems: Vec<String>,
}

/// Where the logs are.
pub trait LogStore {
    /// The logs, by id, and what could not be listed.
    fn list(&self) -> Listing;
    /// Reads up to `buf.len()` bytes of the log named `name` (as [`LogStore::list`] gave it)
    /// from `ofs`: the count read (0 at the end), or why it could not be read (where and
    /// what the system said; a log that is gone). By name, so that a new log appearing
    /// during a transfer cannot change which file is read.
    fn read(&self, name: &str, ofs: u32, buf: &mut [u8]) -> Result<usize, String>;
}

/// The log a status text of the vehicle says it cannot serve (a read that fails, an id it
/// does not have, a file cut since it was listed), if the text is one of those
/// [`LogServer`] says: for the ground to stop waiting for that log.
pub fn unservable(text: &str) -> Option<u16> {
    let rest = text.strip_prefix("log ")?;
    let (id, rest) = rest.split_once([' ', ':'])?;
    let id = id.parse().ok()?;
    [
        " cannot be read at byte ",
        " no such log ",
        ", before its listed size ",
    ]
    .iter()
    .any(|words| rest.contains(words))
    .then_some(id)
}

/// A data request being served.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Transfer {
    id: u16,
    name: String,
    next: u32,
    end: u32,
    size: u32,
}

/// The vehicle's log server.
#[derive(Clone, Debug, Default)]
pub struct LogServer {
    transfer: Option<Transfer>,
    /// Packets sent.
    pub packets_sent: u64,
    /// The reads that fail.
    failing: Failing,
}

/// The reads of the store that fail: the log failing now and its spell, and a count of
/// every failure.
#[derive(Clone, Debug, Default)]
struct Failing {
    log: Option<(u16, Spell)>,
    total: u64,
}

impl Failing {
    /// A read of log `id` failed: true when it is the first of a spell (to say) — the
    /// first failure, or the first of another log than the one failing so far.
    fn failed(&mut self, id: u16) -> bool {
        self.total = self.total.saturating_add(1);
        match &mut self.log {
            Some((failing, spell)) if *failing == id => spell.failed(),
            _ => {
                let mut spell = Spell::default();
                let first = spell.failed();
                self.log = Some((id, spell));
                first
            }
        }
    }

    /// A read of log `id` worked: the failures of its spell, if it ends one (to say).
    fn worked(&mut self, id: u16) -> Option<u64> {
        match self.log.take() {
            Some((failing, mut spell)) if failing == id => spell.worked(),
            other => {
                self.log = other;
                None
            }
        }
    }
}

impl LogServer {
    /// The `LOG_ENTRY` answers to a list request for ids `start..=end` (0xFFFF: the last),
    /// of the store's `logs`.
    pub fn entries(logs: &[LogInfo], start: u16, end: u16) -> Vec<MavMessage> {
        let num_logs = u16::try_from(logs.len()).unwrap_or(u16::MAX);
        let last = logs.iter().map(|l| l.id).max().unwrap_or(0);
        if logs.is_empty() {
            // "No logs" is an entry with num_logs 0, so the ground is not left waiting.
            return vec![MavMessage::LOG_ENTRY(LOG_ENTRY_DATA::default())];
        }
        logs.iter()
            .filter(|l| l.id >= start && l.id <= end.min(last))
            .map(|l| {
                MavMessage::LOG_ENTRY(LOG_ENTRY_DATA {
                    time_utc: l.time_utc,
                    size: l.size,
                    id: l.id,
                    num_logs,
                    last_log_num: last,
                })
            })
            .collect()
    }

    /// Starts serving `count` bytes of log `id` of the store's `logs` from `ofs` (a later
    /// request replaces it). A log that is not there is served as an empty one, and said.
    pub fn request(&mut self, logs: &[LogInfo], id: u16, ofs: u32, count: u32) -> Option<String> {
        let found = logs.iter().find(|l| l.id == id);
        let said = if found.is_none() && self.failing.failed(id) {
            Some(format!(
                "log {id}: no such log (the vehicle has {})",
                logs.len()
            ))
        } else {
            None
        };
        let (name, size) = found.map_or((String::new(), 0), |l| (l.name.clone(), l.size));
        let end = ofs.saturating_add(count).min(size);
        self.transfer = Some(Transfer {
            id,
            name,
            next: ofs.min(end),
            end,
            size,
        });
        said
    }

    /// Stops the transfer under way.
    pub fn end(&mut self) {
        self.transfer = None;
    }

    /// Whether a transfer is under way.
    pub fn busy(&self) -> bool {
        self.transfer.is_some()
    }

    /// Up to `max` packets of the transfer under way. The end of the file is told by a short
    /// packet (an empty one when the file ends on a packet boundary), as ArduPilot does; a
    /// request that ends before the end of the file simply stops. A read that fails, or a
    /// file that ends before the size it was listed with, ends the transfer without a packet
    /// (the ground asks again for what it lacks) and gives what to say, for the first failure
    /// of a spell and the first read that works after it.
    pub fn next_packets(
        &mut self,
        store: &dyn LogStore,
        max: usize,
    ) -> (Vec<MavMessage>, Option<String>) {
        let mut out = Vec::new();
        let mut said = None;
        while out.len() < max {
            let Some(t) = self.transfer.as_mut() else {
                break;
            };
            let mut data = [0u8; LOG_DATA_LEN];
            let want = usize::try_from(t.end.saturating_sub(t.next))
                .unwrap_or(LOG_DATA_LEN)
                .min(LOG_DATA_LEN);
            let got = if want == 0 {
                0
            } else {
                // A read that fails, or a file that ends before the size it was listed with
                // (cut since): what is missing cannot be sent; said, not sent as an end.
                let read = store
                    .read(&t.name, t.next, data.get_mut(..want).unwrap_or(&mut []))
                    .map_err(|e| format!("cannot be read at byte {}: {e}", t.next))
                    .and_then(|n| {
                        let end = t.next.saturating_add(u32::try_from(n).unwrap_or(0));
                        if n < want && end < t.size {
                            Err(format!(
                                "ends at byte {end}, before its listed size {}: it was cut \
                                 after it was listed",
                                t.size
                            ))
                        } else {
                            Ok(n)
                        }
                    });
                match read {
                    Ok(n) => {
                        if let Some(n) = self.failing.worked(t.id) {
                            said = Some(format!("log {}: read again, after {n} failed", t.id));
                        }
                        n
                    }
                    Err(why) => {
                        if self.failing.failed(t.id) {
                            said = Some(format!("log {} ({}) {why}", t.id, t.name));
                        }
                        self.transfer = None;
                        break;
                    }
                }
            };
            let at_eof = t.next.saturating_add(u32::try_from(got).unwrap_or(0)) >= t.size;
            if got > 0 || at_eof {
                out.push(MavMessage::LOG_DATA(LOG_DATA_DATA {
                    ofs: t.next,
                    id: t.id,
                    count: u8::try_from(got).unwrap_or(0),
                    data,
                }));
                self.packets_sent = self.packets_sent.saturating_add(1);
            }
            t.next = t.next.saturating_add(u32::try_from(got).unwrap_or(0));
            if got < want || t.next >= t.end {
                if got == LOG_DATA_LEN && t.next >= t.size {
                    // The file ended exactly on a packet boundary: say so with an empty packet.
                    out.push(MavMessage::LOG_DATA(LOG_DATA_DATA {
                        ofs: t.next,
                        id: t.id,
                        count: 0,
                        data: [0; LOG_DATA_LEN],
                    }));
                }
                self.transfer = None;
            }
        }
        (out, said)
    }

    /// Reads of the store that failed (every log, every request).
    pub fn read_failures(&self) -> u64 {
        self.failing.total
    }
}

/// A store of logs in memory (tests, and the ground's own checks).
#[derive(Clone, Debug, Default)]
pub struct MemoryStore {
    /// Name and bytes of each log, id = index + 1.
    pub logs: Vec<(String, Vec<u8>)>,
}

impl LogStore for MemoryStore {
    fn list(&self) -> Listing {
        let logs = self
            .logs
            .iter()
            .enumerate()
            .map(|(i, (name, bytes))| LogInfo {
                id: u16::try_from(i.saturating_add(1)).unwrap_or(u16::MAX),
                name: name.clone(),
                size: u32::try_from(bytes.len()).unwrap_or(u32::MAX),
                time_utc: 0,
            })
            .collect();
        Listing {
            logs,
            problems: Vec::new(),
        }
    }

    fn read(&self, name: &str, ofs: u32, buf: &mut [u8]) -> Result<usize, String> {
        let Some((_, bytes)) = self.logs.iter().find(|(n, _)| n == name) else {
            return Err(format!("no log named {name}"));
        };
        let from = usize::try_from(ofs).unwrap_or(usize::MAX).min(bytes.len());
        let rest = bytes.get(from..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), rest.get(..n)) {
            dst.copy_from_slice(src);
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store() -> MemoryStore {
        MemoryStore {
            logs: vec![
                ("a.mcap".into(), (0..=255u8).cycle().take(1000).collect()),
                ("b.mcap".into(), vec![7; 180]),
            ],
        }
    }

    #[test]
    fn the_list_names_every_log_and_an_empty_store_says_so() {
        let entries = LogServer::entries(&store().list().logs, 0, 0xFFFF);
        assert_eq!(entries.len(), 2);
        let MavMessage::LOG_ENTRY(e) = &entries[1] else {
            panic!()
        };
        assert_eq!((e.id, e.size, e.num_logs, e.last_log_num), (2, 180, 2, 2));
        let none = LogServer::entries(&MemoryStore::default().list().logs, 0, 0xFFFF);
        let MavMessage::LOG_ENTRY(e) = &none[0] else {
            panic!()
        };
        assert_eq!(e.num_logs, 0);
    }

    fn fetch(server: &mut LogServer, s: &MemoryStore) -> Vec<u8> {
        let mut bytes = Vec::new();
        while server.busy() {
            for p in server.next_packets(s, 7).0 {
                let MavMessage::LOG_DATA(d) = p else { panic!() };
                assert_eq!(d.ofs as usize, bytes.len());
                bytes.extend_from_slice(&d.data[..usize::from(d.count)]);
            }
        }
        bytes
    }

    #[test]
    fn a_whole_log_is_served_in_order_and_ends_short() {
        let s = store();
        let mut server = LogServer::default();
        server.request(&s.list().logs, 1, 0, u32::MAX);
        assert_eq!(fetch(&mut server, &s), s.logs[0].1);
        // 180 bytes end on a packet boundary: an empty packet ends the request.
        server.request(&s.list().logs, 2, 0, u32::MAX);
        assert_eq!(fetch(&mut server, &s), s.logs[1].1);
    }

    #[test]
    fn a_gap_is_served_again_from_its_offset() {
        let s = store();
        let mut server = LogServer::default();
        server.request(&s.list().logs, 1, 450, 100);
        let MavMessage::LOG_DATA(first) = &server.next_packets(&s, 1).0[0] else {
            panic!()
        };
        assert_eq!((first.ofs, first.count), (450, 90));
        assert_eq!(first.data[0], s.logs[0].1[450]);
        let rest = server.next_packets(&s, 10).0;
        let MavMessage::LOG_DATA(last) = rest.last().unwrap() else {
            panic!()
        };
        assert_eq!((last.ofs, last.count), (540, 10));
        assert!(!server.busy());
    }

    #[test]
    fn an_unknown_log_ends_at_once() {
        let s = store();
        let mut server = LogServer::default();
        let said = server.request(&s.list().logs, 9, 0, 100);
        assert_eq!(
            said.as_deref(),
            Some("log 9: no such log (the vehicle has 2)")
        );
        let (packets, said) = server.next_packets(&s, 10);
        assert_eq!(packets.len(), 1);
        assert_eq!(said, None);
        assert!(!server.busy());
        // The ground asks again at once (an empty packet ends its request): said once.
        for _ in 0..50 {
            assert_eq!(server.request(&s.list().logs, 9, 0, 100), None);
            server.next_packets(&s, 10);
        }
        // Another log that is not there is said anew.
        assert!(server.request(&s.list().logs, 8, 0, 100).is_some());
        assert_eq!(server.read_failures(), 52);
    }

    /// A store whose reads fail while `failing` is set.
    struct Flaky {
        inner: MemoryStore,
        failing: std::cell::Cell<bool>,
    }

    impl LogStore for Flaky {
        fn list(&self) -> Listing {
            self.inner.list()
        }
        fn read(&self, name: &str, ofs: u32, buf: &mut [u8]) -> Result<usize, String> {
            if self.failing.get() {
                return Err("/var/heli/a.mcap: Input/output error (os error 5)".into());
            }
            self.inner.read(name, ofs, buf)
        }
    }

    #[test]
    fn the_texts_of_a_log_that_cannot_be_served_name_it_and_no_other_does() {
        let s = Flaky {
            inner: store(),
            failing: std::cell::Cell::new(true),
        };
        let logs = s.list().logs;
        let mut server = LogServer::default();
        let unknown = server.request(&logs, 9, 0, 10).unwrap();
        assert_eq!(unservable(&unknown), Some(9));
        server.request(&logs, 2, 0, 10);
        let failed = server.next_packets(&s, 1).1.unwrap();
        assert_eq!(unservable(&failed), Some(2));
        s.failing.set(false);
        server.request(&logs, 2, 0, 10);
        let again = server.next_packets(&s, 1).1.unwrap();
        assert_eq!(unservable(&again), None, "{again}");
        let mut cut = store();
        cut.logs[0].1.truncate(10);
        server.request(&logs, 1, 0, 100);
        let ended = server.next_packets(&cut, 1).1.unwrap();
        assert_eq!(unservable(&ended), Some(1), "{ended}");
        for other in [
            "log saved",
            "log list: /x: denied",
            "log 3 saved",
            "logx 3: no such log (y)",
        ] {
            assert_eq!(unservable(other), None, "{other}");
        }
    }

    #[test]
    fn a_log_cut_after_it_was_listed_is_said_not_sent_as_its_end() {
        let mut s = store();
        let logs = s.list().logs;
        s.logs[0].1.truncate(500);
        let mut server = LogServer::default();
        server.request(&logs, 1, 450, u32::MAX);
        let (packets, said) = server.next_packets(&s, 10);
        assert!(packets.is_empty(), "{packets:?}");
        assert_eq!(
            said.as_deref(),
            Some(
                "log 1 (a.mcap) ends at byte 500, before its listed size 1000: it was cut after it was listed"
            )
        );
        assert!(!server.busy());
        // Listed again, it is served whole to its new end.
        let logs = s.list().logs;
        server.request(&logs, 1, 450, u32::MAX);
        let (packets, said) = server.next_packets(&s, 10);
        assert_eq!(packets.len(), 1);
        assert_eq!(said.as_deref(), Some("log 1: read again, after 1 failed"));
    }

    #[test]
    fn a_read_that_fails_ends_the_transfer_and_is_said_once_a_spell() {
        let s = Flaky {
            inner: store(),
            failing: std::cell::Cell::new(false),
        };
        let logs = s.list().logs;
        let mut server = LogServer::default();
        assert_eq!(server.request(&logs, 1, 0, u32::MAX), None);
        let (first, said) = server.next_packets(&s, 2);
        assert_eq!((first.len(), said), (2, None));
        s.failing.set(true);
        let (packets, said) = server.next_packets(&s, 5);
        assert!(packets.is_empty(), "no packet for what was not read");
        assert_eq!(
            said.as_deref(),
            Some(
                "log 1 (a.mcap) cannot be read at byte 180: /var/heli/a.mcap: Input/output error (os error 5)"
            )
        );
        assert!(
            !server.busy(),
            "the transfer is over: the ground asks again"
        );
        // The ground asks again; the read fails again: counted, not said again.
        server.request(&logs, 1, 180, u32::MAX);
        assert_eq!(server.next_packets(&s, 5), (Vec::new(), None));
        s.failing.set(false);
        server.request(&logs, 1, 180, u32::MAX);
        let (packets, said) = server.next_packets(&s, 1);
        assert_eq!(packets.len(), 1);
        assert_eq!(said.as_deref(), Some("log 1: read again, after 2 failed"));
        let (_, said) = server.next_packets(&s, 1);
        assert_eq!(said, None);
        // Log 1 fails, then log 2: each is said (one log's spell does not hide another's),
        // and a read of log 2 that works says nothing of log 1.
        s.failing.set(true);
        server.request(&logs, 1, 0, u32::MAX);
        assert!(server.next_packets(&s, 1).1.is_some());
        server.request(&logs, 2, 0, u32::MAX);
        let (_, said) = server.next_packets(&s, 1);
        assert!(said.is_some_and(|t| t.starts_with("log 2 (b.mcap) cannot be read")));
        s.failing.set(false);
        server.request(&logs, 2, 0, u32::MAX);
        assert_eq!(
            server.next_packets(&s, 1).1.as_deref(),
            Some("log 2: read again, after 1 failed")
        );
    }
}
