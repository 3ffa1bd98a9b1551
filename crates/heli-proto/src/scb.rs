//! Servo controller board (SCB): pilot uplink in, servo commands out.
//!
//! The MIT custom board sits between the R/C receiver, the servos and the
//! flight computer, on one 38400-baud serial line. It reports the pilot's
//! stick pulses, the mode switches, the rotor speed and two battery voltages
//! ([`PilotUplink`], 50 Hz), and takes servo pulse widths back
//! ([`ServoPacket`], 50 Hz). The thesis gives only "header + payload + 1-byte
//! checksum"; the layouts below are this project's.
//!
//! Pilot uplink, board → computer, 17 bytes, big-endian:
//!
//! | offset | size | type | field | unit |
//! |---|---|---|---|---|
//! | 0 | 1 | u8 | header `0xA5` | |
//! | 1 | 2 | u16 | rotor speed (governor pick-up) | rpm |
//! | 3 | 2 | u16 | aileron pulse | µs |
//! | 5 | 2 | u16 | elevator pulse | µs |
//! | 7 | 2 | u16 | rudder pulse | µs |
//! | 9 | 2 | u16 | collective pulse | µs |
//! | 11 | 2 | u16 | throttle pulse | µs |
//! | 13 | 1 | u8 | flags: bit 0 auto switch, bit 1 emergency bypass; others 0 | |
//! | 14 | 1 | u8 | receiver battery, LSB 0.05 V | V |
//! | 15 | 1 | u8 | servo battery, LSB 0.05 V | V |
//! | 16 | 1 | u8 | checksum: sum of bytes 1..=15 mod 256 | |
//!
//! Servo command, computer → board, 12 bytes, big-endian:
//!
//! | offset | size | type | field | unit |
//! |---|---|---|---|---|
//! | 0 | 1 | u8 | header `0x5A` | |
//! | 1 | 2 | u16 | aileron pulse | µs |
//! | 3 | 2 | u16 | elevator pulse | µs |
//! | 5 | 2 | u16 | rudder pulse | µs |
//! | 7 | 2 | u16 | collective pulse | µs |
//! | 9 | 2 | u16 | throttle pulse | µs |
//! | 11 | 1 | u8 | checksum: sum of bytes 1..=10 mod 256 | |

use crate::Error;
use crate::bytes;
use crate::framer::{BinaryFormat, Framer};

/// Pulse width of a centred channel, µs.
pub const PULSE_CENTER_US: u16 = 1500;
/// Pulse width change from centre to full deflection, µs.
pub const PULSE_HALF_RANGE_US: u16 = 500;
/// Throttle pulse width at zero throttle, µs.
pub const THROTTLE_MIN_US: u16 = 1000;
/// Throttle pulse width change from zero to full throttle, µs.
pub const THROTTLE_RANGE_US: u16 = 1000;

/// Serial line speed, bit/s (8N1), both directions.
pub const BAUD: u32 = 38_400;

/// The start-up check (thesis §2.3.4: the driver "ensures that the servo controller board is
/// functioning properly by sending nine consecutive non-header bytes"): [`CHECK_LEN`] bytes of
/// [`CHECK_BYTE`]. A servo packet never holds two zero bytes in a row (every pulse is
/// 1000–2000 µs, so no high byte is zero), so the board cannot mistake a command for the
/// check. The board answers with a pilot uplink packet at once.
pub const CHECK_BYTE: u8 = 0x00;
/// Length of the start-up check.
pub const CHECK_LEN: usize = 9;

/// First byte of a pilot uplink packet.
pub const UPLINK_HEADER: u8 = 0xA5;
/// Length of a pilot uplink packet, header and checksum included.
pub const UPLINK_LEN: usize = 17;
/// Pilot uplink packets per second.
pub const UPLINK_RATE_HZ: u32 = 50;
/// Weight of one count of a battery field, V.
pub const BATT_LSB_V: f64 = 0.05;

/// First byte of a servo command packet.
pub const SERVO_HEADER: u8 = 0x5A;
/// Length of a servo command packet, header and checksum included.
pub const SERVO_LEN: usize = 12;
/// Servo command packets per second.
pub const SERVO_RATE_HZ: u32 = 50;

/// Flag bit of the auto/manual switch (1 = automatic).
pub const FLAG_AUTO: u8 = 0x01;
/// Flag bit of the emergency bypass switch (1 = engaged).
pub const FLAG_BYPASS: u8 = 0x02;
/// Every flag bit the format defines; a packet with another one set is refused.
pub const KNOWN_FLAGS: u8 = FLAG_AUTO | FLAG_BYPASS;

/// Byte offsets of the pilot uplink fields.
pub mod uplink_field {
    /// Header byte.
    pub const HEADER: usize = 0;
    /// Rotor speed, 2 bytes.
    pub const ROTOR_RPM: usize = 1;
    /// First of the five pulse widths (aileron, elevator, rudder, collective,
    /// throttle), 2 bytes each.
    pub const PULSES: usize = 3;
    /// Switch flags.
    pub const FLAGS: usize = 13;
    /// Receiver battery.
    pub const RECEIVER_BATT: usize = 14;
    /// Servo battery.
    pub const SERVO_BATT: usize = 15;
    /// Checksum byte.
    pub const CHECKSUM: usize = 16;
}

/// Byte offsets of the servo command fields.
pub mod servo_field {
    /// Header byte.
    pub const HEADER: usize = 0;
    /// First of the five pulse widths (aileron, elevator, rudder, collective,
    /// throttle), 2 bytes each.
    pub const PULSES: usize = 1;
    /// Checksum byte.
    pub const CHECKSUM: usize = 11;
}

/// The normalised channel set, used both for the pilot's sticks and for servo
/// commands.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Controls {
    /// Lateral cyclic, −1 (full left) ..= 1 (full right).
    pub aileron: f64,
    /// Longitudinal cyclic, −1 ..= 1.
    pub elevator: f64,
    /// Tail rotor pitch, −1 ..= 1.
    pub rudder: f64,
    /// Main rotor collective pitch, −1 ..= 1.
    pub collective: f64,
    /// Throttle, 0 ..= 1.
    pub throttle: f64,
}

fn clamp_or_zero(v: f64, lo: f64, hi: f64) -> f64 {
    if v.is_nan() { 0.0 } else { v.clamp(lo, hi) }
}

impl Controls {
    /// The same controls limited to their ranges: the first four to
    /// `[-1, 1]`, throttle to `[0, 1]`. NaN becomes 0 (centre, or throttle
    /// closed).
    pub fn clamped(self) -> Self {
        Controls {
            aileron: clamp_or_zero(self.aileron, -1.0, 1.0),
            elevator: clamp_or_zero(self.elevator, -1.0, 1.0),
            rudder: clamp_or_zero(self.rudder, -1.0, 1.0),
            collective: clamp_or_zero(self.collective, -1.0, 1.0),
            throttle: clamp_or_zero(self.throttle, 0.0, 1.0),
        }
    }
}

/// Five servo pulse widths, µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Pulses {
    /// Aileron (lateral cyclic) pulse, µs.
    pub aileron_us: u16,
    /// Elevator (longitudinal cyclic) pulse, µs.
    pub elevator_us: u16,
    /// Rudder (tail rotor) pulse, µs.
    pub rudder_us: u16,
    /// Collective pulse, µs.
    pub collective_us: u16,
    /// Throttle pulse, µs.
    pub throttle_us: u16,
}

fn centred_us(u: f64) -> u16 {
    bytes::round_u16(f64::from(PULSE_CENTER_US) + f64::from(PULSE_HALF_RANGE_US) * u)
}

fn centred_u(us: u16) -> f64 {
    (f64::from(us) - f64::from(PULSE_CENTER_US)) / f64::from(PULSE_HALF_RANGE_US)
}

impl Pulses {
    /// Pulse widths for a set of controls: `1500 + 500·u` µs for the centred
    /// channels, `1000 + 1000·u` µs for the throttle; the controls are
    /// [clamped](Controls::clamped) first and the result rounded to the
    /// nearest microsecond.
    pub fn from_controls(c: &Controls) -> Self {
        let c = c.clamped();
        Pulses {
            aileron_us: centred_us(c.aileron),
            elevator_us: centred_us(c.elevator),
            rudder_us: centred_us(c.rudder),
            collective_us: centred_us(c.collective),
            throttle_us: bytes::round_u16(
                f64::from(THROTTLE_MIN_US) + f64::from(THROTTLE_RANGE_US) * c.throttle,
            ),
        }
    }

    /// The controls these pulse widths stand for: the inverse of
    /// [`from_controls`](Self::from_controls), without clamping (a 2100 µs
    /// aileron pulse gives 1.2).
    pub fn to_controls(&self) -> Controls {
        Controls {
            aileron: centred_u(self.aileron_us),
            elevator: centred_u(self.elevator_us),
            rudder: centred_u(self.rudder_us),
            collective: centred_u(self.collective_us),
            throttle: (f64::from(self.throttle_us) - f64::from(THROTTLE_MIN_US))
                / f64::from(THROTTLE_RANGE_US),
        }
    }

    /// Whether every channel is zero: the receiver's failsafe when it loses
    /// the pilot's signal.
    pub fn is_all_zero(&self) -> bool {
        self.as_array() == [0; 5]
    }

    /// The five widths in wire order (aileron, elevator, rudder, collective,
    /// throttle).
    pub fn as_array(&self) -> [u16; 5] {
        [
            self.aileron_us,
            self.elevator_us,
            self.rudder_us,
            self.collective_us,
            self.throttle_us,
        ]
    }

    /// Pulses from five widths in wire order.
    pub fn from_array(a: [u16; 5]) -> Self {
        let [
            aileron_us,
            elevator_us,
            rudder_us,
            collective_us,
            throttle_us,
        ] = a;
        Pulses {
            aileron_us,
            elevator_us,
            rudder_us,
            collective_us,
            throttle_us,
        }
    }

    fn read(frame: &[u8], at: usize) -> Self {
        let mut a = [0u16; 5];
        for (i, slot) in a.iter_mut().enumerate() {
            *slot = bytes::u16_be(frame, at.wrapping_add(i.wrapping_mul(2)));
        }
        Pulses::from_array(a)
    }

    fn write(&self, frame: &mut [u8], at: usize) {
        for (i, v) in self.as_array().iter().enumerate() {
            bytes::put_u16_be(frame, at.wrapping_add(i.wrapping_mul(2)), *v);
        }
    }
}

/// One validated pilot uplink packet.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PilotUplink {
    /// Main rotor speed from the governor's magnetic pick-up, rpm.
    pub rotor_rpm: u16,
    /// The pilot's stick pulse widths as the receiver gives them.
    pub pulses: Pulses,
    /// Auto/manual switch: true = automatic (computer flies).
    pub auto_mode: bool,
    /// Emergency bypass switch engaged: the pilot's pulses go straight to the
    /// servos whatever the computer sends.
    pub bypass: bool,
    /// Receiver battery voltage, V (0.05 V steps, 0..=12.75 V).
    pub receiver_batt_v: f64,
    /// Servo battery voltage, V (0.05 V steps, 0..=12.75 V).
    pub servo_batt_v: f64,
}

impl PilotUplink {
    /// Parse a packet (header first; bytes past [`UPLINK_LEN`] are ignored).
    ///
    /// Errors: [`Error::Truncated`], [`Error::BadHeader`],
    /// [`Error::Checksum`], and [`Error::BadField`] if a reserved flag bit is
    /// set.
    pub fn parse(frame: &[u8]) -> Result<Self, Error> {
        let frame = frame.get(..UPLINK_LEN).ok_or(Error::Truncated)?;
        if bytes::u8_at(frame, uplink_field::HEADER) != UPLINK_HEADER {
            return Err(Error::BadHeader);
        }
        if !UplinkFormat::checksum_ok(frame) {
            return Err(Error::Checksum);
        }
        let flags = bytes::u8_at(frame, uplink_field::FLAGS);
        if flags & !KNOWN_FLAGS != 0 {
            return Err(Error::BadField);
        }
        Ok(PilotUplink {
            rotor_rpm: bytes::u16_be(frame, uplink_field::ROTOR_RPM),
            pulses: Pulses::read(frame, uplink_field::PULSES),
            auto_mode: flags & FLAG_AUTO != 0,
            bypass: flags & FLAG_BYPASS != 0,
            receiver_batt_v: f64::from(bytes::u8_at(frame, uplink_field::RECEIVER_BATT))
                * BATT_LSB_V,
            servo_batt_v: f64::from(bytes::u8_at(frame, uplink_field::SERVO_BATT)) * BATT_LSB_V,
        })
    }

    /// Write the packet into the start of `buf`; returns [`UPLINK_LEN`].
    /// Battery voltages are rounded to 0.05 V and saturate at 0 and 12.75 V.
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let out = buf.get_mut(..UPLINK_LEN).ok_or(Error::BufferTooSmall)?;
        bytes::put_u8(out, uplink_field::HEADER, UPLINK_HEADER);
        bytes::put_u16_be(out, uplink_field::ROTOR_RPM, self.rotor_rpm);
        self.pulses.write(out, uplink_field::PULSES);
        let mut flags = 0;
        if self.auto_mode {
            flags |= FLAG_AUTO;
        }
        if self.bypass {
            flags |= FLAG_BYPASS;
        }
        bytes::put_u8(out, uplink_field::FLAGS, flags);
        bytes::put_u8(
            out,
            uplink_field::RECEIVER_BATT,
            bytes::to_u8(self.receiver_batt_v, BATT_LSB_V),
        );
        bytes::put_u8(
            out,
            uplink_field::SERVO_BATT,
            bytes::to_u8(self.servo_batt_v, BATT_LSB_V),
        );
        let sum = bytes::sum8(bytes::span(out, 1, uplink_field::CHECKSUM));
        bytes::put_u8(out, uplink_field::CHECKSUM, sum);
        Ok(UPLINK_LEN)
    }

    /// Whether the receiver has lost the pilot's signal (all pulses zero).
    pub fn signal_lost(&self) -> bool {
        self.pulses.is_all_zero()
    }

    /// The pilot's sticks as normalised controls, or `None` when the signal
    /// is lost.
    pub fn sticks(&self) -> Option<Controls> {
        if self.signal_lost() {
            None
        } else {
            Some(self.pulses.to_controls())
        }
    }
}

/// The pilot uplink format, for [`Framer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct UplinkFormat;

impl BinaryFormat for UplinkFormat {
    const HEADER: u8 = UPLINK_HEADER;
    const MAX_FRAME_LEN: usize = UPLINK_LEN;

    /// Always [`UPLINK_LEN`]; a candidate whose flags byte has a reserved bit
    /// set cannot be a packet (framing error), so a packet the framer delivers
    /// always parses.
    fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
        match prefix.first() {
            Some(&UPLINK_HEADER) => {}
            Some(_) => return Err(()),
            None => return Ok(None),
        }
        match prefix.get(uplink_field::FLAGS) {
            Some(flags) if flags & !KNOWN_FLAGS != 0 => Err(()),
            _ => Ok(Some(UPLINK_LEN)),
        }
    }

    fn checksum_ok(frame: &[u8]) -> bool {
        frame.len() == UPLINK_LEN
            && bytes::sum8(bytes::span(frame, 1, uplink_field::CHECKSUM))
                == bytes::u8_at(frame, uplink_field::CHECKSUM)
    }
}

/// Byte-at-a-time framer for the pilot uplink.
pub type UplinkFramer = Framer<UplinkFormat, UPLINK_LEN>;

/// One validated servo command packet.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ServoPacket {
    /// The commanded pulse widths.
    pub pulses: Pulses,
}

impl ServoPacket {
    /// Parse a packet (header first; bytes past [`SERVO_LEN`] are ignored).
    ///
    /// Errors: [`Error::Truncated`], [`Error::BadHeader`], [`Error::Checksum`].
    pub fn parse(frame: &[u8]) -> Result<Self, Error> {
        let frame = frame.get(..SERVO_LEN).ok_or(Error::Truncated)?;
        if bytes::u8_at(frame, servo_field::HEADER) != SERVO_HEADER {
            return Err(Error::BadHeader);
        }
        if !ServoFormat::checksum_ok(frame) {
            return Err(Error::Checksum);
        }
        Ok(ServoPacket {
            pulses: Pulses::read(frame, servo_field::PULSES),
        })
    }

    /// Write the packet into the start of `buf`; returns [`SERVO_LEN`].
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let out = buf.get_mut(..SERVO_LEN).ok_or(Error::BufferTooSmall)?;
        bytes::put_u8(out, servo_field::HEADER, SERVO_HEADER);
        self.pulses.write(out, servo_field::PULSES);
        let sum = bytes::sum8(bytes::span(out, 1, servo_field::CHECKSUM));
        bytes::put_u8(out, servo_field::CHECKSUM, sum);
        Ok(SERVO_LEN)
    }
}

/// The servo command format, for [`Framer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct ServoFormat;

impl BinaryFormat for ServoFormat {
    const HEADER: u8 = SERVO_HEADER;
    const MAX_FRAME_LEN: usize = SERVO_LEN;

    fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
        match prefix.first() {
            Some(&SERVO_HEADER) => Ok(Some(SERVO_LEN)),
            Some(_) => Err(()),
            None => Ok(None),
        }
    }

    fn checksum_ok(frame: &[u8]) -> bool {
        frame.len() == SERVO_LEN
            && bytes::sum8(bytes::span(frame, 1, servo_field::CHECKSUM))
                == bytes::u8_at(frame, servo_field::CHECKSUM)
    }
}

/// Byte-at-a-time framer for servo commands (the board's side of the link).
pub type ServoFramer = Framer<ServoFormat, SERVO_LEN>;

#[cfg(test)]
mod tests;
