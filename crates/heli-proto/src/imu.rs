//! Inertial measurement unit: body rates, specific force and temperature.
//!
//! A generic 16-byte binary IMU frame in the style of the Crossbow DMU,
//! 100 Hz, 38400 baud 8N1, big-endian fields:
//!
//! | offset | size | type | field | LSB | range |
//! |---|---|---|---|---|---|
//! | 0 | 1 | u8 | header `0x55` | | |
//! | 1 | 2 | i16 | roll rate p | 2^-12 rad/s | ±8 rad/s |
//! | 3 | 2 | i16 | pitch rate q | 2^-12 rad/s | ±8 rad/s |
//! | 5 | 2 | i16 | yaw rate r | 2^-12 rad/s | ±8 rad/s |
//! | 7 | 2 | i16 | specific force x | 2^-8 m/s² | ±128 m/s² |
//! | 9 | 2 | i16 | specific force y | 2^-8 m/s² | ±128 m/s² |
//! | 11 | 2 | i16 | specific force z | 2^-8 m/s² | ±128 m/s² |
//! | 13 | 2 | i16 | temperature | 0.01 °C | |
//! | 15 | 1 | u8 | checksum: sum of bytes 1..=14 mod 256 | | |
//!
//! Axes are body FRD (x forward, y right, z down); the accelerometers measure
//! specific force, so a level helicopter at rest reads about −9.81 m/s² on z.

use crate::Error;
use crate::bytes;
use crate::framer::{BinaryFormat, Framer};

/// First byte of every frame.
pub const HEADER: u8 = 0x55;
/// Length of a frame, header and checksum included.
pub const FRAME_LEN: usize = 16;
/// Weight of one count of a rate field, rad/s (2^-12).
pub const RATE_LSB_RPS: f64 = 1.0 / 4096.0;
/// Weight of one count of an accelerometer field, m/s² (2^-8).
pub const ACCEL_LSB_MPS2: f64 = 1.0 / 256.0;
/// Weight of one count of the temperature field, °C.
pub const TEMP_LSB_C: f64 = 0.01;
/// Frames per second.
pub const RATE_HZ: u32 = 100;
/// Serial line speed, bit/s (8N1).
pub const BAUD: u32 = 38_400;

/// Byte offsets of the fields in a frame.
pub mod field {
    /// Header byte.
    pub const HEADER: usize = 0;
    /// Roll, pitch and yaw rate (p, q, r), 2 bytes each.
    pub const RATE: [usize; 3] = [1, 3, 5];
    /// Specific force x, y, z, 2 bytes each.
    pub const ACCEL: [usize; 3] = [7, 9, 11];
    /// Temperature, 2 bytes.
    pub const TEMP: usize = 13;
    /// Checksum byte.
    pub const CHECKSUM: usize = 15;
}

/// One validated IMU sample in SI units.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ImuRepr {
    /// Body rates p, q, r, rad/s.
    pub rate_rps: [f64; 3],
    /// Specific force along body x, y, z (FRD), m/s².
    pub accel_mps2: [f64; 3],
    /// Sensor temperature, °C.
    pub temp_c: f64,
}

impl ImuRepr {
    /// Parse a frame (header first; bytes past [`FRAME_LEN`] are ignored).
    ///
    /// Errors: [`Error::Truncated`] if shorter than a frame,
    /// [`Error::BadHeader`], [`Error::Checksum`].
    pub fn parse(frame: &[u8]) -> Result<Self, Error> {
        let frame = frame.get(..FRAME_LEN).ok_or(Error::Truncated)?;
        if bytes::u8_at(frame, field::HEADER) != HEADER {
            return Err(Error::BadHeader);
        }
        if !ImuFormat::checksum_ok(frame) {
            return Err(Error::Checksum);
        }
        let rate = field::RATE.map(|at| f64::from(bytes::i16_be(frame, at)) * RATE_LSB_RPS);
        let accel = field::ACCEL.map(|at| f64::from(bytes::i16_be(frame, at)) * ACCEL_LSB_MPS2);
        Ok(ImuRepr {
            rate_rps: rate,
            accel_mps2: accel,
            temp_c: f64::from(bytes::i16_be(frame, field::TEMP)) * TEMP_LSB_C,
        })
    }

    /// Write the frame into the start of `buf`; returns [`FRAME_LEN`].
    ///
    /// Values are rounded to the nearest count; values outside the field's
    /// range saturate at the `i16` limits, as the sensor does (NaN gives 0).
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let out = buf.get_mut(..FRAME_LEN).ok_or(Error::BufferTooSmall)?;
        bytes::put_u8(out, field::HEADER, HEADER);
        for (at, v) in field::RATE.iter().zip(self.rate_rps) {
            bytes::put_i16_be(out, *at, bytes::to_i16(v, RATE_LSB_RPS));
        }
        for (at, v) in field::ACCEL.iter().zip(self.accel_mps2) {
            bytes::put_i16_be(out, *at, bytes::to_i16(v, ACCEL_LSB_MPS2));
        }
        bytes::put_i16_be(out, field::TEMP, bytes::to_i16(self.temp_c, TEMP_LSB_C));
        let sum = bytes::sum8(bytes::span(out, 1, field::CHECKSUM));
        bytes::put_u8(out, field::CHECKSUM, sum);
        Ok(FRAME_LEN)
    }
}

/// The IMU frame format, for [`Framer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct ImuFormat;

impl BinaryFormat for ImuFormat {
    const HEADER: u8 = HEADER;
    const MAX_FRAME_LEN: usize = FRAME_LEN;

    fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
        match prefix.first() {
            Some(&HEADER) => Ok(Some(FRAME_LEN)),
            Some(_) => Err(()),
            None => Ok(None),
        }
    }

    fn checksum_ok(frame: &[u8]) -> bool {
        frame.len() == FRAME_LEN
            && bytes::sum8(bytes::span(frame, 1, field::CHECKSUM))
                == bytes::u8_at(frame, field::CHECKSUM)
    }
}

/// Byte-at-a-time framer for the IMU.
pub type ImuFramer = Framer<ImuFormat, FRAME_LEN>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil;
    use proptest::prelude::*;

    fn frame_of(r: &ImuRepr) -> Vec<u8> {
        let mut b = [0u8; FRAME_LEN];
        assert_eq!(r.emit(&mut b), Ok(FRAME_LEN));
        b.to_vec()
    }

    /// Fixed test samples whose frames hold no extra 0x55.
    fn fixed() -> [ImuRepr; 4] {
        let mk = |k: f64| ImuRepr {
            rate_rps: [0.1 * k, -0.2 * k, 0.3],
            accel_mps2: [0.5 * k, -0.25, -9.81 + k],
            temp_c: 20.0 + k,
        };
        let out = [mk(1.0), mk(2.0), mk(3.0), mk(4.0)];
        for r in &out {
            assert!(!testutil::extra_header::<ImuFormat>(&frame_of(r)), "{r:?}");
        }
        out
    }

    fn repr() -> impl Strategy<Value = ImuRepr> {
        let rate = -8.0f64..(8.0 - RATE_LSB_RPS);
        let acc = -128.0f64..(128.0 - ACCEL_LSB_MPS2);
        (
            [rate.clone(), rate.clone(), rate],
            [acc.clone(), acc.clone(), acc],
            -40.0f64..85.0,
        )
            .prop_map(|(rate_rps, accel_mps2, temp_c)| ImuRepr {
                rate_rps,
                accel_mps2,
                temp_c,
            })
    }

    #[test]
    fn known_frame() {
        let r = ImuRepr {
            rate_rps: [1.0, -1.0, 0.0],
            accel_mps2: [0.0, 0.0, -9.81],
            temp_c: 25.0,
        };
        let f = frame_of(&r);
        assert_eq!(f[0], 0x55);
        assert_eq!(&f[1..3], &[0x10, 0x00]); // 4096
        assert_eq!(&f[3..5], &[0xF0, 0x00]); // -4096
        assert_eq!(&f[11..13], &(-2511i16).to_be_bytes()); // -9.81 * 256 = -2511.36
        assert_eq!(&f[13..15], &2500i16.to_be_bytes());
        let sum = f[1..15].iter().fold(0u8, |a, b| a.wrapping_add(*b));
        assert_eq!(f[15], sum);
    }

    #[test]
    fn emit_saturates_and_handles_nan() {
        let r = ImuRepr {
            rate_rps: [100.0, -100.0, f64::NAN],
            accel_mps2: [f64::INFINITY, f64::NEG_INFINITY, 0.0],
            temp_c: 1e9,
        };
        let p = ImuRepr::parse(&frame_of(&r)).unwrap();
        assert_eq!(p.rate_rps[0], f64::from(i16::MAX) * RATE_LSB_RPS);
        assert_eq!(p.rate_rps[1], f64::from(i16::MIN) * RATE_LSB_RPS);
        assert_eq!(p.rate_rps[2], 0.0);
        assert_eq!(p.accel_mps2[0], f64::from(i16::MAX) * ACCEL_LSB_MPS2);
        assert_eq!(p.accel_mps2[1], -128.0);
        assert_eq!(p.temp_c, f64::from(i16::MAX) * TEMP_LSB_C);
    }

    #[test]
    fn parse_errors() {
        let f = frame_of(&fixed()[0]);
        assert_eq!(ImuRepr::parse(&f[..15]), Err(Error::Truncated));
        assert_eq!(ImuRepr::parse(&[]), Err(Error::Truncated));
        let mut bad = f.clone();
        bad[0] = 0x54;
        assert_eq!(ImuRepr::parse(&bad), Err(Error::BadHeader));
        let mut bad = f.clone();
        bad[15] = bad[15].wrapping_add(1);
        assert_eq!(ImuRepr::parse(&bad), Err(Error::Checksum));
        let mut long = f.clone();
        long.push(0xAA);
        assert!(ImuRepr::parse(&long).is_ok());
        let mut short = [0u8; FRAME_LEN - 1];
        assert_eq!(fixed()[0].emit(&mut short), Err(Error::BufferTooSmall));
    }

    #[test]
    fn good_bad_good_good_fixed() {
        let fr = fixed().map(|r| frame_of(&r));
        for pick in 0..14 {
            testutil::good_bad_good_good::<ImuFormat, FRAME_LEN>(
                [&fr[0], &fr[1], &fr[2], &fr[3]],
                &(1..15).collect::<Vec<_>>(),
                pick,
                0x01,
            );
        }
    }

    #[test]
    fn false_header_fixed() {
        let fr = frame_of(&fixed()[0]);
        assert!(testutil::false_header_then_frame::<ImuFormat, FRAME_LEN>(
            &[1, 2, 3],
            &[9, 8, 7],
            &fr
        ));
    }

    proptest! {
        #[test]
        fn round_trip(r in repr()) {
            let p = ImuRepr::parse(&frame_of(&r)).unwrap();
            for i in 0..3 {
                prop_assert!((p.rate_rps[i] - r.rate_rps[i]).abs() <= RATE_LSB_RPS / 2.0);
                prop_assert!((p.accel_mps2[i] - r.accel_mps2[i]).abs() <= ACCEL_LSB_MPS2 / 2.0);
            }
            prop_assert!((p.temp_c - r.temp_c).abs() <= TEMP_LSB_C / 2.0 + 1e-9);
            // A parsed value re-emits to the identical frame.
            prop_assert_eq!(frame_of(&p), frame_of(&r));
        }

        #[test]
        fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            testutil::garbage_never_panics::<ImuFormat, FRAME_LEN>(&bytes, |f| ImuRepr::parse(f).is_ok());
        }

        #[test]
        fn garbage_rich_in_headers_never_panics(
            bytes in proptest::collection::vec(prop_oneof![Just(HEADER), any::<u8>()], 0..400)
        ) {
            testutil::garbage_never_panics::<ImuFormat, FRAME_LEN>(&bytes, |f| ImuRepr::parse(f).is_ok());
        }

        #[test]
        fn resync_after_noise(noise in proptest::collection::vec(any::<u8>(), 0..64), r in repr()) {
            testutil::resync_after_noise::<ImuFormat, FRAME_LEN>(&noise, &frame_of(&r));
        }

        #[test]
        fn good_bad_good_good(pick in 0usize..14, mask in 1u8..=255) {
            let fr = fixed().map(|r| frame_of(&r));
            testutil::good_bad_good_good::<ImuFormat, FRAME_LEN>(
                [&fr[0], &fr[1], &fr[2], &fr[3]], &(1..15).collect::<Vec<_>>(), pick, mask);
        }

        #[test]
        fn false_header_then_frame(
            noise in proptest::collection::vec(any::<u8>(), 0..32),
            junk in proptest::collection::vec(any::<u8>(), 0..40),
            r in repr(),
        ) {
            let fr = frame_of(&r);
            testutil::false_header_then_frame::<ImuFormat, FRAME_LEN>(&noise, &junk, &fr);
        }
    }
}
