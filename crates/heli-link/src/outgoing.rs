//! Frames going out: a message encoded as a MAVLink 2 frame from a sender, in its sequence,
//! signed when a key is set. Both ends of the link send through an [`Outgoing`].

use mavlink::dialects::common::MavMessage;
use mavlink::{MavlinkVersion, Message};

use crate::frame::{
    CRC_LEN, HEADER_LEN, IFLAG_SIGNED, MAX_PAYLOAD, SIGNATURE_LEN, STX_V2, Sender, checksum,
};
use crate::signing::Signer;

/// Encodes `message` from `sender` with `sequence`, signed by `signer` at `timestamp` (10 µs
/// since the MAVLink epoch) when one is given.
pub fn encode(
    sender: Sender,
    sequence: u8,
    message: &MavMessage,
    signer: Option<(&mut Signer, u64)>,
) -> Vec<u8> {
    let mut payload = [0u8; MAX_PAYLOAD];
    let written = message
        .ser(MavlinkVersion::V2, &mut payload)
        .min(MAX_PAYLOAD);
    // MAVLink 2 cuts the payload's trailing zeros, but never its first byte.
    let mut len = written;
    while len > 1 && payload.get(len.saturating_sub(1)) == Some(&0) {
        len = len.saturating_sub(1);
    }
    let id = message.message_id();
    let [id0, id1, id2, _] = id.to_le_bytes();
    let flags = if signer.is_some() { IFLAG_SIGNED } else { 0 };
    let mut bytes = Vec::with_capacity(HEADER_LEN + MAX_PAYLOAD + CRC_LEN + SIGNATURE_LEN);
    bytes.extend_from_slice(&[
        STX_V2,
        len as u8,
        flags,
        0,
        sequence,
        sender.system,
        sender.component,
        id0,
        id1,
        id2,
    ]);
    bytes.extend_from_slice(payload.get(..len).unwrap_or(&[]));
    let crc = checksum(bytes.get(1..).unwrap_or(&[]), id);
    bytes.extend_from_slice(&crc.to_le_bytes());
    if let Some((signer, timestamp)) = signer {
        signer.sign(&mut bytes, timestamp);
    }
    bytes
}

/// One sender's outgoing frames: its ids, its sequence number, and its signer when a key is
/// set. Both ends of the link send through one.
#[derive(Clone, Debug)]
pub struct Outgoing {
    from: Sender,
    sequence: u8,
    signer: Option<Signer>,
}

impl Outgoing {
    /// Frames from `from`, signed by `signer` when one is given.
    pub fn new(from: Sender, signer: Option<Signer>) -> Self {
        Self {
            from,
            sequence: 0,
            signer,
        }
    }

    /// The bytes of `message`, next in the sequence, signed at `now_us` (Unix µs) if a key is
    /// set.
    pub fn encode(&mut self, message: &MavMessage, now_us: u64) -> Vec<u8> {
        let ts = crate::signing::timestamp_from_unix_us(now_us);
        let bytes = encode(
            self.from,
            self.sequence,
            message,
            self.signer.as_mut().map(|s| (s, ts)),
        );
        self.sequence = self.sequence.wrapping_add(1);
        bytes
    }
}
