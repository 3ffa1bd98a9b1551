//! GPS receiver: the navigation solution message.
//!
//! Framing modelled on the Canadian Marconi / NovAtel SuperStar II binary
//! protocol (SOH, message id, complemented id, payload length, payload,
//! 16-bit sum); the payload layout is this project's. 1 Hz, 19200 baud 8N1.
//!
//! | offset | size | type | field | scaling | unit |
//! |---|---|---|---|---|---|
//! | 0 | 1 | u8 | SOH `0x01` | | |
//! | 1 | 1 | u8 | message id, 20 (navigation solution) | | |
//! | 2 | 1 | u8 | complemented id, `!20` = `0xEB` | | |
//! | 3 | 1 | u8 | payload length, 24 | | bytes |
//! | 4 | 4 | u32 LE | GPS time of week of the solution (time of validity) | 1 | ms |
//! | 8 | 4 | i32 LE | latitude | 1e-7 | deg |
//! | 12 | 4 | i32 LE | longitude | 1e-7 | deg |
//! | 16 | 4 | i32 LE | altitude above mean sea level | 1e-3 | m |
//! | 20 | 2 | i16 LE | velocity north | 0.01 | m/s |
//! | 22 | 2 | i16 LE | velocity east | 0.01 | m/s |
//! | 24 | 2 | i16 LE | velocity down | 0.01 | m/s |
//! | 26 | 1 | u8 | satellites used | | |
//! | 27 | 1 | u8 | fix type: 0 none, 2 2-D, 3 3-D | | |
//! | 28 | 2 | u16 LE | checksum: sum of bytes 0..=27 mod 65536 | | |
//!
//! A prefix whose id is not 20, whose complemented id does not match, or
//! whose length is not 24 cannot start a frame: the framer counts a framing
//! error and resynchronises on the next SOH after it.

use crate::Error;
use crate::bytes;
use crate::framer::{BinaryFormat, Framer};

/// Start-of-header byte, the first of every message.
pub const SOH: u8 = 0x01;
/// Message id of the navigation solution.
pub const NAV_ID: u8 = 20;
/// Payload length of the navigation solution, bytes.
pub const NAV_PAYLOAD_LEN: usize = 24;
/// Length of a navigation solution frame: 4 header bytes, payload, 2
/// checksum bytes.
pub const FRAME_LEN: usize = 30;
/// Solutions per second.
pub const RATE_HZ: u32 = 1;
/// Serial line speed, bit/s (8N1).
pub const BAUD: u32 = 19_200;
/// Weight of one count of latitude and longitude, deg.
pub const LATLON_LSB_DEG: f64 = 1e-7;
/// Weight of one count of altitude, m.
pub const ALT_LSB_M: f64 = 1e-3;
/// Weight of one count of a velocity component, m/s.
pub const VEL_LSB_MPS: f64 = 0.01;

/// Byte offsets of the fields in a frame.
pub mod field {
    /// SOH byte.
    pub const SOH: usize = 0;
    /// Message id.
    pub const ID: usize = 1;
    /// Complemented message id.
    pub const ID_COMPLEMENT: usize = 2;
    /// Payload length.
    pub const LEN: usize = 3;
    /// Start of the payload.
    pub const PAYLOAD: usize = 4;
    /// Time of week, 4 bytes.
    pub const TOW: usize = 4;
    /// Latitude, 4 bytes.
    pub const LAT: usize = 8;
    /// Longitude, 4 bytes.
    pub const LON: usize = 12;
    /// Altitude, 4 bytes.
    pub const ALT: usize = 16;
    /// Velocity north, east, down, 2 bytes each.
    pub const VEL: [usize; 3] = [20, 22, 24];
    /// Satellites used.
    pub const SATS: usize = 26;
    /// Fix type.
    pub const FIX: usize = 27;
    /// Checksum, 2 bytes.
    pub const CHECKSUM: usize = 28;
}

/// Kind of position fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FixType {
    /// No fix (wire value 0); position and velocity are not valid.
    #[default]
    NoFix,
    /// Two-dimensional fix (wire value 2); altitude is held, not measured.
    Fix2D,
    /// Three-dimensional fix (wire value 3).
    Fix3D,
    /// Any other wire value, kept as received.
    Unknown(u8),
}

impl FixType {
    /// The fix type of a wire value.
    pub fn from_u8(v: u8) -> Self {
        match v {
            0 => FixType::NoFix,
            2 => FixType::Fix2D,
            3 => FixType::Fix3D,
            other => FixType::Unknown(other),
        }
    }

    /// The wire value of this fix type.
    pub fn to_u8(self) -> u8 {
        match self {
            FixType::NoFix => 0,
            FixType::Fix2D => 2,
            FixType::Fix3D => 3,
            FixType::Unknown(v) => v,
        }
    }
}

/// One validated navigation solution.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct GpsNav {
    /// GPS time of week at which the solution is valid, ms.
    pub tow_ms: u32,
    /// Geodetic latitude, deg (north positive).
    pub lat_deg: f64,
    /// Longitude, deg (east positive).
    pub lon_deg: f64,
    /// Altitude above mean sea level, m.
    pub alt_m: f64,
    /// Velocity north, east, down, m/s.
    pub vel_ned_mps: [f64; 3],
    /// Satellites used in the solution.
    pub satellites: u8,
    /// Kind of fix.
    pub fix: FixType,
}

impl GpsNav {
    /// Parse a frame (SOH first; bytes past [`FRAME_LEN`] are ignored).
    ///
    /// Errors: [`Error::Truncated`]; [`Error::BadHeader`] for a wrong SOH,
    /// id or complemented id; [`Error::BadLength`] for a payload length other
    /// than 24; [`Error::Checksum`].
    pub fn parse(frame: &[u8]) -> Result<Self, Error> {
        let frame = frame.get(..FRAME_LEN).ok_or(Error::Truncated)?;
        let id = bytes::u8_at(frame, field::ID);
        if bytes::u8_at(frame, field::SOH) != SOH
            || id != NAV_ID
            || bytes::u8_at(frame, field::ID_COMPLEMENT) != !id
        {
            return Err(Error::BadHeader);
        }
        if usize::from(bytes::u8_at(frame, field::LEN)) != NAV_PAYLOAD_LEN {
            return Err(Error::BadLength);
        }
        if !GpsFormat::checksum_ok(frame) {
            return Err(Error::Checksum);
        }
        Ok(GpsNav {
            tow_ms: bytes::u32_le(frame, field::TOW),
            lat_deg: f64::from(bytes::i32_le(frame, field::LAT)) * LATLON_LSB_DEG,
            lon_deg: f64::from(bytes::i32_le(frame, field::LON)) * LATLON_LSB_DEG,
            alt_m: f64::from(bytes::i32_le(frame, field::ALT)) * ALT_LSB_M,
            vel_ned_mps: field::VEL.map(|at| f64::from(bytes::i16_le(frame, at)) * VEL_LSB_MPS),
            satellites: bytes::u8_at(frame, field::SATS),
            fix: FixType::from_u8(bytes::u8_at(frame, field::FIX)),
        })
    }

    /// Write the frame into the start of `buf`; returns [`FRAME_LEN`].
    ///
    /// Values are rounded to the nearest count and saturate at the field's
    /// integer limits (NaN gives 0).
    #[expect(
        clippy::cast_possible_truncation,
        reason = "NAV_PAYLOAD_LEN is the constant 24"
    )]
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, Error> {
        let out = buf.get_mut(..FRAME_LEN).ok_or(Error::BufferTooSmall)?;
        bytes::put_u8(out, field::SOH, SOH);
        bytes::put_u8(out, field::ID, NAV_ID);
        bytes::put_u8(out, field::ID_COMPLEMENT, !NAV_ID);
        bytes::put_u8(out, field::LEN, NAV_PAYLOAD_LEN as u8);
        bytes::put_u32_le(out, field::TOW, self.tow_ms);
        bytes::put_i32_le(out, field::LAT, bytes::to_i32(self.lat_deg, LATLON_LSB_DEG));
        bytes::put_i32_le(out, field::LON, bytes::to_i32(self.lon_deg, LATLON_LSB_DEG));
        bytes::put_i32_le(out, field::ALT, bytes::to_i32(self.alt_m, ALT_LSB_M));
        for (at, v) in field::VEL.iter().zip(self.vel_ned_mps) {
            bytes::put_i16_le(out, *at, bytes::to_i16(v, VEL_LSB_MPS));
        }
        bytes::put_u8(out, field::SATS, self.satellites);
        bytes::put_u8(out, field::FIX, self.fix.to_u8());
        let sum = bytes::sum16(bytes::span(out, 0, field::CHECKSUM));
        bytes::put_u16_le(out, field::CHECKSUM, sum);
        Ok(FRAME_LEN)
    }
}

/// The navigation solution format, for [`Framer`].
#[derive(Clone, Copy, Debug, Default)]
pub struct GpsFormat;

impl BinaryFormat for GpsFormat {
    const HEADER: u8 = SOH;
    const MAX_FRAME_LEN: usize = FRAME_LEN;

    fn frame_len(prefix: &[u8]) -> Result<Option<usize>, ()> {
        match prefix.first() {
            Some(&SOH) => {}
            Some(_) => return Err(()),
            None => return Ok(None),
        }
        let Some(&id) = prefix.get(field::ID) else {
            return Ok(None);
        };
        if id != NAV_ID {
            return Err(());
        }
        let Some(&complement) = prefix.get(field::ID_COMPLEMENT) else {
            return Ok(None);
        };
        if complement != !id {
            return Err(());
        }
        match prefix.get(field::LEN) {
            None => Ok(None),
            Some(&len) if usize::from(len) == NAV_PAYLOAD_LEN => Ok(Some(FRAME_LEN)),
            Some(_) => Err(()),
        }
    }

    fn checksum_ok(frame: &[u8]) -> bool {
        frame.len() == FRAME_LEN
            && bytes::sum16(bytes::span(frame, 0, field::CHECKSUM))
                == bytes::u16_le(frame, field::CHECKSUM)
    }
}

/// Byte-at-a-time framer for the GPS.
pub type GpsFramer = Framer<GpsFormat, FRAME_LEN>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil;
    use proptest::prelude::*;

    fn frame_of(g: &GpsNav) -> Vec<u8> {
        let mut b = [0u8; FRAME_LEN];
        assert_eq!(g.emit(&mut b), Ok(FRAME_LEN));
        b.to_vec()
    }

    /// MIT-ish position, different times: no extra SOH in the bytes.
    fn fixed() -> [GpsNav; 4] {
        let mk = |k: u32| GpsNav {
            tow_ms: 345_600_000 + 1000 * k,
            lat_deg: 42.360_2 + f64::from(k) * 1e-5,
            lon_deg: -71.094_2 - f64::from(k) * 1e-5,
            alt_m: 20.5 + f64::from(k),
            vel_ned_mps: [0.5, -1.25, 0.1 * f64::from(k)],
            satellites: 7,
            fix: FixType::Fix3D,
        };
        let out = [mk(1), mk(2), mk(3), mk(4)];
        for g in &out {
            assert!(!testutil::extra_header::<GpsFormat>(&frame_of(g)), "{g:?}");
        }
        out
    }

    fn nav() -> impl Strategy<Value = GpsNav> {
        (
            any::<u32>(),
            -90.0f64..=90.0,
            -180.0f64..=180.0,
            -1000.0f64..20_000.0,
            [-300.0f64..300.0, -300.0f64..300.0, -300.0f64..300.0],
            any::<u8>(),
            any::<u8>(),
        )
            .prop_map(
                |(tow_ms, lat_deg, lon_deg, alt_m, vel_ned_mps, satellites, fix)| GpsNav {
                    tow_ms,
                    lat_deg,
                    lon_deg,
                    alt_m,
                    vel_ned_mps,
                    satellites,
                    fix: FixType::from_u8(fix),
                },
            )
    }

    #[test]
    fn known_frame() {
        let f = frame_of(&fixed()[0]);
        assert_eq!(&f[..4], &[0x01, 20, 0xEB, 24]);
        assert_eq!(u32::from_le_bytes(f[4..8].try_into().unwrap()), 345_601_000);
        assert_eq!(
            i32::from_le_bytes(f[8..12].try_into().unwrap()),
            423_602_100
        );
        assert_eq!(f[27], 3);
        let sum = f[..28]
            .iter()
            .fold(0u16, |a, b| a.wrapping_add(u16::from(*b)));
        assert_eq!(&f[28..30], &sum.to_le_bytes());
    }

    #[test]
    fn fix_type_codes() {
        for v in 0..=255u8 {
            assert_eq!(FixType::from_u8(v).to_u8(), v);
        }
        assert_eq!(FixType::from_u8(1), FixType::Unknown(1));
        assert_eq!(FixType::default(), FixType::NoFix);
    }

    #[test]
    fn parse_errors() {
        let f = frame_of(&fixed()[0]);
        assert_eq!(GpsNav::parse(&f[..29]), Err(Error::Truncated));
        let mut bad = f.clone();
        bad[0] = 0x02;
        assert_eq!(GpsNav::parse(&bad), Err(Error::BadHeader));
        let mut bad = f.clone();
        bad[1] = 21;
        assert_eq!(GpsNav::parse(&bad), Err(Error::BadHeader));
        let mut bad = f.clone();
        bad[2] = 0xEA;
        assert_eq!(GpsNav::parse(&bad), Err(Error::BadHeader));
        let mut bad = f.clone();
        bad[3] = 23;
        assert_eq!(GpsNav::parse(&bad), Err(Error::BadLength));
        let mut bad = f.clone();
        bad[29] ^= 0x80;
        assert_eq!(GpsNav::parse(&bad), Err(Error::Checksum));
        let mut short = [0u8; FRAME_LEN - 1];
        assert_eq!(fixed()[0].emit(&mut short), Err(Error::BufferTooSmall));
    }

    #[test]
    fn framing_errors_on_bad_prefixes() {
        let good = frame_of(&fixed()[0]);
        for (at, v) in [(1usize, 21u8), (2, 0x00), (3, 25)] {
            let mut bad = good.clone();
            bad[at] = v;
            let stream = [bad.as_slice(), &good].concat();
            let (got, stats) = testutil::run::<GpsFormat, FRAME_LEN>(&stream);
            assert_eq!(got, vec![good.clone()]);
            assert_eq!(stats.framing_errors, 1);
            assert_eq!(stats.checksum_errors, 0);
        }
    }

    #[test]
    fn good_bad_good_good_fixed() {
        let fr = fixed().map(|g| frame_of(&g));
        let payload: Vec<usize> = (4..28).collect();
        for pick in 0..24 {
            testutil::good_bad_good_good::<GpsFormat, FRAME_LEN>(
                [&fr[0], &fr[1], &fr[2], &fr[3]],
                &payload,
                pick,
                0x20,
            );
        }
    }

    #[test]
    fn false_header_fixed() {
        let fr = frame_of(&fixed()[0]);
        assert!(testutil::false_header_then_frame::<GpsFormat, FRAME_LEN>(
            &[7, 7],
            &[],
            &fr
        ));
        // A false SOH followed by a plausible id/complement/length.
        assert!(testutil::false_header_then_frame::<GpsFormat, FRAME_LEN>(
            &[7, 7],
            &[20, 0xEB, 24, 5, 6],
            &fr
        ));
    }

    proptest! {
        #[test]
        fn round_trip(g in nav()) {
            let p = GpsNav::parse(&frame_of(&g)).unwrap();
            prop_assert_eq!(p.tow_ms, g.tow_ms);
            prop_assert!((p.lat_deg - g.lat_deg).abs() <= LATLON_LSB_DEG / 2.0 + 1e-12);
            prop_assert!((p.lon_deg - g.lon_deg).abs() <= LATLON_LSB_DEG / 2.0 + 1e-12);
            prop_assert!((p.alt_m - g.alt_m).abs() <= ALT_LSB_M / 2.0 + 1e-9);
            for i in 0..3 {
                prop_assert!((p.vel_ned_mps[i] - g.vel_ned_mps[i]).abs() <= VEL_LSB_MPS / 2.0 + 1e-9);
            }
            prop_assert_eq!(p.satellites, g.satellites);
            prop_assert_eq!(p.fix, g.fix);
            prop_assert_eq!(frame_of(&p), frame_of(&g));
        }

        #[test]
        fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            testutil::garbage_never_panics::<GpsFormat, FRAME_LEN>(&bytes, |f| GpsNav::parse(f).is_ok());
        }

        #[test]
        fn garbage_rich_in_headers_never_panics(
            bytes in proptest::collection::vec(
                prop_oneof![Just(SOH), Just(NAV_ID), Just(!NAV_ID), Just(24u8), any::<u8>()], 0..400)
        ) {
            testutil::garbage_never_panics::<GpsFormat, FRAME_LEN>(&bytes, |f| GpsNav::parse(f).is_ok());
        }

        #[test]
        fn resync_after_noise(noise in proptest::collection::vec(any::<u8>(), 0..64), g in nav()) {
            testutil::resync_after_noise::<GpsFormat, FRAME_LEN>(&noise, &frame_of(&g));
        }

        #[test]
        fn good_bad_good_good(pick in 0usize..24, mask in 1u8..=255) {
            let fr = fixed().map(|g| frame_of(&g));
            let payload: Vec<usize> = (4..28).collect();
            testutil::good_bad_good_good::<GpsFormat, FRAME_LEN>(
                [&fr[0], &fr[1], &fr[2], &fr[3]], &payload, pick, mask);
        }

        #[test]
        fn false_header_then_frame(
            noise in proptest::collection::vec(any::<u8>(), 0..32),
            junk in proptest::collection::vec(any::<u8>(), 0..60),
            g in nav(),
        ) {
            let fr = frame_of(&g);
            testutil::false_header_then_frame::<GpsFormat, FRAME_LEN>(&noise, &junk, &fr);
        }
    }
}
