use super::*;

fn full() -> Telemetry {
    Telemetry {
        t_us: 1,
        phase: None,
        imu: Some(ImuRow {
            rate_rps: [0.1, 0.0, 0.0],
            accel_mps2: [0.0, 0.0, -9.80665],
        }),
        state: Some(StateRow {
            phase: "hold".into(),
            euler_rad: [0.1, -0.1, 1.0],
            rate_rps: [0.0; 3],
            pos_ned_m: [1.0, 2.0, -10.0],
            vel_ned_mps: [0.5, 0.0, 0.0],
        }),
        uplink: Some(UplinkRow {
            pulses_us: [1500; 5],
            auto_mode: true,
            bypass: false,
            rotor_rpm: 1600,
            receiver_batt_v: 4.8,
            servo_batt_v: 4.9,
        }),
        servo: Some(ServoRow {
            commands: [0.0, 1.0, -1.0, 0.5, 0.0],
        }),
        gps: Some(GpsRow {
            lat_deg: 42.36,
            lon_deg: -71.09,
            alt_m: 20.0,
            vel_ned_mps: [0.0, 1.0, 0.0],
            satellites: 8,
            fix_3d: true,
            age_s: 0.25,
        }),
        baro: Some(BaroRow {
            pressure_mbar: 1013.0,
            alt_m: Some(10.0),
        }),
        compass: Some(CompassRow {
            field_gauss: [0.2, 0.0, 0.4],
            heading_rad: Some(1.0),
        }),
        battery_v: Some(12.3),
        battery_remaining: None,
        power: None,
        origin: Some([42.36, -71.09, 15.0]),
        health: vec![
            DeviceHealth {
                device: "imu".into(),
                state: "ok".into(),
                lapses: 0,
            },
            DeviceHealth {
                device: "gps".into(),
                state: "silent".into(),
                lapses: 0,
            },
        ],
    }
}

#[test]
fn every_telemetry_message_is_made_from_a_full_snapshot() {
    for id in TELEMETRY_MESSAGES
        .iter()
        .filter(|&&id| id != HEARTBEAT_DATA::ID)
    {
        assert!(message(*id, &full(), 10).is_some(), "message {id}");
    }
}

#[test]
fn nothing_is_made_before_its_stream_has_data() {
    let empty = Telemetry::default();
    for id in TELEMETRY_MESSAGES {
        if id != SYS_STATUS_DATA::ID {
            assert!(message(id, &empty, 0).is_none(), "message {id}");
        }
    }
}

#[test]
fn the_estimate_is_healthy_only_while_current_and_flown_on() {
    let ahrs = MavSysStatusSensor::MAV_SYS_STATUS_AHRS;
    let health = |t: &Telemetry| match message(SYS_STATUS_DATA::ID, t, 0) {
        Some(MavMessage::SYS_STATUS(s)) => (
            s.onboard_control_sensors_present.contains(ahrs),
            s.onboard_control_sensors_health.contains(ahrs),
        ),
        other => panic!("no SYS_STATUS: {other:?}"),
    };
    // Current and holding: present and healthy.
    assert_eq!(health(&full()), (true, true));
    // The flight core's phase now rules over the last estimate's.
    for lost in ["calibrating", "blind-descent"] {
        let t = Telemetry {
            phase: Some(lost.into()),
            ..full()
        };
        assert_eq!(health(&t), (true, false), "{lost}");
    }
    // The ground failsafe of a transmitter lost on the skids, the estimate running: healthy.
    let t = Telemetry {
        phase: Some("ground-failsafe".into()),
        ..full()
    };
    assert_eq!(health(&t), (true, true));
    // An estimate that stopped coming (no state row) is not healthy, though the IMU is there:
    // in the ground failsafe of a lost estimate too.
    for phase in ["hold", "ground-failsafe"] {
        let t = Telemetry {
            phase: Some(phase.into()),
            state: None,
            ..full()
        };
        assert_eq!(health(&t), (true, false), "{phase}");
    }
    let t = Telemetry {
        phase: Some("hold".into()),
        state: None,
        ..full()
    };
    assert_eq!(phase_now(&t), Some("hold"));
    assert_eq!(phase_now(&full()), Some("hold"), "from the state row");
    assert_eq!(phase_now(&Telemetry::default()), None);
}

#[test]
fn units_are_mavlinks() {
    let Some(MavMessage::SCALED_IMU(imu)) = message(SCALED_IMU_DATA::ID, &full(), 0) else {
        panic!()
    };
    assert_eq!(imu.zacc, -1000);
    assert_eq!(imu.xgyro, 100);
    let Some(MavMessage::SERVO_OUTPUT_RAW(s)) = message(SERVO_OUTPUT_RAW_DATA::ID, &full(), 0)
    else {
        panic!()
    };
    assert_eq!((s.servo2_raw, s.servo3_raw), (2000, 1000));
    let Some(MavMessage::SYS_STATUS(st)) = message(SYS_STATUS_DATA::ID, &full(), 0) else {
        panic!()
    };
    assert!(
        st.onboard_control_sensors_health
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO)
    );
    assert!(
        !st.onboard_control_sensors_health
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS)
    );
    assert!(
        st.onboard_control_sensors_present
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS)
    );
    assert_eq!(st.voltage_battery, 12_300);
    // The GPS message carries its fix's time (0.25 s before the snapshot), not the send time.
    let Some(MavMessage::GPS_RAW_INT(g)) = message(GPS_RAW_INT_DATA::ID, &full(), 10_000) else {
        panic!()
    };
    assert_eq!(g.time_usec, 9_750_000);
    // The estimate's origin, as MAVLink's local frame's.
    let Some(MavMessage::GPS_GLOBAL_ORIGIN(o)) = message(GPS_GLOBAL_ORIGIN_DATA::ID, &full(), 0)
    else {
        panic!()
    };
    assert_eq!(
        (o.latitude, o.longitude, o.altitude),
        (423_600_000, -710_900_000, 15_000)
    );
}

#[test]
fn telemetry_round_trips_as_json() {
    let text = serde_json::to_string(&full()).unwrap();
    assert_eq!(serde_json::from_str::<Telemetry>(&text).unwrap(), full());
}

/// The power values sent with the batteries, by name.
fn named_values(t: &Telemetry) -> Vec<(String, f32)> {
    power_values(t, 5)
        .iter()
        .filter_map(|m| match m {
            MavMessage::NAMED_VALUE_FLOAT(v) => {
                Some((v.name.to_str().unwrap_or("").to_string(), v.value))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn the_gauges_go_out_as_battery_remaining_and_named_values() {
    let mut t = full();
    assert!(power_values(&t, 5).is_empty(), "no gauge, no values");
    let row = |name: &str, percent: f64, minutes_left: f64| BatteryRow {
        name: name.into(),
        volts: 5.0,
        percent,
        minutes_left,
        level: "good".into(),
        draining_abnormally: false,
    };
    t.power = Some(PowerRow {
        batteries: vec![row("receiver", 80.4, 100.0), row("servo", 55.0, 40.0)],
        source: Some("ground".into()),
        flight_s: 0.0,
        ground_s: 90.0,
    });
    let remaining: Vec<i8> = board_batteries(&t)
        .iter()
        .filter_map(|m| match m {
            MavMessage::BATTERY_STATUS(b) => Some(b.battery_remaining),
            _ => None,
        })
        .collect();
    assert_eq!(remaining, [80, 55]);
    let values = named_values(&t);
    // No flight pack read: its minutes are left out, not sent as a made-up number.
    assert_eq!(
        values,
        [
            ("RTXB_MIN".to_string(), 100.0),
            ("SBAT_MIN".to_string(), 40.0),
            ("PWR_FLIGHT".to_string(), 0.0),
            ("PWR_FLT_S".to_string(), 0.0),
            ("PWR_GND_S".to_string(), 90.0),
            ("RTXB_LVL".to_string(), 0.0),
            ("SBAT_LVL".to_string(), 0.0),
        ]
    );
}

/// The telemetry with a flight pack's gauge row at `percent` with the vehicle's `level`.
fn with_flight_pack(percent: f64, level: &str) -> Telemetry {
    let mut t = full();
    t.battery_remaining = Some(percent / 100.0);
    t.power = Some(PowerRow {
        batteries: vec![BatteryRow {
            name: "flight".into(),
            volts: 11.6,
            percent,
            minutes_left: 3.0,
            level: level.into(),
            draining_abnormally: false,
        }],
        source: None,
        flight_s: 0.0,
        ground_s: 0.0,
    });
    t
}

#[test]
fn each_pack_goes_out_with_its_charge_and_the_vehicles_own_level() {
    // Found by the operator-truth test: the vehicle's good 33.46 % goes out as a whole 33,
    // which a ground judging the number by the same levels shows red. The charge goes out
    // as it is and the level beside it, the vehicle's verdict — a warning latched while
    // the charge bounced back to 34.2 % as well.
    for (percent, level, sent) in [
        (33.46, "good", 33),
        (34.2, "warning", 34),
        (15.4, "warning", 15),
        (16.1, "critical", 16),
        (72.6, "good", 73),
    ] {
        let t = with_flight_pack(percent, level);
        let sys = match message(SYS_STATUS_DATA::ID, &t, 0) {
            Some(MavMessage::SYS_STATUS(s)) => s.battery_remaining,
            other => panic!("{other:?}"),
        };
        let bat = match message(BATTERY_STATUS_DATA::ID, &t, 0) {
            Some(MavMessage::BATTERY_STATUS(b)) => b.battery_remaining,
            other => panic!("{other:?}"),
        };
        assert_eq!([sys, bat], [sent, sent], "{percent} % {level}");
        let levels: Vec<(String, f32)> = named_values(&t)
            .into_iter()
            .filter(|(name, _)| name.ends_with("_LVL"))
            .collect();
        assert_eq!(levels.len(), 1, "{levels:?}");
        assert_eq!(levels[0].0, "FLT_LVL");
        assert_eq!(
            level_of_code(f64::from(levels[0].1)),
            Some(level),
            "{percent} % {level}"
        );
    }
    for level in ["good", "warning", "critical"] {
        assert_eq!(level_code(level).and_then(level_of_code), Some(level));
    }
    assert_eq!(level_code("unknown"), None);
    assert_eq!(level_of_code(0.5), None);
    // A ground without the level judges the number at the default levels, at or below each.
    assert_eq!(level_of_percent(100.0 / 3.0), "warning");
    assert_eq!(level_of_percent(33.34), "good");
    assert_eq!(level_of_percent(15.0), "critical");
    assert_eq!(level_of_percent(15.01), "warning");
    // No gauge row: the bare charge, rounded.
    let mut t = full();
    t.battery_remaining = Some(0.3346);
    match message(SYS_STATUS_DATA::ID, &t, 0) {
        Some(MavMessage::SYS_STATUS(s)) => assert_eq!(s.battery_remaining, 33),
        other => panic!("{other:?}"),
    }
}
