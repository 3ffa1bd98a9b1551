//! The filter against simulated truths: still, biased, delayed, lying and coasting.

use super::*;

const EARTH_FIELD: [f64; 3] = [0.19, 0.0, 0.48];

fn level_biases() -> ImuBiases {
    ImuBiases {
        gyro_rps: Vector3::zeros(),
        mean_accel_mps2: Vector3::new(0.0, 0.0, -9.81),
        samples: 8000,
    }
}

/// An IMU reading with no rotation and the given specific force.
fn imu_reading(accel_mps2: [f64; 3]) -> ImuRepr {
    ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2,
        temp_c: 25.0,
    }
}

fn origin() -> GeoOrigin {
    GeoOrigin {
        lat_deg: 42.0,
        lon_deg: -71.0,
        alt_m: 20.0,
    }
}

fn fix_at(ned: [f64; 3], vel: [f64; 3]) -> GpsNav {
    let (lat, lon, alt) = origin().to_geodetic(ned);
    GpsNav {
        tow_ms: 0,
        lat_deg: lat,
        lon_deg: lon,
        alt_m: alt,
        vel_ned_mps: vel,
        satellites: 8,
        fix: FixType::Fix3D,
    }
}

fn field_at(att: &UnitQuaternion<f64>) -> MagField {
    let b = att.inverse() * Vector3::from(EARTH_FIELD);
    MagField {
        field_gauss: [b.x, b.y, b.z],
    }
}

/// A filter initialised at rest at the origin, heading north, with baro and compass read.
fn started() -> Navigator {
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_gps(0, &fix_at([0.0; 3], [0.0; 3]));
    for _ in 0..10 {
        nav.fuse_baro(1013.25);
    }
    nav.fuse_compass(&field_at(&UnitQuaternion::identity()));
    nav.initialise(0, &level_biases());
    nav
}

/// Flies the filter for `seconds` on a helicopter sitting still (true rates zero, specific
/// force straight up), its IMU reading `gyro_bias` and `accel_bias`, with GPS (arriving
/// one second late), baro and compass all telling the truth.
fn sit_still(
    nav: &mut Navigator,
    from_us: u64,
    seconds: u64,
    gyro_bias: Vector3<f64>,
    accel_bias: Vector3<f64>,
) -> u64 {
    let imu = ImuRepr {
        rate_rps: gyro_bias.into(),
        accel_mps2: (Vector3::new(0.0, 0.0, -9.81) + accel_bias).into(),
        temp_c: 25.0,
    };
    let mut t = from_us;
    for k in 1..=seconds * 50 {
        t = from_us + k * 20_000;
        nav.propagate(t, &imu, &imu);
        if k % 10 == 0 {
            nav.fuse_baro(1013.25);
        }
        if k % 50 == 0 && t >= 1_000_000 {
            nav.fuse_gps(t, &fix_at([0.0; 3], [0.0; 3]));
        }
        if k % 3 == 0 {
            nav.fuse_compass(&field_at(&UnitQuaternion::identity()));
        }
    }
    t
}

#[test]
fn sitting_still_with_true_sensors_stays_put_and_grows_confident() {
    let mut nav = started();
    let p0 = nav.covariance().trace();
    sit_still(&mut nav, 0, 60, Vector3::zeros(), Vector3::zeros());
    let s = nav.state().copied().unwrap_or_else(|| unreachable!());
    assert!(s.pos_ned_m.norm() < 1e-6, "{:?}", s.pos_ned_m);
    assert!(s.att.angle() < 1e-6);
    assert!(nav.covariance().trace() < p0);
    assert_eq!(nav.stats().gps_rejected, 0);
    assert!(nav.stats().gps_fused >= 58);
}

#[test]
fn a_gyro_bias_the_calibration_missed_is_found() {
    let mut nav = started();
    let missed = Vector3::new(0.002, -0.0015, 0.001);
    sit_still(&mut nav, 0, 300, missed, Vector3::zeros());
    let s = nav.state().copied().unwrap_or_else(|| unreachable!());
    let err = (s.gyro_bias_rps - missed).abs();
    assert!(
        err.max() < 2e-4,
        "estimated {:?}, true {missed:?}",
        s.gyro_bias_rps
    );
    assert!(s.att.angle() < 0.01, "attitude held: {} rad", s.att.angle());
}

#[test]
fn delayed_gps_fused_at_its_time_of_validity_beats_fusing_it_as_current() {
    // The helicopter accelerates north at 1 m/s² from rest. Its GPS reports, one second
    // late, exactly where it was. The same filter told the latency is 0 (fuse as if
    // current) is dragged back toward stale positions.
    let run = |latency_s: f64| {
        let config = NavConfig {
            gps_latency_s: latency_s,
            ..NavConfig::default()
        };
        let mut nav = Navigator::new(config);
        nav.fuse_gps(0, &fix_at([0.0; 3], [0.0; 3]));
        nav.fuse_compass(&field_at(&UnitQuaternion::identity()));
        nav.initialise(0, &level_biases());
        let imu = imu_reading([1.0, 0.0, -9.81]);
        let mut worst: f64 = 0.0;
        for k in 1..=500u64 {
            let t = k * 20_000;
            nav.propagate(t, &imu, &imu);
            let t_s = t as f64 * 1e-6;
            if k % 50 == 0 && t_s >= 1.0 {
                let valid = t_s - 1.0;
                nav.fuse_gps(
                    t,
                    &fix_at([0.5 * valid * valid, 0.0, 0.0], [valid, 0.0, 0.0]),
                );
            }
            let truth = 0.5 * t_s * t_s;
            let err = nav
                .state()
                .map_or(f64::NAN, |s| (s.pos_ned_m.x - truth).abs());
            worst = worst.max(err);
        }
        worst
    };
    let delayed = run(1.0);
    let as_current = run(0.0);
    assert!(
        delayed < 0.05,
        "fused at its time of validity: worst error {delayed} m"
    );
    assert!(
        as_current > 10.0 * delayed,
        "fused as current: worst error {as_current} m"
    );
}

#[test]
fn after_a_long_coast_the_gate_gives_way_and_the_estimate_resets_to_gps() {
    let mut nav = started();
    let t = sit_still(&mut nav, 0, 5, Vector3::zeros(), Vector3::zeros());
    // 30 s without GPS on an accelerometer that lies by 1 m/s² northward: hundreds of
    // metres of drift, far outside what the covariance allows.
    let drifting = imu_reading([1.0, 0.0, -9.81]);
    let mut t = t;
    for k in 1..=1500u64 {
        t += 20_000;
        nav.propagate(t, &drifting, &drifting);
        if k % 10 == 0 {
            nav.fuse_baro(1013.25);
        }
    }
    let drift = nav.state().map_or(0.0, |s| s.pos_ned_m.xy().norm());
    assert!(drift > 100.0, "drift {drift}");
    // The GPS comes back telling the truth: refused by the gate a few times, then the
    // estimate is reset to it and fixes fuse again.
    for k in 1..=8u64 {
        for _ in 0..50 {
            t += 20_000;
            nav.propagate(t, &drifting, &drifting);
        }
        nav.fuse_gps(t, &fix_at([0.0; 3], [0.0; 3]));
        if k == 2 {
            assert_eq!(nav.stats().gps_resets, 0, "not after one or two refusals");
        }
    }
    assert_eq!(nav.stats().gps_resets, 1);
    let after = nav
        .state()
        .map_or(f64::INFINITY, |s| s.pos_ned_m.xy().norm());
    assert!(after < 20.0, "after the reset: {after} m from the GPS");
}

#[test]
fn a_lying_gps_is_rejected_and_counted() {
    let mut nav = started();
    let t = sit_still(&mut nav, 0, 5, Vector3::zeros(), Vector3::zeros());
    nav.fuse_gps(t, &fix_at([500.0, 0.0, 0.0], [0.0; 3]));
    assert_eq!(nav.stats().gps_rejected, 1);
    assert!(nav.state().map_or(1.0, |s| s.pos_ned_m.norm()) < 1e-6);
}

#[test]
fn baro_pulls_altitude_toward_the_pressure_altitude() {
    let mut nav = started();
    let target = heli_proto::baro::pressure_at_altitude_mbar(3.0, 1013.25);
    let imu = imu_reading([0.0, 0.0, -9.81]);
    for k in 1..=3000u64 {
        nav.propagate(k * 20_000, &imu, &imu);
        if k % 10 == 0 {
            nav.fuse_baro(target);
        }
    }
    let z = nav.state().map_or(0.0, |s| s.pos_ned_m.z);
    assert!((z + 3.0).abs() < 0.1, "z {z}");
}

#[test]
fn an_altimeter_that_starts_late_is_referenced_where_it_first_speaks() {
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_gps(0, &fix_at([0.0; 3], [0.0; 3]));
    nav.fuse_compass(&field_at(&UnitQuaternion::identity()));
    nav.initialise(0, &level_biases());
    let imu = imu_reading([0.0, 0.0, -9.81]);
    let p0 = 1000.0;
    for k in 1..=3000u64 {
        nav.propagate(k * 20_000, &imu, &imu);
        if k % 10 == 0 {
            let alt = if k > 100 { 4.0 } else { 0.0 };
            nav.fuse_baro(heli_proto::baro::pressure_at_altitude_mbar(alt, p0));
        }
    }
    assert_eq!(nav.baro_reference_mbar(), Some(p0));
    let z = nav.state().map_or(0.0, |s| s.pos_ned_m.z);
    assert!((z + 4.0).abs() < 0.1, "z {z}");
}

#[test]
fn without_a_compass_at_start_the_first_reading_sets_the_heading() {
    let mut nav = Navigator::new(NavConfig::default());
    nav.initialise(0, &level_biases());
    let east = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2);
    nav.fuse_compass(&field_at(&east));
    let (_, _, yaw) = nav.state().map(NavState::euler_rad).unwrap_or_default();
    assert!(
        (yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
        "yaw {yaw}"
    );
}

#[test]
fn magnetometer_jacobian_matches_finite_differences() {
    let att = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    let earth = Vector3::from(EARTH_FIELD);
    let h = |q: &UnitQuaternion<f64>| q.inverse() * earth;
    let analytic = att.inverse().to_rotation_matrix().into_inner() * skew(&earth);
    for j in 0..3 {
        let mut d = Vector3::zeros();
        d[j] = 1e-7;
        let numeric = (h(&(UnitQuaternion::from_scaled_axis(d) * att)) - h(&att)) / 1e-7;
        for i in 0..3 {
            assert!((numeric[i] - analytic[(i, j)]).abs() < 1e-5, "({i},{j})");
        }
    }
}

#[test]
fn wrap_pi_wraps() {
    assert!((wrap_pi(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    assert!((wrap_pi(-0.5) + 0.5).abs() < 1e-12);
}

#[test]
fn calibration_seeds_the_accelerometer_bias_it_can_see() {
    let mut nav = Navigator::new(NavConfig::default());
    let biases = ImuBiases {
        gyro_rps: Vector3::new(0.01, 0.0, 0.0),
        mean_accel_mps2: Vector3::new(0.0, 0.0, -9.91),
        samples: 8000,
    };
    nav.initialise(0, &biases);
    let s = nav.state().copied().unwrap_or_else(|| unreachable!());
    assert!(
        (s.accel_bias_mps2.z + 0.1).abs() < 1e-9,
        "{:?}",
        s.accel_bias_mps2
    );
    assert_eq!(s.gyro_bias_rps, biases.gyro_rps);
}

#[test]
fn a_fix_from_before_the_heading_was_aligned_cannot_undo_it() {
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_gps(0, &fix_at([0.0; 3], [0.0; 3]));
    nav.initialise(0, &level_biases());
    let imu = imu_reading([0.0, 0.0, -9.81]);
    let east = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2);
    let mut t = 0;
    for k in 1..=1500u64 {
        t = k * 20_000;
        nav.propagate(t, &imu, &imu);
        if k == 25 {
            nav.fuse_compass(&field_at(&east)); // the compass first speaks at 0.5 s
        } else if k > 25 && k % 3 == 0 {
            nav.fuse_compass(&field_at(&east));
        }
        if k % 50 == 0 {
            nav.fuse_gps(t, &fix_at([0.0; 3], [0.0; 3]));
        }
    }
    let (_, _, yaw) = nav.state().map(NavState::euler_rad).unwrap_or_default();
    assert!(
        (yaw - std::f64::consts::FRAC_PI_2).abs() < 0.01,
        "yaw {yaw} at t={t}"
    );
    assert!(nav.stats().compass_rejected < 5, "{:?}", nav.stats());
    // The fix valid at 0 s (before the alignment) was refused as too old.
    assert!(nav.stats().gps_rejected >= 1);
}

#[test]
fn a_fix_older_than_the_log_is_refused_and_the_log_is_bounded() {
    let config = NavConfig {
        history_s: f64::INFINITY,
        ..NavConfig::default()
    };
    let mut nav = Navigator::new(config);
    nav.fuse_gps(0, &fix_at([0.0; 3], [0.0; 3]));
    nav.fuse_compass(&field_at(&UnitQuaternion::identity()));
    nav.initialise(0, &level_biases());
    let imu = imu_reading([0.0, 0.0, -9.81]);
    for k in 1..=1000u64 {
        nav.propagate(k * 20_000, &imu, &imu);
    }
    assert!(nav.history.len() <= (11.0 * 75.0) as usize + 1);
    // Arrives at 20 s, valid at 19 s: inside the log. Arrives at 20 s claiming 15 s of
    // latency is impossible here; a fix valid before the oldest entry is refused.
    let before = nav.stats().gps_rejected;
    nav.fuse_gps(20_000_000, &fix_at([0.0; 3], [0.0; 3]));
    assert_eq!(nav.stats().gps_rejected, before);
    nav.fuse_gps(2_000_000, &fix_at([0.0; 3], [0.0; 3]));
    assert_eq!(nav.stats().gps_rejected, before + 1);
}
