//! The observers of the running flight: the battery server (thesis §2.3: it reads the
//! battery's analog channel and answers requests for the voltage) and the telemetry server,
//! which samples the freshest value of each stream at [`TELEMETRY_PERIOD`] and reports it.
//! Both only read the streams; neither can delay the control loop.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use heli_fsw::Stamped;
use heli_proto::battery::BatteryAdc;
use heli_types::Device;
use serde_json::{Value, json};

use crate::adc;
use crate::logger::{LogItem, LogSender};
use crate::streams::LiveStreams;
use crate::threads::{Clock, LoopMsg, sleep_unless_stopped};
use heli_fsw::RecordedInput;

/// Battery read period.
pub const BATTERY_PERIOD: Duration = Duration::from_secs(1);
/// Telemetry report period: 10 Hz, so the link can serve each message at up to that rate
/// (3 Hz by default, as the thesis's display asked).
pub const TELEMETRY_PERIOD: Duration = Duration::from_millis(100);

/// A request to the battery server: the reply goes to the enclosed sender.
pub type BatteryRequest = Sender<Option<Stamped<f64>>>;

/// Starts the battery server. It reads channel `adc_channel` of `dir` every [`BATTERY_PERIOD`],
/// publishes the voltage, logs it, hands the reading to the control loop (the safety rule's
/// `battery` condition) and answers requests on the returned sender.
pub fn spawn_battery_server(
    dir: PathBuf,
    adc_channel: u8,
    to_loop: Sender<LoopMsg>,
    clock: Clock,
    streams: Arc<LiveStreams>,
    log: Option<LogSender>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<(Sender<BatteryRequest>, JoinHandle<()>)> {
    let (tx, rx): (Sender<BatteryRequest>, Receiver<BatteryRequest>) = channel();
    let handle = crate::rt::thread("battery", crate::rt::HELPER_STACK_BYTES).spawn(move || {
        let mut latest: Option<Stamped<f64>> = None;
        let mut next_read_us = 0u64;
        // A channel that cannot be read is said once a failing spell, with why (the
        // path and the error); the core's channel watch raises the readings' lateness.
        let mut failing = false;
        let period_us = u64::try_from(BATTERY_PERIOD.as_micros()).unwrap_or(1_000_000);
        while !stop.load(Ordering::Acquire) {
            let now = clock.now_us();
            if now >= next_read_us {
                next_read_us = now.saturating_add(period_us);
                let read = adc::read_channel(&dir, adc_channel);
                if let Some(note) = spell_note(&mut failing, &read) {
                    let _ = to_loop.send(LoopMsg::Note(format!("battery: {note}")));
                }
                if let Ok(counts) = read {
                    let _ = to_loop.send(LoopMsg::Input(
                        now,
                        RecordedInput::Battery(BatteryAdc { counts }),
                    ));
                    let volts = BatteryAdc { counts }.volts();
                    let reading = Stamped::new(now, volts);
                    latest = Some(reading);
                    streams.battery_v.publish(reading);
                    if let Some(log) = &log {
                        log.send(LogItem::Battery(now, volts));
                    }
                }
            }
            // Answer what came in, then wait a little for more.
            match rx.recv_timeout(Duration::from_millis(50)) {
                Ok(reply) => {
                    let _ = reply.send(latest);
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return,
            }
        }
    })?;
    Ok((tx, handle))
}

/// What to say of a read in a spell of failures: the first failure (with its error), and
/// the first read that works after it. `failing` is whether the spell is on.
fn spell_note<T, E: std::fmt::Display>(failing: &mut bool, read: &Result<T, E>) -> Option<String> {
    match (read, *failing) {
        (Err(e), false) => {
            *failing = true;
            Some(format!("{e}: no reading until it can be read again"))
        }
        (Ok(_), true) => {
            *failing = false;
            Some("read again".to_string())
        }
        _ => None,
    }
}

/// Asks the battery server for the voltage (waits at most 200 ms).
pub fn ask_battery(server: &Sender<BatteryRequest>) -> Option<Stamped<f64>> {
    let (tx, rx) = channel();
    server.send(tx).ok()?;
    rx.recv_timeout(Duration::from_millis(200)).ok().flatten()
}

/// How long an estimate stays current after its stamp (µs): the control loop publishes one
/// every 20 ms, so one half a second old has stopped coming (the estimate lost, the IMU
/// silent) and is not reported as the helicopter's state.
pub const STATE_CURRENT_US: u64 = 500_000;

/// One telemetry report: the freshest value of each stream, as the ground display's rows
/// and the link's telemetry messages.
pub fn snapshot(streams: &LiveStreams, battery: Option<Stamped<f64>>, now_us: u64) -> Value {
    use heli_link::telemetry as t;
    // The flight software's clock now: the records are stamped on it as their inputs came,
    // and none is later than now.
    let newest = streams.state.latest();
    let core_now_us = now_us.max(newest.as_ref().map_or(0, |s| s.t_us));
    let state = newest
        .filter(|s| core_now_us.saturating_sub(s.t_us) <= STATE_CURRENT_US)
        .map(|s| {
            let nav = &s.value.nav;
            let (roll, pitch, yaw) = nav.euler_rad();
            t::StateRow {
                phase: s.value.phase.name().to_string(),
                euler_rad: [roll, pitch, yaw],
                rate_rps: [
                    nav.rate_body_rps.x,
                    nav.rate_body_rps.y,
                    nav.rate_body_rps.z,
                ],
                pos_ned_m: [nav.pos_ned_m.x, nav.pos_ned_m.y, nav.pos_ned_m.z],
                vel_ned_mps: [nav.vel_ned_mps.x, nav.vel_ned_mps.y, nav.vel_ned_mps.z],
            }
        });
    let servo = streams.servo.latest().map(|s| {
        let c = s.value.controls;
        t::ServoRow {
            commands: [c.aileron, c.elevator, c.rudder, c.collective, c.throttle],
        }
    });
    let uplink = streams.uplink.latest().map(|u| {
        let p = u.value.pulses;
        t::UplinkRow {
            pulses_us: [
                p.aileron_us,
                p.elevator_us,
                p.rudder_us,
                p.collective_us,
                p.throttle_us,
            ],
            auto_mode: u.value.auto_mode,
            bypass: u.value.bypass,
            rotor_rpm: u.value.rotor_rpm,
            receiver_batt_v: u.value.receiver_batt_v,
            servo_batt_v: u.value.servo_batt_v,
        }
    });
    // The GPS fix's age on the flight software's clock: it grows while the GPS is silent,
    // whether or not the estimate goes on.
    let gps = streams.gps.latest().map(|g| t::GpsRow {
        lat_deg: g.value.lat_deg,
        lon_deg: g.value.lon_deg,
        alt_m: g.value.alt_m,
        vel_ned_mps: g.value.vel_ned_mps,
        satellites: g.value.satellites,
        fix_3d: g.value.fix == heli_proto::gps::FixType::Fix3D,
        age_s: core_now_us.saturating_sub(g.t_us) as f64 * 1e-6,
    });
    let imu = streams.imu.latest().map(|i| t::ImuRow {
        rate_rps: i.value.imu.rate_rps,
        accel_mps2: i.value.imu.accel_mps2,
    });
    let baro = streams.baro.latest().map(|b| t::BaroRow {
        pressure_mbar: b.value.pressure_mbar,
        alt_m: b.value.alt_m,
    });
    let compass = streams.compass.latest().map(|c| t::CompassRow {
        field_gauss: c.value.field.field_gauss,
        heading_rad: c.value.heading_rad,
    });
    let health = streams
        .health
        .latest()
        .map(|h| {
            Device::ALL
                .iter()
                .map(|d| t::DeviceHealth {
                    device: d.name().to_string(),
                    state: h.state(*d).name().to_string(),
                    lapses: h.monitor(*d).counts().lapses(),
                })
                .collect()
        })
        .unwrap_or_default();
    let power = streams.power.latest().map(|p| (*p).clone());
    let telemetry = t::Telemetry {
        t_us: now_us,
        phase: streams.phase.latest().map(|p| p.name().to_string()),
        imu,
        state,
        uplink,
        servo,
        gps,
        baro,
        compass,
        battery_v: battery.map(|b| b.value),
        battery_remaining: power.as_ref().and_then(|p| {
            p.batteries
                .iter()
                .find(|b| b.name == "flight")
                .map(|b| b.percent / 100.0)
        }),
        health,
        power,
        origin: streams
            .origin
            .latest()
            .and_then(|o| *o)
            .map(|o| [o.lat_deg, o.lon_deg, o.alt_m]),
    };
    let mut value = serde_json::to_value(&telemetry).unwrap_or(Value::Null);
    if let Some(map) = value.as_object_mut() {
        map.insert(
            "published".into(),
            json!({
                "imu": streams.imu.published(),
                "state": streams.state.published(),
                "servo": streams.servo.published(),
                "uplink": streams.uplink.published(),
                "gps": streams.gps.published(),
                "baro": streams.baro.published(),
                "compass": streams.compass.published(),
            }),
        );
    }
    value
}

/// The batteries' gauges and the hot-swap's times as the telemetry's power row, at `now_us`.
pub fn power_row(core: &heli_fsw::core::FlightCore, now_us: u64) -> heli_link::telemetry::PowerRow {
    use heli_fsw::core::power::Battery;
    let power = core.power();
    let batteries = Battery::ALL
        .iter()
        .filter_map(|b| {
            let s = power.state(*b)?;
            Some(heli_link::telemetry::BatteryRow {
                name: match b {
                    Battery::Flight => "flight",
                    Battery::Receiver => "receiver",
                    Battery::Servo => "servo",
                }
                .to_string(),
                volts: s.volts,
                percent: 100.0 * s.soc,
                minutes_left: s.time_left_s / 60.0,
                level: s.level.name().to_string(),
                draining_abnormally: s.draining_abnormally,
            })
        })
        .collect();
    let (flight_s, ground_s) = power.times(now_us);
    heli_link::telemetry::PowerRow {
        batteries,
        source: power.source().map(|s| s.name().to_string()),
        flight_s,
        ground_s,
    }
}

/// Starts the telemetry server: every [`TELEMETRY_PERIOD`] it takes a [`snapshot`] and hands
/// it to `report`.
pub fn spawn_telemetry(
    clock: Clock,
    streams: Arc<LiveStreams>,
    battery: Sender<BatteryRequest>,
    report: Arc<dyn Fn(Value) + Send + Sync>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    crate::rt::thread("telemetry", crate::rt::HELPER_STACK_BYTES).spawn(move || {
        while !stop.load(Ordering::Acquire) {
            sleep_unless_stopped(TELEMETRY_PERIOD, &stop);
            let volts = ask_battery(&battery);
            report(snapshot(&streams, volts, clock.now_us()));
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_fsw::core::{CoreConfig, FlightCore, FlightParams, Input};
    use heli_fsw::phase::Phase;
    use heli_fsw::streams::{BaroRecord, CompassRecord, ImuRecord, ServoRecord, StateRecord};
    use heli_proto::compass::{CompassAdc, MagField};
    use heli_proto::gps::{FixType, GpsNav};
    use heli_proto::imu::ImuRepr;
    use heli_proto::scb::{Controls, PilotUplink, Pulses};
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn a_failing_channel_is_said_once_a_spell_and_again_when_it_reads() {
        let mut failing = false;
        let bad: Result<u16, &str> = Err("in_voltage3_raw: 'junk' is not a count");
        let good: Result<u16, &str> = Ok(3000);
        assert_eq!(spell_note(&mut failing, &good), None);
        assert_eq!(
            spell_note(&mut failing, &bad).as_deref(),
            Some("in_voltage3_raw: 'junk' is not a count: no reading until it can be read again")
        );
        assert_eq!(spell_note(&mut failing, &bad), None);
        assert_eq!(
            spell_note(&mut failing, &good).as_deref(),
            Some("read again")
        );
        assert_eq!(spell_note(&mut failing, &good), None);
        assert!(spell_note(&mut failing, &bad).is_some(), "a new spell");
    }

    fn close(v: &Value, expected: f64) {
        let x = v.as_f64().unwrap_or(f64::NAN);
        assert!((x - expected).abs() < 1e-9, "{v} != {expected}");
    }

    #[test]
    fn a_snapshot_carries_the_freshest_value_of_every_stream() {
        let streams = LiveStreams::default();
        let empty = snapshot(&streams, None, 5);
        assert_eq!(empty["t_us"], 5);
        assert!(empty["state"].is_null() && empty["gps"].is_null());
        streams.imu.publish(Stamped::new(
            1,
            ImuRecord {
                imu: ImuRepr {
                    rate_rps: [0.1, 0.2, 0.3],
                    accel_mps2: [0.0, 0.5, -9.8],
                    temp_c: 20.0,
                },
                repeated: false,
            },
        ));
        let nav = heli_nav::NavState {
            t_us: 2,
            att: UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3),
            vel_ned_mps: Vector3::new(1.0, 2.0, 3.0),
            pos_ned_m: Vector3::new(4.0, 5.0, -6.0),
            rate_body_rps: Vector3::new(0.01, 0.02, 0.03),
            accel_body_mps2: Vector3::zeros(),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        };
        streams.state.publish(Stamped::new(
            2,
            StateRecord {
                nav,
                phase: Phase::Landed,
                target: None,
            },
        ));
        streams.servo.publish(Stamped::new(
            3,
            ServoRecord {
                controls: Controls {
                    aileron: 0.1,
                    elevator: 0.2,
                    rudder: 0.3,
                    collective: 0.4,
                    throttle: 0.8,
                },
                rotor_rpm: 1600,
            },
        ));
        let pulses = Pulses::from_controls(&Controls::default());
        streams.uplink.publish(Stamped::new(
            4,
            PilotUplink {
                rotor_rpm: 1590,
                pulses,
                auto_mode: true,
                bypass: false,
                receiver_batt_v: 5.1,
                servo_batt_v: 4.9,
            },
        ));
        streams.gps.publish(Stamped::new(
            5,
            GpsNav {
                tow_ms: 0,
                lat_deg: 42.3,
                lon_deg: -71.1,
                alt_m: 12.0,
                vel_ned_mps: [0.5, 0.0, 0.0],
                satellites: 7,
                fix: FixType::Fix3D,
            },
        ));
        streams.baro.publish(Stamped::new(
            6,
            BaroRecord {
                pressure_mbar: 1001.5,
                alt_m: Some(3.5),
            },
        ));
        streams.compass.publish(Stamped::new(
            7,
            CompassRecord {
                adc: CompassAdc { counts: [1, 2, 3] },
                field: MagField {
                    field_gauss: [0.2, 0.0, 0.4],
                },
                heading_rad: Some(1.2),
            },
        ));
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        let mut out = Vec::new();
        core.handle(Input::Battery { volts: 12.2 }, 1_000_000, &mut out);
        streams.power.publish(power_row(&core, 1_000_000));
        streams.health.publish(*core.health());
        let v = snapshot(&streams, Some(Stamped::new(8, 12.2)), 9);
        assert_eq!(v["imu"]["rate_rps"][2], 0.3);
        assert_eq!(v["imu"]["accel_mps2"][1], 0.5);
        assert_eq!(v["state"]["phase"], "landed");
        close(&v["state"]["euler_rad"][0], 0.1);
        close(&v["state"]["euler_rad"][1], -0.2);
        close(&v["state"]["euler_rad"][2], 0.3);
        assert_eq!(v["state"]["rate_rps"], json!([0.01, 0.02, 0.03]));
        assert_eq!(v["state"]["pos_ned_m"], json!([4.0, 5.0, -6.0]));
        assert_eq!(v["state"]["vel_ned_mps"], json!([1.0, 2.0, 3.0]));
        assert_eq!(v["servo"]["commands"], json!([0.1, 0.2, 0.3, 0.4, 0.8]));
        assert_eq!(v["uplink"]["rotor_rpm"], 1590);
        assert_eq!(v["uplink"]["auto_mode"], true);
        // The fix's age, on the flight software's clock (its newest estimate's stamp), not
        // the telemetry thread's: a GPS gone silent ages while the estimate goes on.
        let state = streams.state.latest().map(|s| s.value).unwrap();
        streams.state.publish(Stamped::new(1_500_005, state));
        let aged = snapshot(&streams, None, 9);
        close(&aged["gps"]["age_s"], 1.5);
        assert_eq!(v["uplink"]["bypass"], false);
        assert_eq!(v["uplink"]["receiver_batt_v"], 5.1);
        assert_eq!(v["uplink"]["servo_batt_v"], 4.9);
        assert_eq!(
            v["uplink"]["pulses_us"],
            json!([
                pulses.aileron_us,
                pulses.elevator_us,
                pulses.rudder_us,
                pulses.collective_us,
                pulses.throttle_us
            ])
        );
        assert_eq!(v["gps"]["satellites"], 7);
        assert_eq!(v["gps"]["fix_3d"], true);
        assert_eq!(v["gps"]["alt_m"], 12.0);
        assert_eq!(v["gps"]["lat_deg"], 42.3);
        assert_eq!(v["gps"]["lon_deg"], -71.1);
        assert_eq!(v["baro"]["pressure_mbar"], 1001.5);
        assert_eq!(v["baro"]["alt_m"], 3.5);
        assert_eq!(v["compass"]["heading_rad"], 1.2);
        assert_eq!(v["compass"]["field_gauss"], json!([0.2, 0.0, 0.4]));
        assert_eq!(v["battery_v"], 12.2);
        let flight = &v["power"]["batteries"][0];
        assert_eq!(flight["name"], "flight");
        close(
            &v["battery_remaining"],
            flight["percent"].as_f64().unwrap_or(0.0) / 100.0,
        );
        assert_eq!(v["health"][0]["device"], "imu");
        assert_eq!(v["health"][0]["state"], "waiting");
        assert_eq!(
            v["published"],
            json!({"imu": 1, "state": 1, "servo": 1, "uplink": 1, "gps": 1, "baro": 1, "compass": 1})
        );
    }

    #[test]
    fn an_estimate_that_stopped_coming_is_not_sent_on_but_the_phase_now_is() {
        let streams = LiveStreams::default();
        let nav = heli_nav::NavState {
            t_us: 1_000_000,
            att: UnitQuaternion::identity(),
            vel_ned_mps: Vector3::new(9.9, 0.0, 0.0),
            pos_ned_m: Vector3::zeros(),
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: Vector3::zeros(),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        };
        streams.state.publish(Stamped::new(
            1_000_000,
            StateRecord {
                nav,
                phase: Phase::Landed,
                target: None,
            },
        ));
        streams
            .gps
            .publish(Stamped::new(1_000_000, GpsNav::default()));
        streams.phase.publish(Phase::BlindDescent);
        let at = |now_us: u64| snapshot(&streams, None, now_us);
        // Half a second on, the estimate is still the helicopter's state.
        let v = at(1_000_000 + STATE_CURRENT_US);
        assert_eq!(v["state"]["vel_ned_mps"][0], 9.9);
        assert_eq!(v["phase"], "blind-descent");
        // Beyond, it is not sent on; the phase and the GPS's growing age are.
        let v = at(1_000_001 + STATE_CURRENT_US);
        assert!(v["state"].is_null(), "{}", v["state"]);
        assert_eq!(v["phase"], "blind-descent");
        let v = at(56_000_000);
        assert!(v["state"].is_null());
        close(&v["gps"]["age_s"], 55.0);
        // Before any flight core has spoken: no phase.
        assert!(snapshot(&LiveStreams::default(), None, 1)["phase"].is_null());
    }

    #[test]
    fn a_lapse_between_two_reports_is_counted_though_the_device_is_ok_again() {
        let streams = LiveStreams::default();
        let mut health = heli_fsw::health::Health::default();
        let imu = health.monitor_mut(Device::Imu);
        imu.arm(0);
        let _ = imu.sample(10_000);
        // 40 ms without a packet: late; the next packet makes it ok again.
        let _ = imu.check(50_000);
        let _ = imu.sample(55_000);
        streams.health.publish(health);
        let v = snapshot(&streams, None, 60_000);
        assert_eq!(v["health"][0]["device"], "imu");
        assert_eq!(v["health"][0]["state"], "ok");
        assert_eq!(v["health"][0]["lapses"], 1);
        assert_eq!(v["health"][1]["lapses"], 0);
    }

    #[test]
    fn the_power_row_lists_each_pack_read_and_the_hot_swaps_times() {
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        let mut out = Vec::new();
        let row = power_row(&core, 0);
        assert!(row.batteries.is_empty() && row.source.is_none());
        core.handle(
            Input::PowerSource(heli_power::PowerSource::Ground),
            0,
            &mut out,
        );
        core.handle(
            Input::PowerSource(heli_power::PowerSource::Flight),
            30_000_000,
            &mut out,
        );
        core.handle(Input::Battery { volts: 12.0 }, 31_000_000, &mut out);
        let mut pilot = PilotUplink {
            rotor_rpm: 0,
            pulses: Pulses::from_controls(&Controls::default()),
            auto_mode: false,
            bypass: false,
            receiver_batt_v: 5.0,
            servo_batt_v: 4.9,
        };
        core.handle(Input::Uplink(pilot), 31_000_000, &mut out);
        pilot.servo_batt_v = 4.8;
        core.handle(Input::Uplink(pilot), 31_100_000, &mut out);
        let row = power_row(&core, 90_000_000);
        let names: Vec<_> = row.batteries.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["flight", "receiver", "servo"]);
        let state = core
            .power()
            .state(heli_fsw::core::power::Battery::Flight)
            .unwrap_or_else(|| panic!("read"));
        let flight = &row.batteries[0];
        assert_eq!(flight.volts, 12.0);
        assert!((flight.percent - 100.0 * state.soc).abs() < 1e-9);
        assert!((flight.minutes_left - state.time_left_s / 60.0).abs() < 1e-9);
        assert_eq!(flight.level, state.level.name());
        assert_eq!(row.source.as_deref(), Some("flight"));
        assert!((row.flight_s - 60.0).abs() < 1e-9 && (row.ground_s - 30.0).abs() < 1e-9);
    }

    #[test]
    fn the_links_default_levels_are_the_gauges() {
        // A ground that gets no level judges the whole percentage at these: they must be
        // the gauge's defaults, which the vehicle judges at.
        let levels = heli_power::Levels::default();
        assert!((100.0 * levels.warning - heli_link::telemetry::WARNING_PERCENT).abs() < 1e-9);
        assert!((100.0 * levels.critical - heli_link::telemetry::CRITICAL_PERCENT).abs() < 1e-9);
    }
}
