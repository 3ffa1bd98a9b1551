//! The whole flight software on hostile serial ports: arbitrary bytes on the IMU, servo
//! board, GPS and altimeter ports, interleaved with well-formed IMU and pilot packets built
//! from the input (so that the core gets through calibration and into flight), delivered
//! through the drivers to the flight core with the watchdog timer. The flight must never
//! panic and every servo command it writes must be finite and within the servo range,
//! whatever arrives.
//!
//! Input layout: byte 0 picks the flight mode; then chunks of `[port | dt << 3, len, bytes]`
//! where `dt` is 0–31 ms of time passing before the chunk, and port is
//! 0 IMU, 1 servo board, 2 GPS, 3 altimeter (raw bytes), 4 a well-formed IMU sample,
//! 5 a well-formed pilot packet (sticks, rpm, auto and bypass switches from the bytes).
#![no_main]

use heli_fsw::Action;
use heli_fsw::core::{CoreConfig, FlightCore, FlightParams, Input};
use heli_fsw::drivers::Drivers;
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{PilotUplink, Pulses};
use heli_types::{AugmentedMode, FlightMode};
use libfuzzer_sys::fuzz_target;

const GRAVITY_MPS2: f64 = 9.80665;

fn imu_frame(b: &[u8]) -> Vec<u8> {
    let s = |i: usize| f64::from(b.get(i).copied().unwrap_or(0) as i8);
    let sample = ImuRepr {
        rate_rps: [s(0) / 32.0, s(1) / 32.0, s(2) / 32.0],
        accel_mps2: [s(3) / 8.0, s(4) / 8.0, -GRAVITY_MPS2 + s(5) / 8.0],
        temp_c: 20.0,
    };
    let mut buf = [0u8; 64];
    let n = sample.emit(&mut buf).unwrap_or(0);
    buf[..n].to_vec()
}

fn uplink_frame(b: &[u8]) -> Vec<u8> {
    let stick = |i: usize| 1000 + 4 * u16::from(b.get(i).copied().unwrap_or(125)).min(250);
    let flags = b.get(5).copied().unwrap_or(0);
    let packet = PilotUplink {
        rotor_rpm: 1500 + u16::from(b.get(6).copied().unwrap_or(100)),
        pulses: Pulses {
            aileron_us: stick(0),
            elevator_us: stick(1),
            rudder_us: stick(2),
            collective_us: stick(3),
            throttle_us: stick(4),
        },
        auto_mode: flags & 1 != 0,
        bypass: flags & 2 != 0,
        receiver_batt_v: 5.0,
        servo_batt_v: 5.0,
    };
    let mut buf = [0u8; 64];
    let n = packet.emit(&mut buf).unwrap_or(0);
    buf[..n].to_vec()
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, mut rest)) = data.split_first() else {
        return;
    };
    let mode = match mode % 5 {
        0 => FlightMode::Manual,
        1 => FlightMode::Autonomous,
        2 => FlightMode::Augmented(AugmentedMode::Rate),
        3 => FlightMode::Augmented(AugmentedMode::Attitude),
        _ => FlightMode::Augmented(AugmentedMode::Velocity),
    };
    let config = CoreConfig {
        imu_warm_up_s: 0.0,
        calibration_s: 0.1,
        ..CoreConfig::default()
    };
    let params = FlightParams {
        mode,
        ..FlightParams::default()
    };
    let mut core = FlightCore::new(config, params);
    let mut drivers = Drivers::new(5);
    let mut now_us = 0u64;
    let mut inputs: Vec<Input> = Vec::new();
    let mut actions: Vec<Action> = Vec::new();
    core.start(now_us);
    drivers.baro.start(now_us, &mut |_: &[u8]| {});

    while let [header, len, tail @ ..] = rest {
        let n = usize::from(*len).min(tail.len());
        let (chunk, next) = tail.split_at(n);
        rest = next;
        let deadline = now_us + 1000 * u64::from(header >> 3);
        // The watchdog fires wherever it is due on the way.
        while let Some(at) = core.poll_at().filter(|&at| at <= deadline) {
            now_us = now_us.max(at);
            core.handle(Input::Timer, now_us, &mut actions);
        }
        now_us = deadline;
        let sink = |i: Input| inputs.push(i);
        match header & 7 {
            0 => drivers.imu_bytes(chunk, sink),
            1 => drivers.uplink_bytes(chunk, sink),
            2 => drivers.gps_bytes(chunk, sink),
            3 => drivers.baro_bytes(chunk, now_us, &mut |_: &[u8]| {}, sink),
            4 => drivers.imu_bytes(&imu_frame(chunk), sink),
            _ => drivers.uplink_bytes(&uplink_frame(chunk), sink),
        }
        for input in inputs.drain(..) {
            core.handle(input, now_us, &mut actions);
        }
    }

    if std::env::var_os("HELI_FUZZ_SHOW").is_some() {
        eprintln!("phase {:?} stats {:?}", core.phase(), core.stats());
    }
    for action in &actions {
        if let Action::Servo(command) = action {
            let c = command.value;
            for v in [c.aileron, c.elevator, c.rudder, c.collective] {
                assert!(v.is_finite() && (-1.0..=1.0).contains(&v), "{c:?}");
            }
            assert!(
                c.throttle.is_finite() && (0.0..=1.0).contains(&c.throttle),
                "{c:?}"
            );
        }
    }
});
