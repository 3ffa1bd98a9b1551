//! The simulator's "inverse interfaces" (thesis §3.2): each simulated device turns the true
//! state into the bytes the real device would put on its wire, at the device's own rate and
//! with its own errors, using the encoders of `heli-proto`; and the servo controller board
//! reads back the command bytes the flight software writes.
//!
//! Error models here are the simple white-noise ones of the skeleton; the thesis's figures
//! (bias drift, vibration, GPS latency error and satellite drop-outs, ground effect on the
//! altimeter, the avionics' own field on the compass, battery sag) are the next issue's.

pub mod baro;
pub mod battery;
pub mod compass;
pub mod gps;
pub mod imu;
pub mod scb;

pub use heli_model::noise::Noise;

/// Up to 32 bytes of one transmission, without allocating.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bytes {
    buf: [u8; 32],
    len: usize,
}

impl Bytes {
    /// Bytes written by an encoder into a 32-byte buffer.
    pub fn encode(emit: impl FnOnce(&mut [u8]) -> Result<usize, heli_proto::Error>) -> Self {
        let mut buf = [0u8; 32];
        let len = emit(&mut buf).unwrap_or(0);
        Self { buf, len }
    }

    /// A copy of `bytes` (at most 32 are kept).
    pub fn from_slice(bytes: &[u8]) -> Self {
        let mut buf = [0u8; 32];
        let len = bytes.len().min(32);
        buf[..len].copy_from_slice(&bytes[..len]);
        Self { buf, len }
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

/// Time to send `n` bytes at `baud` with 8N1 framing (10 bits a byte), in µs.
pub fn transmit_time_us(n: usize, baud: u32) -> u64 {
    (n as u64 * 10 * 1_000_000).div_ceil(u64::from(baud))
}
