use super::*;
use crate::testutil;
use proptest::prelude::*;

fn uplink_frame(u: &PilotUplink) -> Vec<u8> {
    let mut b = [0u8; UPLINK_LEN];
    assert_eq!(u.emit(&mut b), Ok(UPLINK_LEN));
    b.to_vec()
}

fn servo_frame(s: &ServoPacket) -> Vec<u8> {
    let mut b = [0u8; SERVO_LEN];
    assert_eq!(s.emit(&mut b), Ok(SERVO_LEN));
    b.to_vec()
}

fn pulses() -> impl Strategy<Value = Pulses> {
    any::<[u16; 5]>().prop_map(Pulses::from_array)
}

fn uplink() -> impl Strategy<Value = PilotUplink> {
    (
        any::<u16>(),
        pulses(),
        any::<bool>(),
        any::<bool>(),
        0.0f64..12.75,
        0.0f64..12.75,
    )
        .prop_map(|(rotor_rpm, pulses, auto_mode, bypass, r, s)| PilotUplink {
            rotor_rpm,
            pulses,
            auto_mode,
            bypass,
            receiver_batt_v: r,
            servo_batt_v: s,
        })
}

fn fixed_uplinks() -> [PilotUplink; 4] {
    let mk = |k: u16| PilotUplink {
        rotor_rpm: 1600 + k,
        pulses: Pulses::from_array([1500 + k, 1400 + k, 1600 - k, 1300 + k, 1100 + k]),
        auto_mode: k.is_multiple_of(2),
        bypass: false,
        receiver_batt_v: 4.8,
        servo_batt_v: 6.0,
    };
    let out = [mk(1), mk(2), mk(3), mk(4)];
    for u in &out {
        assert!(!testutil::extra_header::<UplinkFormat>(&uplink_frame(u)));
    }
    out
}

fn fixed_servos() -> [ServoPacket; 4] {
    let mk = |k: u16| ServoPacket {
        pulses: Pulses::from_array([1500 + k, 1400 + k, 1600 - k, 1300 + k, 1100 + k]),
    };
    let out = [mk(1), mk(2), mk(3), mk(4)];
    for s in &out {
        assert!(!testutil::extra_header::<ServoFormat>(&servo_frame(s)));
    }
    out
}

#[test]
fn pulses_from_controls_fixed_points() {
    let c = Controls {
        aileron: -1.0,
        elevator: 0.0,
        rudder: 1.0,
        collective: 0.5,
        throttle: 0.25,
    };
    let p = Pulses::from_controls(&c);
    assert_eq!(p.as_array(), [1000, 1500, 2000, 1750, 1250]);
    assert_eq!(p.to_controls(), c);
}

#[test]
fn pulses_clamping() {
    let c = Controls {
        aileron: -3.0,
        elevator: 7.0,
        rudder: f64::NAN,
        collective: f64::INFINITY,
        throttle: -0.5,
    };
    let p = Pulses::from_controls(&c);
    assert_eq!(p.as_array(), [1000, 2000, 1500, 2000, 1000]);
    let c = Controls {
        throttle: 2.0,
        ..Controls::default()
    };
    assert_eq!(Pulses::from_controls(&c).throttle_us, 2000);
    assert_eq!(
        Controls {
            throttle: f64::NAN,
            ..c
        }
        .clamped()
        .throttle,
        0.0
    );
    // to_controls does not clamp.
    let wide = Pulses::from_array([2100, 900, 1500, 1500, 2500]);
    let w = wide.to_controls();
    assert!((w.aileron - 1.2).abs() < 1e-12);
    assert!((w.elevator + 1.2).abs() < 1e-12);
    assert!((w.throttle - 1.5).abs() < 1e-12);
}

#[test]
fn sticks_none_when_signal_lost() {
    let lost = PilotUplink {
        rotor_rpm: 1500,
        auto_mode: true,
        ..PilotUplink::default()
    };
    assert!(lost.signal_lost());
    assert_eq!(lost.sticks(), None);
    let parsed = PilotUplink::parse(&uplink_frame(&lost)).unwrap();
    assert_eq!(parsed.sticks(), None);

    let live = PilotUplink {
        pulses: Pulses::from_array([0, 0, 0, 0, 1000]),
        ..lost
    };
    assert!(!live.signal_lost());
    let s = live.sticks().unwrap();
    assert_eq!(s.throttle, 0.0);
    assert_eq!(s.aileron, -3.0);
}

#[test]
fn uplink_known_frame_and_errors() {
    let u = PilotUplink {
        rotor_rpm: 0x0102,
        pulses: Pulses::from_array([1500, 1501, 1502, 1503, 1000]),
        auto_mode: true,
        bypass: true,
        receiver_batt_v: 4.8,
        servo_batt_v: 6.05,
    };
    let f = uplink_frame(&u);
    assert_eq!(f[0], 0xA5);
    assert_eq!(&f[1..3], &[0x01, 0x02]);
    assert_eq!(&f[3..5], &1500u16.to_be_bytes());
    assert_eq!(&f[11..13], &1000u16.to_be_bytes());
    assert_eq!(f[13], 0x03);
    assert_eq!(f[14], 96);
    assert_eq!(f[15], 121);
    assert_eq!(f[16], f[1..16].iter().fold(0u8, |a, b| a.wrapping_add(*b)));

    assert_eq!(PilotUplink::parse(&f[..16]), Err(Error::Truncated));
    let mut bad = f.clone();
    bad[0] = 0x5A;
    assert_eq!(PilotUplink::parse(&bad), Err(Error::BadHeader));
    let mut bad = f.clone();
    bad[5] ^= 0x10;
    assert_eq!(PilotUplink::parse(&bad), Err(Error::Checksum));
    // A reserved flag bit, with a consistent checksum.
    let mut bad = f.clone();
    bad[13] |= 0x80;
    bad[16] = bad[1..16].iter().fold(0u8, |a, b| a.wrapping_add(*b));
    assert_eq!(PilotUplink::parse(&bad), Err(Error::BadField));
    let mut short = [0u8; UPLINK_LEN - 1];
    assert_eq!(u.emit(&mut short), Err(Error::BufferTooSmall));

    let hi = PilotUplink {
        receiver_batt_v: 50.0,
        servo_batt_v: -1.0,
        ..u
    };
    let p = PilotUplink::parse(&uplink_frame(&hi)).unwrap();
    assert!((p.receiver_batt_v - 12.75).abs() < 1e-9);
    assert_eq!(p.servo_batt_v, 0.0);
}

#[test]
fn servo_known_frame_and_errors() {
    let s = ServoPacket {
        pulses: Pulses::from_array([1000, 2000, 1500, 1234, 1999]),
    };
    let f = servo_frame(&s);
    assert_eq!(f[0], 0x5A);
    assert_eq!(&f[1..3], &1000u16.to_be_bytes());
    assert_eq!(&f[9..11], &1999u16.to_be_bytes());
    assert_eq!(f[11], f[1..11].iter().fold(0u8, |a, b| a.wrapping_add(*b)));
    assert_eq!(ServoPacket::parse(&f), Ok(s));
    assert_eq!(ServoPacket::parse(&f[..11]), Err(Error::Truncated));
    let mut bad = f.clone();
    bad[0] = 0xA5;
    assert_eq!(ServoPacket::parse(&bad), Err(Error::BadHeader));
    let mut bad = f.clone();
    bad[11] ^= 1;
    assert_eq!(ServoPacket::parse(&bad), Err(Error::Checksum));
    let mut short = [0u8; SERVO_LEN - 1];
    assert_eq!(s.emit(&mut short), Err(Error::BufferTooSmall));
}

/// Payload offsets whose corruption only the checksum can catch (a
/// reserved flag bit is caught earlier, as a framing error).
const UPLINK_CORRUPTIBLE: [usize; 14] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 14, 15];

#[test]
fn reserved_flag_bit_is_a_framing_error() {
    let u = fixed_uplinks().map(|x| uplink_frame(&x));
    let mut bad = u[1].clone();
    bad[13] |= 0x40;
    bad[16] = bad[1..16].iter().fold(0u8, |a, b| a.wrapping_add(*b));
    let stream = [u[0].clone(), bad, u[2].clone(), u[3].clone()].concat();
    let (got, stats) = testutil::run::<UplinkFormat, UPLINK_LEN>(&stream);
    assert_eq!(got, vec![u[0].clone(), u[2].clone(), u[3].clone()]);
    assert_eq!(stats.framing_errors, 1);
    assert_eq!(stats.checksum_errors, 0);
}

#[test]
fn good_bad_good_good_fixed() {
    let u = fixed_uplinks().map(|x| uplink_frame(&x));
    let s = fixed_servos().map(|x| servo_frame(&x));
    for pick in 0..15 {
        testutil::good_bad_good_good::<UplinkFormat, UPLINK_LEN>(
            [&u[0], &u[1], &u[2], &u[3]],
            &UPLINK_CORRUPTIBLE,
            pick,
            0x04,
        );
        testutil::good_bad_good_good::<ServoFormat, SERVO_LEN>(
            [&s[0], &s[1], &s[2], &s[3]],
            &(1..11).collect::<Vec<_>>(),
            pick,
            0x04,
        );
    }
}

#[test]
fn false_header_fixed() {
    let u = uplink_frame(&fixed_uplinks()[0]);
    assert!(testutil::false_header_then_frame::<UplinkFormat, UPLINK_LEN>(&[0, 1], &[2, 3, 4], &u));
    let s = servo_frame(&fixed_servos()[0]);
    assert!(testutil::false_header_then_frame::<ServoFormat, SERVO_LEN>(
        &[0, 1],
        &[2, 3, 4],
        &s
    ));
}

proptest! {
    #[test]
    fn controls_round_trip(
        a in -1.0f64..=1.0, e in -1.0f64..=1.0, r in -1.0f64..=1.0,
        c in -1.0f64..=1.0, t in 0.0f64..=1.0,
    ) {
        let ctl = Controls { aileron: a, elevator: e, rudder: r, collective: c, throttle: t };
        let back = Pulses::from_controls(&ctl).to_controls();
        prop_assert!((back.aileron - a).abs() <= 0.5 / 500.0 + 1e-12);
        prop_assert!((back.elevator - e).abs() <= 0.5 / 500.0 + 1e-12);
        prop_assert!((back.rudder - r).abs() <= 0.5 / 500.0 + 1e-12);
        prop_assert!((back.collective - c).abs() <= 0.5 / 500.0 + 1e-12);
        prop_assert!((back.throttle - t).abs() <= 0.5 / 1000.0 + 1e-12);
    }

    #[test]
    fn pulses_round_trip_in_range(
        a in 1000u16..=2000, e in 1000u16..=2000, r in 1000u16..=2000,
        c in 1000u16..=2000, t in 1000u16..=2000,
    ) {
        let p = Pulses::from_array([a, e, r, c, t]);
        prop_assert_eq!(Pulses::from_controls(&p.to_controls()), p);
    }

    #[test]
    fn uplink_round_trip(u in uplink()) {
        let p = PilotUplink::parse(&uplink_frame(&u)).unwrap();
        prop_assert_eq!(p.rotor_rpm, u.rotor_rpm);
        prop_assert_eq!(p.pulses, u.pulses);
        prop_assert_eq!(p.auto_mode, u.auto_mode);
        prop_assert_eq!(p.bypass, u.bypass);
        prop_assert!((p.receiver_batt_v - u.receiver_batt_v).abs() <= BATT_LSB_V / 2.0 + 1e-9);
        prop_assert!((p.servo_batt_v - u.servo_batt_v).abs() <= BATT_LSB_V / 2.0 + 1e-9);
        prop_assert_eq!(uplink_frame(&p), uplink_frame(&u));
    }

    #[test]
    fn servo_round_trip(p in pulses()) {
        let s = ServoPacket { pulses: p };
        prop_assert_eq!(ServoPacket::parse(&servo_frame(&s)), Ok(s));
    }

    #[test]
    fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        testutil::garbage_never_panics::<UplinkFormat, UPLINK_LEN>(&bytes, |f| PilotUplink::parse(f).is_ok());
        testutil::garbage_never_panics::<ServoFormat, SERVO_LEN>(&bytes, |f| ServoPacket::parse(f).is_ok());
    }

    #[test]
    fn garbage_rich_in_headers_never_panics(
        bytes in proptest::collection::vec(
            prop_oneof![Just(UPLINK_HEADER), Just(SERVO_HEADER), Just(0u8), any::<u8>()], 0..400)
    ) {
        testutil::garbage_never_panics::<UplinkFormat, UPLINK_LEN>(&bytes, |f| PilotUplink::parse(f).is_ok());
        testutil::garbage_never_panics::<ServoFormat, SERVO_LEN>(&bytes, |f| ServoPacket::parse(f).is_ok());
    }

    #[test]
    fn resync_after_noise(noise in proptest::collection::vec(any::<u8>(), 0..64), u in uplink(), p in pulses()) {
        testutil::resync_after_noise::<UplinkFormat, UPLINK_LEN>(&noise, &uplink_frame(&u));
        testutil::resync_after_noise::<ServoFormat, SERVO_LEN>(&noise, &servo_frame(&ServoPacket { pulses: p }));
    }

    #[test]
    fn good_bad_good_good(pick in 0usize..15, mask in 1u8..=255) {
        let u = fixed_uplinks().map(|x| uplink_frame(&x));
        testutil::good_bad_good_good::<UplinkFormat, UPLINK_LEN>([&u[0], &u[1], &u[2], &u[3]], &UPLINK_CORRUPTIBLE, pick, mask);
        let s = fixed_servos().map(|x| servo_frame(&x));
        testutil::good_bad_good_good::<ServoFormat, SERVO_LEN>([&s[0], &s[1], &s[2], &s[3]], &(1..11).collect::<Vec<_>>(), pick, mask);
    }

    #[test]
    fn false_header_then_frame(
        noise in proptest::collection::vec(any::<u8>(), 0..32),
        junk in proptest::collection::vec(any::<u8>(), 0..40),
        u in uplink(),
        p in pulses(),
    ) {
        let uf = uplink_frame(&u);
        testutil::false_header_then_frame::<UplinkFormat, UPLINK_LEN>(&noise, &junk, &uf);
        let sf = servo_frame(&ServoPacket { pulses: p });
        testutil::false_header_then_frame::<ServoFormat, SERVO_LEN>(&noise, &junk, &sf);
    }
}
