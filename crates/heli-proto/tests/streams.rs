//! Stream-level checks of the binary framers through the public API only:
//! the byte-at-a-time framer must agree exactly with an offline reference
//! scan of the whole stream, for every format.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::unreachable
)]

use heli_proto::framer::{BinaryFormat, Framer};
use heli_proto::gps::{self, GpsFormat, GpsNav};
use heli_proto::imu::{self, ImuFormat, ImuRepr};
use heli_proto::scb::{self, PilotUplink, Pulses, ServoFormat, ServoPacket, UplinkFormat};
use proptest::prelude::*;

#[derive(Debug, Default, PartialEq)]
struct Outcome {
    frames: Vec<Vec<u8>>,
    checksum_errors: u32,
    framing_errors: u32,
}

/// Offline reference: a candidate starts at every header byte not inside a
/// delivered frame; it is rejected if any of its prefixes is refused by
/// `frame_len`, or if it is complete and fails its checksum; after a
/// rejection the scan restarts one byte after the failed header.
fn reference<F: BinaryFormat>(stream: &[u8]) -> Outcome {
    let mut out = Outcome::default();
    let mut i = 0;
    'scan: while i < stream.len() {
        if stream[i] != F::HEADER {
            i += 1;
            continue;
        }
        let rest = &stream[i..];
        let mut k = 1;
        let mut n = None;
        loop {
            if k > rest.len() {
                break 'scan; // incomplete candidate at the end of the stream
            }
            match F::frame_len(&rest[..k]) {
                Err(()) => {
                    out.framing_errors += 1;
                    i += 1;
                    continue 'scan;
                }
                Ok(Some(len)) => n = Some(len),
                Ok(None) => {}
            }
            if let Some(len) = n
                && k >= len
            {
                break;
            }
            k += 1;
        }
        let len = n.unwrap();
        if F::checksum_ok(&rest[..len]) {
            out.frames.push(rest[..len].to_vec());
            i += len;
        } else {
            out.checksum_errors += 1;
            i += 1;
        }
    }
    out
}

fn online<F: BinaryFormat, const N: usize>(stream: &[u8]) -> Outcome {
    let mut f: Framer<F, N> = Framer::new();
    let frames = stream
        .iter()
        .filter_map(|&b| f.push(b).map(<[u8]>::to_vec))
        .collect();
    let s = f.stats();
    Outcome {
        frames,
        checksum_errors: s.checksum_errors,
        framing_errors: s.framing_errors,
    }
}

/// A stream made of pieces: good frames, good frames with one byte changed,
/// truncated frames, bare header bytes and random bytes.
fn stream(frames: Vec<Vec<u8>>, header: u8) -> impl Strategy<Value = Vec<u8>> {
    let piece = (
        0usize..5,
        any::<prop::sample::Index>(),
        any::<u8>(),
        proptest::collection::vec(any::<u8>(), 0..8),
    );
    proptest::collection::vec(piece, 0..24).prop_map(move |pieces| {
        let mut s = Vec::new();
        for (kind, idx, byte, noise) in pieces {
            let f = idx.get(&frames);
            match kind {
                0 | 1 => s.extend_from_slice(f),
                2 => {
                    let mut g = f.clone();
                    let at = idx.index(g.len());
                    g[at] ^= byte | 1;
                    s.extend(g);
                }
                3 => s.extend_from_slice(&f[..idx.index(f.len())]),
                _ => {
                    s.push(header);
                    s.extend(noise);
                }
            }
        }
        s
    })
}

fn imu_frames() -> Vec<Vec<u8>> {
    (0..8)
        .map(|k| {
            let r = ImuRepr {
                rate_rps: [0.01 * f64::from(k), -0.5, 1.0],
                accel_mps2: [0.0, 0.1 * f64::from(k), -9.81],
                temp_c: 25.0,
            };
            let mut b = [0u8; imu::FRAME_LEN];
            r.emit(&mut b).unwrap();
            b.to_vec()
        })
        .collect()
}

fn uplink_frames() -> Vec<Vec<u8>> {
    (0..8u16)
        .map(|k| {
            let u = PilotUplink {
                rotor_rpm: 1500 + 37 * k,
                pulses: Pulses::from_array([1500 + k, 1500 - k, 1100 * (k % 2), 1600, 1200]),
                auto_mode: k % 3 == 0,
                bypass: k == 5,
                receiver_batt_v: 4.9,
                servo_batt_v: 5.9,
            };
            let mut b = [0u8; scb::UPLINK_LEN];
            u.emit(&mut b).unwrap();
            b.to_vec()
        })
        .collect()
}

fn servo_frames() -> Vec<Vec<u8>> {
    (0..8u16)
        .map(|k| {
            let p = ServoPacket {
                pulses: Pulses::from_array([1000 + 90 * k, 2000 - 3 * k, 1500, 1500 + k, 1000]),
            };
            let mut b = [0u8; scb::SERVO_LEN];
            p.emit(&mut b).unwrap();
            b.to_vec()
        })
        .collect()
}

fn gps_frames() -> Vec<Vec<u8>> {
    (0..8u32)
        .map(|k| {
            let g = GpsNav {
                tow_ms: 1000 * k,
                lat_deg: 42.36 + 1e-6 * f64::from(k),
                lon_deg: -71.09,
                alt_m: 10.0 * f64::from(k),
                vel_ned_mps: [1.0, 0.0, -0.5],
                satellites: 4 + (k as u8),
                fix: gps::FixType::from_u8((k % 4) as u8),
            };
            let mut b = [0u8; gps::FRAME_LEN];
            g.emit(&mut b).unwrap();
            b.to_vec()
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn imu_matches_reference(s in stream(imu_frames(), imu::HEADER)) {
        let got = online::<ImuFormat, { imu::FRAME_LEN }>(&s);
        prop_assert_eq!(&got, &reference::<ImuFormat>(&s));
        for f in &got.frames {
            prop_assert!(ImuRepr::parse(f).is_ok());
        }
    }

    #[test]
    fn uplink_matches_reference(s in stream(uplink_frames(), scb::UPLINK_HEADER)) {
        let got = online::<UplinkFormat, { scb::UPLINK_LEN }>(&s);
        prop_assert_eq!(&got, &reference::<UplinkFormat>(&s));
        for f in &got.frames {
            prop_assert!(PilotUplink::parse(f).is_ok());
        }
    }

    #[test]
    fn servo_matches_reference(s in stream(servo_frames(), scb::SERVO_HEADER)) {
        let got = online::<ServoFormat, { scb::SERVO_LEN }>(&s);
        prop_assert_eq!(&got, &reference::<ServoFormat>(&s));
        for f in &got.frames {
            prop_assert!(ServoPacket::parse(f).is_ok());
        }
    }

    #[test]
    fn gps_matches_reference(s in stream(gps_frames(), gps::SOH)) {
        let got = online::<GpsFormat, { gps::FRAME_LEN }>(&s);
        prop_assert_eq!(&got, &reference::<GpsFormat>(&s));
        for f in &got.frames {
            prop_assert!(GpsNav::parse(f).is_ok());
        }
    }

    /// Clean back-to-back frames with header-free noise in between all come
    /// out, in order.
    #[test]
    fn clean_sequences_all_delivered(
        picks in proptest::collection::vec((0usize..8, proptest::collection::vec(any::<u8>(), 0..10)), 0..30)
    ) {
        let frames = imu_frames();
        let mut s = Vec::new();
        let mut want = Vec::new();
        for (k, noise) in picks {
            s.extend(noise.into_iter().filter(|&b| b != imu::HEADER));
            s.extend_from_slice(&frames[k]);
            want.push(frames[k].clone());
        }
        let got = online::<ImuFormat, { imu::FRAME_LEN }>(&s);
        prop_assert_eq!(got.frames, want);
        prop_assert_eq!(got.checksum_errors, 0);
    }
}

#[test]
fn error_is_reexported_and_displays() {
    let e: heli_proto::Error = ImuRepr::parse(&[0x55]).unwrap_err();
    assert_eq!(e, heli_proto::Error::Truncated);
    assert!(!e.to_string().is_empty());
    let boxed: Box<dyn std::error::Error> = Box::new(e);
    assert!(!boxed.to_string().is_empty());
}

#[test]
fn framer_aliases_are_usable_as_statics_state() {
    // Const construction, as an interrupt handler's state would be.
    const IMU: imu::ImuFramer = imu::ImuFramer::new();
    const GPS: gps::GpsFramer = gps::GpsFramer::new();
    let mut a = IMU;
    let mut g = GPS;
    let mut u = scb::UplinkFramer::default();
    let mut s = scb::ServoFramer::default();
    assert_eq!(a.push(0), None);
    assert_eq!(g.push(0), None);
    assert_eq!(u.push(0), None);
    assert_eq!(s.push(0), None);
    assert_eq!(a.stats().discarded_bytes, 1);
}
