//! MAVLink 2 frames: encoding a message of the common dialect into the bytes of one frame
//! (signed or not), and splitting a datagram back into frames. The payloads are the `mavlink`
//! crate's; the framing is here so that it is sans-I/O and every frame refused is counted
//! with its reason (the crate skips bad frames silently).
//!
//! Frame layout (<https://mavlink.io/en/guide/serialization.html>): `0xFD`, payload length,
//! incompatibility flags (0x01: signed), compatibility flags, sequence, system id, component
//! id, message id (3 bytes, little-endian), payload (trailing zeros cut), CRC-16/MCRF4XX over
//! everything after the start byte plus the message's CRC_EXTRA, then for a signed frame 13
//! bytes: link id, 48-bit timestamp, 48-bit signature.

use std::fmt;

use mavlink::dialects::common::MavMessage;
use mavlink::{MavlinkVersion, Message};

/// First byte of every MAVLink 2 frame.
pub const STX_V2: u8 = 0xFD;
/// Incompatibility flag of a signed frame.
pub const IFLAG_SIGNED: u8 = 0x01;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 10;
/// Bytes of the checksum.
pub const CRC_LEN: usize = 2;
/// Largest payload.
pub const MAX_PAYLOAD: usize = 255;

/// Who sent a frame, and its place in the sender's sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sender {
    /// System id (the vehicle is 1, a ground station usually 255).
    pub system: u8,
    /// Component id (the autopilot is 1, a ground station 190).
    pub component: u8,
}

/// The vehicle's system and component ids.
pub const VEHICLE: Sender = Sender {
    system: 1,
    component: 1,
};

/// The ground's system and component ids (a ground control station's usual ones).
pub const GROUND: Sender = Sender {
    system: 255,
    component: 190,
};

/// Bytes a signature adds to a frame.
pub const SIGNATURE_LEN: usize = 13;

/// One frame of a datagram, checked for length and checksum but not yet for its signature.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawFrame {
    /// The frame's bytes, from the start byte to the end of the signature.
    pub bytes: Vec<u8>,
    /// Sender.
    pub sender: Sender,
    /// Sequence number.
    pub sequence: u8,
    /// Message id.
    pub message_id: u32,
}

/// Why bytes were not a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// Bytes before a start byte, skipped (the count).
    Garbage(usize),
    /// The datagram ended inside a frame.
    Truncated,
    /// A MAVLink 1 frame (`0xFE`): this link speaks MAVLink 2 only.
    Version1,
    /// An incompatibility flag this link does not know.
    UnknownFlags(u8),
    /// A message id not in the common dialect.
    UnknownMessage(u32),
    /// The checksum does not match.
    BadChecksum {
        /// Message id.
        message_id: u32,
    },
    /// The payload does not decode as its message.
    BadPayload {
        /// Message id.
        message_id: u32,
        /// The parser's words.
        why: String,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::Garbage(n) => write!(f, "{n} bytes that are not a MAVLink 2 frame"),
            FrameError::Truncated => write!(f, "a frame cut short by the end of the datagram"),
            FrameError::Version1 => write!(f, "a MAVLink 1 frame (this link speaks MAVLink 2)"),
            FrameError::UnknownFlags(x) => write!(f, "unknown incompatibility flags {x:#04x}"),
            FrameError::UnknownMessage(id) => {
                write!(f, "message id {id} is not in the common dialect")
            }
            FrameError::BadChecksum { message_id } => {
                write!(f, "bad checksum on a frame of message id {message_id}")
            }
            FrameError::BadPayload { message_id, why } => {
                write!(f, "message id {message_id} does not decode: {why}")
            }
        }
    }
}

impl std::error::Error for FrameError {}

impl RawFrame {
    /// Whether the frame carries a signature.
    pub fn is_signed(&self) -> bool {
        self.bytes.get(2).is_some_and(|f| f & IFLAG_SIGNED != 0)
    }

    /// The link id of a signed frame's signature (`None` unsigned).
    pub fn signing_link_id(&self) -> Option<u8> {
        if !self.is_signed() {
            return None;
        }
        let at = self.bytes.len().checked_sub(SIGNATURE_LEN)?;
        self.bytes.get(at).copied()
    }

    /// The message the frame carries.
    pub fn message(&self) -> Result<MavMessage, FrameError> {
        let len = usize::from(self.bytes.get(1).copied().unwrap_or(0));
        let payload = self
            .bytes
            .get(HEADER_LEN..HEADER_LEN.saturating_add(len))
            .ok_or(FrameError::Truncated)?;
        MavMessage::parse(MavlinkVersion::V2, self.message_id, payload).map_err(|e| {
            FrameError::BadPayload {
                message_id: self.message_id,
                why: e.to_string(),
            }
        })
    }
}

/// The CRC-16/MCRF4XX (X.25) accumulation of `bytes` onto `crc`.
fn crc_accumulate(mut crc: u16, bytes: &[u8]) -> u16 {
    for &b in bytes {
        let mut tmp = b ^ (crc & 0xFF) as u8;
        tmp ^= tmp << 4;
        crc = (crc >> 8) ^ (u16::from(tmp) << 8) ^ (u16::from(tmp) << 3) ^ (u16::from(tmp) >> 4);
    }
    crc
}

/// The frame checksum of `header_and_payload` (without the start byte) for `message_id`.
pub(crate) fn checksum(header_and_payload: &[u8], message_id: u32) -> u16 {
    let crc = crc_accumulate(0xFFFF, header_and_payload);
    crc_accumulate(crc, &[MavMessage::extra_crc(message_id)])
}

/// Splits a datagram into frames. Bytes between frames are reported as garbage and skipped;
/// a frame with a bad checksum is reported and the search goes on after its start byte, so
/// one damaged frame costs only itself.
pub fn split(datagram: &[u8]) -> Vec<Result<RawFrame, FrameError>> {
    let mut out = Vec::new();
    let mut at = 0usize;
    while at < datagram.len() {
        let rest = datagram.get(at..).unwrap_or(&[]);
        let Some(start) = rest.iter().position(|&b| b == STX_V2 || b == 0xFE) else {
            out.push(Err(FrameError::Garbage(rest.len())));
            break;
        };
        if start > 0 {
            out.push(Err(FrameError::Garbage(start)));
        }
        at = at.saturating_add(start);
        let rest = datagram.get(at..).unwrap_or(&[]);
        match frame_at(rest) {
            Ok(frame) => {
                at = at.saturating_add(frame.bytes.len());
                out.push(Ok(frame));
            }
            Err(e) => {
                out.push(Err(e));
                at = at.saturating_add(1);
            }
        }
    }
    out
}

/// The frame starting at the first byte of `bytes`.
fn frame_at(bytes: &[u8]) -> Result<RawFrame, FrameError> {
    if bytes.first() == Some(&0xFE) {
        return Err(FrameError::Version1);
    }
    let header = bytes.get(..HEADER_LEN).ok_or(FrameError::Truncated)?;
    let &[_, len, flags, _, sequence, system, component, id0, id1, id2] = header else {
        return Err(FrameError::Truncated);
    };
    if flags & !IFLAG_SIGNED != 0 {
        return Err(FrameError::UnknownFlags(flags));
    }
    let message_id = u32::from_le_bytes([id0, id1, id2, 0]);
    let body = HEADER_LEN.saturating_add(usize::from(len));
    let signature = if flags & IFLAG_SIGNED != 0 {
        SIGNATURE_LEN
    } else {
        0
    };
    let total = body.saturating_add(CRC_LEN).saturating_add(signature);
    let frame = bytes.get(..total).ok_or(FrameError::Truncated)?;
    if MavMessage::default_message_from_id(message_id).is_none() {
        return Err(FrameError::UnknownMessage(message_id));
    }
    let crc_bytes = frame
        .get(body..body.saturating_add(CRC_LEN))
        .ok_or(FrameError::Truncated)?;
    let crc = u16::from_le_bytes([
        crc_bytes.first().copied().unwrap_or(0),
        crc_bytes.get(1).copied().unwrap_or(0),
    ]);
    if checksum(frame.get(1..body).unwrap_or(&[]), message_id) != crc {
        return Err(FrameError::BadChecksum { message_id });
    }
    Ok(RawFrame {
        bytes: frame.to_vec(),
        sender: Sender { system, component },
        sequence,
        message_id,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outgoing::encode;
    use mavlink::dialects::common::*;

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 7,
            mavtype: MavType::MAV_TYPE_HELICOPTER,
            autopilot: MavAutopilot::MAV_AUTOPILOT_GENERIC,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    const VEHICLE: Sender = Sender {
        system: 1,
        component: 1,
    };

    #[test]
    fn a_frame_round_trips() {
        let bytes = encode(VEHICLE, 9, &heartbeat(), None);
        let frames = split(&bytes);
        assert_eq!(frames.len(), 1);
        let frame = frames[0].clone().unwrap();
        assert_eq!(frame.sender, VEHICLE);
        assert_eq!(frame.sequence, 9);
        assert_eq!(frame.message().unwrap(), heartbeat());
        assert!(!frame.is_signed());
    }

    #[test]
    fn the_checksum_matches_the_mavlink_crate() {
        // The crate's own frame writer is the reference for our CRC and layout.
        let ours = encode(VEHICLE, 3, &heartbeat(), None);
        let mut theirs = Vec::new();
        let header = mavlink::MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 3,
        };
        mavlink::write_v2_msg(&mut theirs, header, &heartbeat()).unwrap();
        assert_eq!(ours, theirs);
    }

    #[test]
    fn garbage_around_frames_is_skipped_and_reported() {
        let mut datagram = vec![1, 2, 3];
        datagram.extend(encode(VEHICLE, 1, &heartbeat(), None));
        datagram.extend([0xFD, 9]);
        let frames = split(&datagram);
        assert_eq!(frames[0], Err(FrameError::Garbage(3)));
        assert!(frames[1].is_ok());
        assert_eq!(frames[2], Err(FrameError::Truncated));
    }

    #[test]
    fn a_damaged_frame_costs_only_itself() {
        let mut first = encode(VEHICLE, 1, &heartbeat(), None);
        first[12] ^= 0x40;
        let second = encode(VEHICLE, 2, &heartbeat(), None);
        let datagram = [first, second].concat();
        let frames = split(&datagram);
        assert!(matches!(frames[0], Err(FrameError::BadChecksum { .. })));
        assert!(
            frames
                .iter()
                .filter_map(|f| f.as_ref().ok())
                .any(|f| f.sequence == 2)
        );
    }

    proptest::proptest! {
        #[test]
        fn random_datagrams_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..600)) {
            for frame in split(&bytes).into_iter().flatten() {
                let _ = frame.message();
            }
        }
    }
}
