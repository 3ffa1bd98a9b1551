//! Every device parser on arbitrary bytes. The framers (byte at a time, as the thesis ISR)
//! must never panic and must count every frame they deliver; every binary frame they verify
//! must parse and survive an emit/parse round trip bit for bit. The one-shot parsers are
//! also fed the raw input.
#![no_main]

use heli_proto::baro::{self, BaroCommand, BaroReply};
use heli_proto::framer::FramerStats;
use heli_proto::gps::{GpsFramer, GpsNav};
use heli_proto::imu::{ImuFramer, ImuRepr};
use heli_proto::scb::{PilotUplink, ServoFramer, ServoPacket, UplinkFramer};
use libfuzzer_sys::fuzz_target;

/// Feeds `data` to a framer byte by byte; each verified frame goes to `check`.
macro_rules! frames {
    ($framer:expr, $data:expr, $check:expr) => {{
        let mut framer = $framer;
        for &b in $data {
            if let Some(frame) = framer.push(b) {
                $check(frame);
            }
        }
        framer.stats()
    }};
}

/// Parses a verified frame, emits it again and parses that: the same value both times.
macro_rules! round_trip {
    ($ty:ty, $frame:expr) => {{
        let value = <$ty>::parse($frame).expect("a verified frame parses");
        let mut buf = [0u8; 64];
        let n = value.emit(&mut buf).expect("a parsed value emits");
        assert_eq!(<$ty>::parse(&buf[..n]).ok(), Some(value));
    }};
}

fn sane(stats: FramerStats, frames: u32) {
    assert_eq!(stats.frames, frames);
}

fuzz_target!(|data: &[u8]| {
    let mut n = 0;
    let s = frames!(ImuFramer::default(), data, |f: &[u8]| {
        n += 1;
        round_trip!(ImuRepr, f)
    });
    sane(s, n);
    let mut n = 0;
    let s = frames!(UplinkFramer::default(), data, |f: &[u8]| {
        n += 1;
        round_trip!(PilotUplink, f)
    });
    sane(s, n);
    let mut n = 0;
    let s = frames!(ServoFramer::default(), data, |f: &[u8]| {
        n += 1;
        round_trip!(ServoPacket, f)
    });
    sane(s, n);
    let mut n = 0;
    let s = frames!(GpsFramer::default(), data, |f: &[u8]| {
        n += 1;
        round_trip!(GpsNav, f)
    });
    sane(s, n);
    // ASCII lines: a line may be anything; parsing it must answer, not panic. The altimeter
    // writes pressures with three decimals while the parser takes any plain decimal, so a
    // reply's text form is checked to be stable and within half a unit of the third decimal.
    frames!(baro::reply_framer(), data, |line: &[u8]| {
        if let Ok(first) = BaroReply::parse(line) {
            let mut text = [0u8; 64];
            if let Ok(n) = first.emit(&mut text) {
                let second = BaroReply::parse(&text[..n]).expect("an emitted reply parses");
                if let (
                    BaroReply::Pressure { pressure_mbar: a },
                    BaroReply::Pressure { pressure_mbar: b },
                ) = (first, second)
                {
                    assert!((a - b).abs() <= 0.0005 + 1e-9, "{a} {b}");
                } else {
                    assert_eq!(first, second);
                }
                let mut again = [0u8; 64];
                let m = second.emit(&mut again).expect("a re-parsed reply emits");
                assert_eq!(&text[..n], &again[..m]);
            }
        }
    });
    frames!(baro::command_framer(), data, |line: &[u8]| {
        if BaroCommand::parse(line).is_ok() {
            round_trip!(BaroCommand, line);
        }
    });
    // The one-shot parsers on the raw bytes.
    let _ = ImuRepr::parse(data);
    let _ = PilotUplink::parse(data);
    let _ = ServoPacket::parse(data);
    let _ = GpsNav::parse(data);
    let _ = BaroReply::parse(data);
    let _ = BaroCommand::parse(data);
});
