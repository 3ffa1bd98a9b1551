//! State-machine property tests: the main control process driven by arbitrary input
//! sequences (any device, any order, any timing, nonsense values, time going backwards),
//! with every invariant of `heli_fsw::invariants` checked after every input.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::panic,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing
)]

use heli_fsw::invariants::Invariants;
use heli_fsw::{Action, CoreConfig, FlightCore, FlightParams, Input};
use heli_power::PowerSource;
use heli_proto::compass::CompassAdc;
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink, Pulses};
use heli_types::Device;
use heli_types::{AugmentedMode, FlightMode, Leg, Plan};
use proptest::prelude::*;

/// One input of a generated sequence, with the time since the previous one.
#[derive(Clone, Debug)]
enum Step {
    /// An IMU packet: still, or pushing the helicopter up or sideways, or rolling it.
    Imu {
        rate_rps: [f64; 3],
        accel_mps2: [f64; 3],
    },
    /// Several IMU packets 10 ms apart (time passes quickly in a sequence of bounded length).
    ImuRun {
        count: u8,
        accel_up_mps2: f64,
        roll_rate_rps: f64,
    },
    Timer,
    Uplink {
        auto: bool,
        bypass: bool,
        lost: bool,
        collective: f64,
        rpm: u16,
        batt_v: f64,
    },
    Gps {
        north_m: f64,
        east_m: f64,
        satellites: u8,
        alt_m: f64,
        vel_ned_mps: [f64; 3],
    },
    Baro {
        pressure_mbar: f64,
    },
    Compass {
        counts: [u16; 3],
    },
    Battery {
        volts: f64,
    },
    DeviceFailed(u8),
    PowerSource(bool),
    GroundLink(bool),
    /// An IMU packet that is not a reading.
    NotFinite,
}

fn step() -> impl Strategy<Value = Step> {
    let imu = (
        prop::array::uniform3(-0.5f64..0.5),
        (-3.0f64..3.0, -3.0f64..3.0, -14.0f64..-6.0),
    )
        .prop_map(|(rate_rps, (ax, ay, az))| Step::Imu {
            rate_rps,
            accel_mps2: [ax, ay, az],
        });
    let run =
        (1u8..60, 0.0f64..3.0, -3.0f64..3.0).prop_map(|(count, accel_up_mps2, roll_rate_rps)| {
            Step::ImuRun {
                count,
                accel_up_mps2,
                roll_rate_rps,
            }
        });
    let uplink = (
        any::<bool>(),
        prop::bool::weighted(0.1),
        prop::bool::weighted(0.05),
        -1.0f64..1.0,
        prop_oneof![Just(1600u16), 0u16..2000],
        prop_oneof![Just(5.1f64), 3.0f64..6.0],
    )
        .prop_map(
            |(auto, bypass, lost, collective, rpm, batt_v)| Step::Uplink {
                auto,
                bypass,
                lost,
                collective,
                rpm,
                batt_v,
            },
        );
    let gps = (
        -50.0f64..50.0,
        -50.0f64..50.0,
        0u8..12,
        prop_oneof![4 => Just(5.0f64), 1 => -1e7f64..1e7],
        prop_oneof![4 => Just([0.0f64; 3]), 1 => prop::array::uniform3(-1e4f64..1e4)],
    )
        .prop_map(
            |(north_m, east_m, satellites, alt_m, vel_ned_mps)| Step::Gps {
                north_m,
                east_m,
                satellites,
                alt_m,
                vel_ned_mps,
            },
        );
    prop_oneof![
        6 => imu,
        6 => run,
        2 => Just(Step::Timer),
        6 => uplink,
        2 => gps,
        1 => prop_oneof![900.0f64..1100.0, 1e-300f64..1.0, 1e6f64..1e300].prop_map(|pressure_mbar| Step::Baro { pressure_mbar }),
        1 => prop::array::uniform3(0u16..4096).prop_map(|counts| Step::Compass { counts }),
        1 => prop_oneof![9.0f64..13.0, -1e300f64..1e300].prop_map(|volts| Step::Battery { volts }),
        1 => (0u8..5).prop_map(Step::DeviceFailed),
        1 => any::<bool>().prop_map(Step::PowerSource),
        1 => any::<bool>().prop_map(Step::GroundLink),
        1 => Just(Step::NotFinite),
    ]
}

/// A step and the time before it: mostly 10 ms, sometimes a gap, sometimes backwards.
fn timed_step() -> impl Strategy<Value = (i64, Step)> {
    (
        prop_oneof![8 => Just(10_000i64), 2 => 0i64..40_000, 1 => -20_000i64..0],
        step(),
    )
}

fn config() -> CoreConfig {
    CoreConfig {
        imu_warm_up_s: 0.1,
        calibration_s: 1.0,
        ..CoreConfig::default()
    }
}

fn params(mode: u8, rolls: bool) -> FlightParams {
    let mode = match mode {
        0 => FlightMode::Manual,
        1 => FlightMode::Augmented(AugmentedMode::Rate),
        2 => FlightMode::Augmented(AugmentedMode::Attitude),
        3 => FlightMode::Augmented(AugmentedMode::Velocity),
        _ => FlightMode::Autonomous,
    };
    let legs = if rolls {
        vec![
            Leg::Takeoff { alt_m: 2.0 },
            Leg::Rolls {
                count: 1,
                speed_mps: 5.0,
            },
            Leg::Hold { seconds: 1.0 },
            Leg::Land,
        ]
    } else {
        vec![
            Leg::Takeoff { alt_m: 1.0 },
            Leg::Hold { seconds: 0.5 },
            Leg::Land,
        ]
    };
    FlightParams {
        mode,
        plan: Plan::new(&legs).unwrap_or_else(|_| Plan::hover(10.0, 60.0)),
    }
}

fn imu(rate_rps: [f64; 3], accel_mps2: [f64; 3]) -> ImuRepr {
    ImuRepr {
        rate_rps,
        accel_mps2,
        temp_c: 30.0,
    }
}

fn device(k: u8) -> Device {
    match k {
        0 => Device::Imu,
        1 => Device::Uplink,
        2 => Device::Gps,
        3 => Device::Baro,
        _ => Device::Compass,
    }
}

/// Runs `steps` through a fresh core, checking the invariants after every input.
fn run(mode: u8, rolls: bool, start: bool, steps: &[(i64, Step)]) -> Result<u64, String> {
    let config = config();
    let mut core = FlightCore::new(config, params(mode, rolls));
    let mut t_us: u64 = 1_000_000;
    if start {
        core.start(t_us);
    }
    let mut checker = Invariants::new(&core, config.watchdog_us);
    let mut out: Vec<Action> = Vec::new();
    let mut feed = |core: &mut FlightCore, input: Input, t_us: u64| -> Result<(), String> {
        out.clear();
        // The caller's duty: deliver the timer when it is due before anything later.
        if let Some(due) = core.poll_at().filter(|due| *due <= t_us) {
            core.handle(Input::Timer, due, &mut out);
            checker
                .check(core, due, &out)
                .map_err(|v| format!("timer at {due} µs: {v}"))?;
            out.clear();
        }
        core.handle(input, t_us, &mut out);
        checker
            .check(core, t_us, &out)
            .map_err(|v| format!("{input:?} at {t_us} µs: {v}"))
    };
    for (dt_us, step) in steps {
        t_us = t_us.saturating_add_signed(*dt_us);
        let input = match step {
            Step::Imu {
                rate_rps,
                accel_mps2,
            } => Input::Imu(imu(*rate_rps, *accel_mps2)),
            Step::ImuRun {
                count,
                accel_up_mps2,
                roll_rate_rps,
            } => {
                for _ in 1..*count {
                    feed(
                        &mut core,
                        Input::Imu(imu(
                            [*roll_rate_rps, 0.0, 0.0],
                            [0.0, 0.0, -9.81 - accel_up_mps2],
                        )),
                        t_us,
                    )?;
                    t_us = t_us.saturating_add(10_000);
                }
                Input::Imu(imu(
                    [*roll_rate_rps, 0.0, 0.0],
                    [0.0, 0.0, -9.81 - accel_up_mps2],
                ))
            }
            Step::Timer => Input::Timer,
            Step::Uplink {
                auto,
                bypass,
                lost,
                collective,
                rpm,
                batt_v,
            } => Input::Uplink(PilotUplink {
                rotor_rpm: *rpm,
                pulses: if *lost {
                    Pulses::default()
                } else {
                    Pulses::from_controls(&Controls {
                        collective: *collective,
                        throttle: 0.8,
                        ..Controls::default()
                    })
                },
                auto_mode: *auto,
                bypass: *bypass,
                receiver_batt_v: *batt_v,
                servo_batt_v: *batt_v,
            }),
            Step::Gps {
                north_m,
                east_m,
                satellites,
                alt_m,
                vel_ned_mps,
            } => Input::Gps(GpsNav {
                tow_ms: 0,
                lat_deg: 42.3581 + north_m / 111_000.0,
                lon_deg: -71.0966 + east_m / 82_000.0,
                alt_m: *alt_m,
                vel_ned_mps: *vel_ned_mps,
                satellites: *satellites,
                fix: FixType::Fix3D,
            }),
            Step::Baro { pressure_mbar } => Input::Baro {
                pressure_mbar: *pressure_mbar,
            },
            Step::Compass { counts } => Input::Compass(CompassAdc { counts: *counts }),
            Step::Battery { volts } => Input::Battery { volts: *volts },
            Step::DeviceFailed(k) => Input::DeviceFailed(device(*k)),
            Step::PowerSource(ground) => Input::PowerSource(if *ground {
                PowerSource::Ground
            } else {
                PowerSource::Flight
            }),
            Step::GroundLink(fresh) => Input::GroundLink { fresh: *fresh },
            Step::NotFinite => Input::Imu(imu([f64::NAN, 0.0, 0.0], [0.0, 0.0, -9.81])),
        };
        feed(&mut core, input, t_us)?;
    }
    Ok(checker.checked())
}

/// Cases per property (`PROPTEST_CASES` overrides): the sequences are long, so fewer than
/// proptest's default keep the suite fast.
fn cases() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(32),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(cases())]

    #[test]
    fn every_input_keeps_the_invariants(
        mode in 0u8..5,
        rolls in any::<bool>(),
        start in any::<bool>(),
        steps in prop::collection::vec(timed_step(), 50..400),
    ) {
        let checked = run(mode, rolls, start, &steps);
        prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }
}

/// The same checker over a long calibrated flight with the auto switch on: calibration,
/// the pre-flight check, the take-off, the climb the IMU reports, the switch cycled.
#[test]
fn a_scripted_flight_keeps_the_invariants() {
    let mut steps = Vec::new();
    let uplink = |auto| Step::Uplink {
        auto,
        bypass: false,
        lost: false,
        collective: 0.0,
        rpm: 1600,
        batt_v: 5.1,
    };
    steps.push((10_000, uplink(true)));
    for k in 0..400 {
        steps.push((
            10_000,
            Step::ImuRun {
                count: 1,
                accel_up_mps2: if k > 200 { 1.0 } else { 0.0 },
                roll_rate_rps: 0.0,
            },
        ));
        if k % 50 == 0 {
            steps.push((
                0,
                Step::Gps {
                    north_m: 0.0,
                    east_m: 0.0,
                    satellites: 8,
                    alt_m: 5.0,
                    vel_ned_mps: [0.0; 3],
                },
            ));
            steps.push((0, uplink(k < 300)));
        }
    }
    for mode in 0..5 {
        let checked = run(mode, true, true, &steps).unwrap();
        assert!(checked > 400);
    }
}
