//! MAVLink 2 message signing (<https://mavlink.io/en/guide/message_signing.html>): a 32-byte
//! secret key shared by the vehicle and the ground; every signed frame carries a link id, a
//! 48-bit timestamp (10 µs since 2015-01-01) and the first 48 bits of
//! SHA-256(key + header + payload + CRC + link id + timestamp). A receiver with a key refuses
//! unsigned frames, frames whose signature is wrong, and frames whose timestamp is not newer
//! than the last one of their stream (system, component, link) — a replay — or, for a stream
//! it has not heard before, more than a minute older than its own clock. Unlike the
//! specification's receiver, it also refuses frames stamped more than a minute *ahead* of its
//! clock: one sender whose clock is fast would otherwise move every stream's floor into the
//! future and lock out each correctly clocked sender until the receiver restarts. A receiver
//! whose own clock was never set (before [`CLOCK_SET_FLOOR`]: a flight computer without a
//! real-time clock or network time) judges by the newest timestamp it accepted instead.
//!
//! Sans-I/O: the time comes in as an argument; the key file is read and written by the
//! caller ([`Key::from_text`], [`Key::to_text`]).

use std::collections::BTreeMap;
use std::fmt;

use sha2::{Digest, Sha256};

pub use crate::frame::SIGNATURE_LEN;
use crate::frame::{IFLAG_SIGNED, RawFrame};

/// Unix time of the MAVLink epoch, 2015-01-01 00:00:00 UTC (s).
pub const MAVLINK_EPOCH_UNIX_S: u64 = 1_420_070_400;
/// How far a new stream's first timestamp may lag the receiver's clock (10 µs units): one
/// minute, as the MAVLink specification says.
pub const NEW_STREAM_WINDOW: u64 = 6_000_000;
/// A receiver clock earlier than this (signing units: 2025-01-01 00:00:00 UTC) was never set.
pub const CLOCK_SET_FLOOR: u64 = (1_735_689_600 - MAVLINK_EPOCH_UNIX_S) * 100_000;

/// The signing timestamp (10 µs since the MAVLink epoch) of a Unix time in microseconds.
pub fn timestamp_from_unix_us(unix_us: u64) -> u64 {
    unix_us.saturating_sub(MAVLINK_EPOCH_UNIX_S.saturating_mul(1_000_000)) / 10
}

/// A 32-byte secret key.
#[derive(Clone, PartialEq, Eq)]
pub struct Key([u8; 32]);

impl fmt::Debug for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Never print a secret.
        write!(f, "Key(..)")
    }
}

/// Why a key file's text is not a key.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BadKey(pub String);

impl fmt::Display for BadKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (a key file holds 64 hex digits: 32 bytes)", self.0)
    }
}

impl std::error::Error for BadKey {}

impl Key {
    /// A key of these bytes.
    pub fn new(bytes: [u8; 32]) -> Self {
        Self(bytes)
    }

    /// How many different byte values the key has (a random key of 32 bytes has about 30).
    pub fn distinct_bytes(&self) -> usize {
        let mut seen = [0u64; 4];
        for b in self.0 {
            let (word, bit) = (usize::from(b / 64), b % 64);
            if let Some(w) = seen.get_mut(word) {
                *w |= 1 << bit;
            }
        }
        seen.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The key in a key file's text: 64 hex digits; blank lines and lines starting with `#`
    /// are comments.
    pub fn from_text(text: &str) -> Result<Self, BadKey> {
        let hex: String = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .collect();
        if hex.len() != 64 {
            return Err(BadKey(format!("{} hex digits", hex.len())));
        }
        let mut bytes = [0u8; 32];
        for (i, b) in bytes.iter_mut().enumerate() {
            let digits = hex
                .get(i.saturating_mul(2)..i.saturating_mul(2).saturating_add(2))
                .ok_or_else(|| BadKey("not hex".into()))?;
            *b = u8::from_str_radix(digits, 16)
                .map_err(|_| BadKey(format!("'{digits}' is not a hex byte")))?;
        }
        Ok(Self(bytes))
    }

    /// The key file's text.
    pub fn to_text(&self) -> String {
        let hex: String = self.0.iter().map(|b| format!("{b:02x}")).collect();
        format!(
            "# heli MAVLink 2 signing key: keep it secret, give it to the vehicle and the ground\n{hex}\n"
        )
    }

    /// HMAC-SHA256 of `message` under this key (RFC 2104): what signs a lab's attestation
    /// (`heli certify`), so that the key never leaves this type.
    pub fn hmac_sha256(&self, message: &[u8]) -> [u8; 32] {
        const BLOCK: usize = 64;
        let mut inner_pad = [0x36u8; BLOCK];
        let mut outer_pad = [0x5cu8; BLOCK];
        for (i, k) in self.0.iter().enumerate() {
            if let (Some(a), Some(b)) = (inner_pad.get_mut(i), outer_pad.get_mut(i)) {
                *a ^= k;
                *b ^= k;
            }
        }
        let inner = Sha256::new()
            .chain_update(inner_pad)
            .chain_update(message)
            .finalize();
        let outer = Sha256::new()
            .chain_update(outer_pad)
            .chain_update(inner)
            .finalize();
        let mut out = [0u8; 32];
        out.copy_from_slice(&outer);
        out
    }

    /// The 48-bit signature of `signed_part` (a frame up to and including its timestamp).
    fn signature(&self, signed_part: &[u8]) -> [u8; 6] {
        let mut hash = Sha256::new();
        hash.update(self.0);
        hash.update(signed_part);
        let digest = hash.finalize();
        let mut out = [0u8; 6];
        for (o, d) in out.iter_mut().zip(digest.iter()) {
            *o = *d;
        }
        out
    }
}

/// Signs outgoing frames with a key, on one link id, with timestamps that always increase.
#[derive(Clone, Debug)]
pub struct Signer {
    key: Key,
    link_id: u8,
    last: u64,
}

impl Signer {
    /// A signer for `link_id`.
    pub fn new(key: Key, link_id: u8) -> Self {
        Self {
            key,
            link_id,
            last: 0,
        }
    }

    /// Appends the signature to `frame` (its bytes up to the CRC, with the signed flag set
    /// before the CRC was computed), at `timestamp` or just after the last one.
    pub fn sign(&mut self, frame: &mut Vec<u8>, timestamp: u64) {
        let ts = timestamp.max(self.last.saturating_add(1)) & 0xFFFF_FFFF_FFFF;
        self.last = ts;
        frame.push(self.link_id);
        frame.extend_from_slice(ts.to_le_bytes().get(..6).unwrap_or(&[0; 6]));
        let signature = self.key.signature(frame);
        frame.extend_from_slice(&signature);
    }
}

/// Why a frame was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not signed, and a key is set.
    Unsigned,
    /// The signature is not the key's.
    BadSignature,
    /// Not newer than the last frame of its stream: a replay.
    Replayed,
    /// A new stream's first frame, more than a minute older than the receiver's clock (or
    /// a command older than the vehicle's age limit).
    Stale,
    /// Stamped more than a minute ahead of the receiver's clock.
    Future,
}

impl Refusal {
    /// Short words for messages.
    pub fn text(self) -> &'static str {
        match self {
            Refusal::Unsigned => "unsigned",
            Refusal::BadSignature => "wrongly signed",
            Refusal::Replayed => "replayed",
            Refusal::Stale => "signed too long ago",
            Refusal::Future => "stamped in the future",
        }
    }

    /// Whether the frame was signed with the key (refused for its timestamp only): its sender
    /// holds the key, and may be told why.
    pub fn keyed(self) -> bool {
        matches!(self, Refusal::Replayed | Refusal::Stale | Refusal::Future)
    }

    /// What the sender can do about it: the refusal's likely cause in the sender's words.
    pub fn cause(self) -> &'static str {
        match self {
            Refusal::Unsigned => "this vehicle takes only signed frames: give the ground its key",
            Refusal::BadSignature => "not signed with this vehicle's key",
            Refusal::Replayed => {
                "not newer than the last frame of its stream: another ground signs on the same link id, or this ground's clock went back"
            }
            Refusal::Stale => {
                "stamped too long before the vehicle's clock: the ground's clock is slow, or the frame was held back"
            }
            Refusal::Future => {
                "stamped more than a minute after the vehicle's clock: the ground's clock is fast, or the vehicle's is slow"
            }
        }
    }
}

/// Frames refused, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefusalCounts {
    /// Unsigned.
    pub unsigned: u64,
    /// Wrong signature.
    pub bad_signature: u64,
    /// Replayed.
    pub replayed: u64,
    /// Too old for a new stream, or a command too old to obey.
    pub stale: u64,
    /// Stamped ahead of the receiver's clock.
    pub future: u64,
}

impl RefusalCounts {
    /// All refusals.
    pub fn total(&self) -> u64 {
        self.unsigned
            .saturating_add(self.bad_signature)
            .saturating_add(self.replayed)
            .saturating_add(self.stale)
            .saturating_add(self.future)
    }

    /// Counts one refusal.
    pub fn count(&mut self, r: Refusal) {
        let c = match r {
            Refusal::Unsigned => &mut self.unsigned,
            Refusal::BadSignature => &mut self.bad_signature,
            Refusal::Replayed => &mut self.replayed,
            Refusal::Stale => &mut self.stale,
            Refusal::Future => &mut self.future,
        };
        *c = c.saturating_add(1);
    }
}

/// Checks incoming frames against a key (or accepts everything without one).
#[derive(Clone, Debug, Default)]
pub struct Verifier {
    key: Option<Key>,
    streams: BTreeMap<(u8, u8, u8), u64>,
    clock: u64,
    /// What was refused.
    pub refused: RefusalCounts,
}

impl Verifier {
    /// A verifier with `key`, or one that accepts unsigned frames when `None`.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            ..Self::default()
        }
    }

    /// Whether a key is set.
    pub fn has_key(&self) -> bool {
        self.key.is_some()
    }

    /// The receiver's clock at `now` (signing units): `now` when it was set, else the newest
    /// timestamp accepted (0 before any).
    pub fn clock(&self, now: u64) -> u64 {
        if now >= CLOCK_SET_FLOOR {
            now
        } else {
            self.clock
        }
    }

    /// Checks `frame` at the receiver's `now` (signing timestamp units); counts a refusal.
    /// Gives the frame's signed timestamp (`None` for an unsigned frame taken without a key).
    pub fn check(&mut self, frame: &RawFrame, now: u64) -> Result<Option<u64>, Refusal> {
        let result = self.verdict(frame, now);
        if let Err(r) = result {
            self.refused.count(r);
        }
        result
    }

    fn verdict(&mut self, frame: &RawFrame, now: u64) -> Result<Option<u64>, Refusal> {
        let Some(key) = &self.key else {
            return Ok(None);
        };
        let flags = frame.bytes.get(2).copied().unwrap_or(0);
        if flags & IFLAG_SIGNED == 0 || frame.bytes.len() < SIGNATURE_LEN {
            return Err(Refusal::Unsigned);
        }
        let split = frame.bytes.len().saturating_sub(6);
        let (signed_part, signature) = frame.bytes.split_at(split);
        if key.signature(signed_part) != signature {
            return Err(Refusal::BadSignature);
        }
        let tail = signed_part
            .get(signed_part.len().saturating_sub(7)..)
            .unwrap_or(&[]);
        let link_id = tail.first().copied().unwrap_or(0);
        let mut ts_bytes = [0u8; 8];
        for (t, b) in ts_bytes.iter_mut().zip(tail.iter().skip(1)) {
            *t = *b;
        }
        let ts = u64::from_le_bytes(ts_bytes);
        let stream = (frame.sender.system, frame.sender.component, link_id);
        let clock = self.clock(now);
        // A frame from the future would raise its stream's floor beyond every correctly
        // clocked frame; with a clock never set, the first frame heard sets it.
        if clock > 0 && ts > clock.saturating_add(NEW_STREAM_WINDOW) {
            return Err(Refusal::Future);
        }
        match self.streams.get(&stream) {
            Some(&last) if ts <= last => return Err(Refusal::Replayed),
            None if ts.saturating_add(NEW_STREAM_WINDOW) < clock => return Err(Refusal::Stale),
            _ => {}
        }
        self.streams.insert(stream, ts);
        self.clock = self.clock.max(ts);
        Ok(Some(ts))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Sender, split};
    use crate::outgoing::encode;
    use mavlink::dialects::common::*;

    /// 2026-11-27, a set clock.
    const NOW: u64 = 37_242_000_000_000;

    fn stop() -> MavMessage {
        MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            target_system: 1,
            target_component: 1,
            command: MavCmd::MAV_CMD_USER_3,
            ..Default::default()
        })
    }

    fn frame_of(bytes: &[u8]) -> RawFrame {
        split(bytes)[0].clone().unwrap()
    }

    const GROUND: Sender = Sender {
        system: 255,
        component: 190,
    };

    #[test]
    fn a_key_file_round_trips_and_bad_ones_say_why() {
        let key = Key::new([7; 32]);
        assert_eq!(Key::from_text(&key.to_text()), Ok(key));
        assert!(
            Key::from_text("abc")
                .unwrap_err()
                .to_string()
                .contains("3 hex digits")
        );
        assert!(Key::from_text(&"zz".repeat(32)).is_err());
        assert_eq!(format!("{:?}", Key::new([1; 32])), "Key(..)");
    }

    #[test]
    fn our_signature_is_the_mavlink_crates() {
        let key = [42u8; 32];
        let mut signer = Signer::new(Key::new(key), 3);
        let ours = encode(GROUND, 5, &stop(), Some((&mut signer, NOW)));
        // The crate signs with its own clock: compare the signature it computes over our
        // frame's bytes.
        let mut raw = mavlink::MAVLinkV2MessageRaw::new();
        raw.as_mut_slice()[..ours.len()].copy_from_slice(&ours);
        let mut sig = [0u8; 6];
        raw.calculate_signature(&key, &mut sig);
        assert_eq!(&ours[ours.len() - 6..], &sig);
    }

    #[test]
    fn signed_frames_pass_and_the_rest_are_refused_and_counted() {
        let key = Key::new([9; 32]);
        let mut verifier = Verifier::new(Some(key.clone()));
        let mut signer = Signer::new(key, 0);
        let good = encode(GROUND, 1, &stop(), Some((&mut signer, NOW)));
        assert!(verifier.check(&frame_of(&good), NOW).is_ok());
        // The same frame again: a replay.
        assert_eq!(
            verifier.check(&frame_of(&good), NOW),
            Err(Refusal::Replayed)
        );
        let unsigned = encode(GROUND, 2, &stop(), None);
        assert_eq!(
            verifier.check(&frame_of(&unsigned), NOW),
            Err(Refusal::Unsigned)
        );
        let mut other = Signer::new(Key::new([8; 32]), 0);
        let wrong = encode(GROUND, 3, &stop(), Some((&mut other, NOW + 10)));
        assert_eq!(
            verifier.check(&frame_of(&wrong), NOW),
            Err(Refusal::BadSignature)
        );
        let mut old = Signer::new(Key::new([9; 32]), 4);
        let stale = encode(
            GROUND,
            4,
            &stop(),
            Some((&mut old, NOW - 2 * NEW_STREAM_WINDOW)),
        );
        assert_eq!(verifier.check(&frame_of(&stale), NOW), Err(Refusal::Stale));
        let next = encode(GROUND, 5, &stop(), Some((&mut signer, NOW)));
        assert!(verifier.check(&frame_of(&next), NOW).is_ok());
        assert_eq!(
            verifier.refused,
            RefusalCounts {
                unsigned: 1,
                bad_signature: 1,
                replayed: 1,
                stale: 1,
                future: 0
            }
        );
    }

    #[test]
    fn a_tampered_payload_fails_its_signature() {
        let key = Key::new([9; 32]);
        let mut signer = Signer::new(key.clone(), 0);
        let mut bytes = encode(GROUND, 1, &stop(), Some((&mut signer, NOW)));
        // Change a byte of the payload and mend the CRC: only the signature can tell.
        let body = crate::frame::HEADER_LEN + usize::from(bytes[1]);
        bytes[crate::frame::HEADER_LEN] ^= 1;
        let crc = crate::frame::checksum(&bytes[1..body], 76);
        bytes[body..body + 2].copy_from_slice(&crc.to_le_bytes());
        let frame = frame_of(&bytes);
        let mut verifier = Verifier::new(Some(key));
        assert_eq!(verifier.check(&frame, NOW), Err(Refusal::BadSignature));
    }

    #[test]
    fn without_a_key_everything_is_accepted() {
        let mut verifier = Verifier::new(None);
        let unsigned = encode(GROUND, 2, &stop(), None);
        assert_eq!(verifier.check(&frame_of(&unsigned), NOW), Ok(None));
        assert!(!verifier.has_key());
    }

    #[test]
    fn timestamps_count_from_2015() {
        assert_eq!(
            timestamp_from_unix_us(MAVLINK_EPOCH_UNIX_S * 1_000_000 + 20),
            2
        );
        assert_eq!(timestamp_from_unix_us(0), 0);
    }

    #[test]
    fn a_frame_from_the_future_is_refused_and_a_correct_clock_still_commands() {
        let key = Key::new([9; 32]);
        let mut verifier = Verifier::new(Some(key.clone()));
        // A ground whose clock is an hour fast, on the stream a correct ground also uses.
        let mut fast = Signer::new(key.clone(), 1);
        let hour = 360_000_000;
        let ahead = encode(GROUND, 1, &stop(), Some((&mut fast, NOW + hour)));
        assert_eq!(verifier.check(&frame_of(&ahead), NOW), Err(Refusal::Future));
        assert_eq!(verifier.refused.future, 1);
        let mut correct = Signer::new(key, 1);
        let good = encode(GROUND, 2, &stop(), Some((&mut correct, NOW)));
        assert!(verifier.check(&frame_of(&good), NOW).is_ok());
        // Up to the window ahead is a clock's ordinary disagreement.
        let slightly = encode(
            GROUND,
            3,
            &stop(),
            Some((&mut correct, NOW + NEW_STREAM_WINDOW)),
        );
        assert!(verifier.check(&frame_of(&slightly), NOW).is_ok());
        assert!(Refusal::Future.cause().contains("clock is fast"));
    }

    #[test]
    fn a_receiver_whose_clock_was_never_set_learns_it_from_the_first_frame() {
        let key = Key::new([9; 32]);
        let mut verifier = Verifier::new(Some(key.clone()));
        // A flight computer booted without a real-time clock: 1970.
        let unset = 0;
        assert_eq!(verifier.clock(unset), 0);
        let mut ground = Signer::new(key.clone(), 1);
        let first = encode(GROUND, 1, &stop(), Some((&mut ground, NOW)));
        assert!(verifier.check(&frame_of(&first), unset).is_ok());
        assert_eq!(verifier.clock(unset), NOW);
        assert_eq!(verifier.clock(CLOCK_SET_FLOOR), CLOCK_SET_FLOOR);
        // Now judged by the learned clock: a year ahead of it is refused.
        let mut fast = Signer::new(key, 2);
        let year = 365 * 24 * 360_000_000;
        let ahead = encode(GROUND, 2, &stop(), Some((&mut fast, NOW + year)));
        assert_eq!(
            verifier.check(&frame_of(&ahead), unset),
            Err(Refusal::Future)
        );
    }
}
