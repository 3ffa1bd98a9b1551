//! Worked examples of the filter's algebra: each test sets up a case small enough to work out
//! by hand (a diagonal covariance, one measurement, a helicopter moving straight and level)
//! and checks the filter's numbers against it exactly. The accuracy tests (`tests.rs`) show
//! that the filter converges; these show that each term is the one the equations call for,
//! so that a changed sign, gain or index shows as a wrong number.

use super::*;

/// The calibration of an IMU sitting level and still: no gyro bias, gravity only.
pub(super) fn level_biases() -> ImuBiases {
    ImuBiases {
        gyro_rps: Vector3::zeros(),
        mean_accel_mps2: Vector3::new(0.0, 0.0, -GRAVITY_MPS2),
        samples: 100,
    }
}

/// A level IMU reading: no rotation, the specific force of gravity only.
fn level_imu() -> ImuRepr {
    ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -GRAVITY_MPS2],
        temp_c: 25.0,
    }
}

fn origin() -> GeoOrigin {
    GeoOrigin {
        lat_deg: 42.36,
        lon_deg: -71.09,
        alt_m: 10.0,
    }
}

fn fix_at(ned: Vector3<f64>, vel: Vector3<f64>) -> GpsNav {
    let (lat_deg, lon_deg, alt_m) = origin().to_geodetic([ned.x, ned.y, ned.z]);
    GpsNav {
        tow_ms: 0,
        lat_deg,
        lon_deg,
        alt_m,
        vel_ned_mps: [vel.x, vel.y, vel.z],
        satellites: 8,
        fix: FixType::Fix3D,
    }
}

/// A filter initialised at rest at the origin at `t_us`, heading north, covariance diagonal.
fn at_rest(t_us: u64) -> Navigator {
    let mut nav = Navigator::new(NavConfig::default());
    nav.set_origin(origin());
    nav.initialise(t_us, &level_biases());
    nav
}

/// One measurement of the north position.
fn north_row() -> SMatrix<f64, 1, N_ERR> {
    let mut h = SMatrix::<f64, 1, N_ERR>::zeros();
    h[(0, ix::POS)] = 1.0;
    h
}

#[test]
fn the_gate_is_gate_sigmas_standard_deviations_of_the_innovation() {
    // North position variance 3.5 m², measurement variance 0.5 m²: S = 4 m², σ = 2 m, and
    // the default 5σ gate is 10 m.
    let mut nav = at_rest(0);
    nav.cov[(ix::POS, ix::POS)] = 3.5;
    let r = SVector::<f64, 1>::new(0.5);
    let mut inside = nav.clone();
    assert!(inside.update(&SVector::<f64, 1>::new(5.0), &north_row(), &r));
    // The test ratio is y² / (gate² S) = 25 / (25 · 4).
    assert_eq!(inside.last_test_ratio, 0.25);
    // The Kalman gain is P / S = 0.875: the estimate moves 0.875 of the way.
    assert_eq!(inside.state().map(|s| s.pos_ned_m.x), Some(4.375));
    // The variance after it is P R / S = 0.4375 m².
    assert!((inside.cov[(ix::POS, ix::POS)] - 0.4375).abs() < 1e-15);
    // Exactly on the gate (ratio 1) is fused; just beyond it is refused and changes nothing.
    let mut edge = nav.clone();
    assert!(edge.update(&SVector::<f64, 1>::new(10.0), &north_row(), &r));
    assert_eq!(edge.last_test_ratio, 1.0);
    assert_eq!(edge.state().map(|s| s.pos_ned_m.x), Some(8.75));
    let mut beyond = nav.clone();
    assert!(!beyond.update(&SVector::<f64, 1>::new(10.001), &north_row(), &r));
    assert!(beyond.last_test_ratio > 1.0);
    assert_eq!(beyond.state().map(|s| s.pos_ned_m.x), Some(0.0));
    assert_eq!(beyond.cov, nav.cov);
}

#[test]
fn a_near_perfect_measurement_leaves_the_variance_at_its_floor_and_the_covariance_symmetric() {
    // A measurement of variance 1e-20 m² would make the north position certain: the filter
    // keeps 1e-12 m² so that it can still learn, and the matrix exactly symmetric.
    let mut nav = at_rest(0);
    for k in 1..=25u64 {
        nav.propagate(k * 20_000, &level_imu(), &level_imu());
    }
    let r = SVector::<f64, 1>::new(1e-20);
    assert!(nav.update(&SVector::<f64, 1>::new(0.01), &north_row(), &r));
    assert_eq!(nav.cov[(ix::POS, ix::POS)], 1e-12);
    assert_eq!(nav.cov, nav.cov.transpose());
    assert!(nav.cov.diagonal().iter().all(|&d| d >= 1e-12));
}

#[test]
fn a_gps_fix_corrects_each_of_its_five_components_by_its_own_gain() {
    // Fresh filter, diagonal covariance, no propagation yet: each measured component moves
    // by P / (P + R) of its innovation and nothing else moves.
    let c = NavConfig::default();
    let mut nav = at_rest(0);
    let innovation_pos = Vector3::new(1.0, -0.6, 3.0);
    let innovation_vel = Vector3::new(0.2, -0.1, 0.3);
    // Arrives one latency after the start: valid at the start, where the state is.
    nav.fuse_gps(1_000_000, &fix_at(innovation_pos, innovation_vel));
    assert_eq!(nav.stats().gps_fused, 1);
    let s = nav
        .state()
        .copied()
        .unwrap_or_else(|| panic!("initialised"));
    let (p_pos, p_vel) = (
        c.initial_pos_sigma_m.powi(2),
        c.initial_vel_sigma_mps.powi(2),
    );
    let (r_pos, r_vel) = (c.gps_pos_sigma_m.powi(2), c.gps_vel_sigma_mps.powi(2));
    let k_pos = p_pos / (p_pos + r_pos);
    let k_vel = p_vel / (p_vel + r_vel);
    // The vertical velocity is trusted a quarter as much (4 times the variance).
    let k_vel_down = p_vel / (p_vel + 4.0 * r_vel);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(close(s.pos_ned_m.x, k_pos * 1.0), "{:?}", s.pos_ned_m);
    assert!(close(s.pos_ned_m.y, k_pos * -0.6), "{:?}", s.pos_ned_m);
    assert_eq!(s.pos_ned_m.z, 0.0, "the GPS's height is not used");
    assert!(close(s.vel_ned_mps.x, k_vel * 0.2), "{:?}", s.vel_ned_mps);
    assert!(close(s.vel_ned_mps.y, k_vel * -0.1), "{:?}", s.vel_ned_mps);
    assert!(
        close(s.vel_ned_mps.z, k_vel_down * 0.3),
        "{:?}",
        s.vel_ned_mps
    );
    assert!(s.att.angle() < 1e-15, "{:?}", s.att);
    assert_eq!(s.gyro_bias_rps, Vector3::zeros());
    assert_eq!(s.accel_bias_mps2, Vector3::zeros());
}

/// A helicopter flying straight and level at `vel` from the origin, its filter started in
/// the air at time 0 and propagated every 20 ms to `until_us` on a perfect IMU.
fn cruising(vel: Vector3<f64>, until_us: u64) -> Navigator {
    let mut nav = Navigator::new(NavConfig::default());
    nav.set_origin(origin());
    nav.initialise_in_air(0, &level_biases(), Some(vel));
    let mut t = 0;
    while t < until_us {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
    }
    nav
}

#[test]
fn a_delayed_fix_is_compared_with_the_state_carried_to_its_time_of_validity() {
    // The fix is valid 5 ms after a propagation (at 1.245 s) and says exactly where the
    // helicopter was then: the innovation is zero, and fusing it changes nothing.
    let vel = Vector3::new(2.0, 1.5, -0.5);
    let mut nav = cruising(vel, 1_600_000);
    let truth_valid = vel * 1.245;
    nav.fuse_gps(2_245_000, &fix_at(truth_valid, vel));
    assert_eq!(nav.stats().gps_fused, 1);
    assert_eq!(nav.stats().gps_rejected, 0);
    let s = nav
        .state()
        .copied()
        .unwrap_or_else(|| panic!("initialised"));
    assert_eq!(s.t_us, 1_600_000, "replayed to the present");
    let err = (s.pos_ned_m - vel * 1.6).norm();
    assert!(err < 1e-6, "position off by {err} m");
    assert!((s.vel_ned_mps - vel).norm() < 1e-9, "{:?}", s.vel_ned_mps);
}

#[test]
fn a_fix_up_to_30_ms_older_than_the_log_is_fused_on_its_oldest_state() {
    // Started at 50 ms and propagated from 70 ms: the oldest state kept is at 50 ms.
    let started_at = |valid_us: u64| {
        let mut nav = Navigator::new(NavConfig::default());
        nav.set_origin(origin());
        nav.initialise(50_000, &level_biases());
        for k in 1..=5u64 {
            nav.propagate(50_000 + k * 20_000, &level_imu(), &level_imu());
        }
        nav.fuse_gps(
            valid_us + 1_000_000,
            &fix_at(Vector3::zeros(), Vector3::zeros()),
        );
        nav.stats()
    };
    let at_30_ms = started_at(20_000);
    assert_eq!((at_30_ms.gps_fused, at_30_ms.gps_rejected), (1, 0));
    let beyond = started_at(19_999);
    assert_eq!((beyond.gps_fused, beyond.gps_rejected), (0, 1));
}

#[test]
fn the_log_of_the_past_holds_exactly_its_length() {
    let mut nav = at_rest(0);
    let len = nav.history_len;
    assert_eq!(len, (NavConfig::default().history_s * 85.0).ceil() as usize);
    for k in 1..=(len as u64 + 40) {
        nav.propagate(k * 20_000, &level_imu(), &level_imu());
        assert_eq!(nav.history.len(), (k as usize).min(len));
    }
}

#[test]
fn an_imu_sample_with_any_value_not_finite_is_not_propagated() {
    let nan_rate = ImuRepr {
        rate_rps: [0.0, f64::NAN, 0.0],
        ..level_imu()
    };
    let nan_accel = ImuRepr {
        accel_mps2: [0.0, 0.0, f64::INFINITY],
        ..level_imu()
    };
    for bad in [nan_rate, nan_accel] {
        let mut nav = at_rest(0);
        nav.propagate(20_000, &level_imu(), &bad);
        assert_eq!(nav.state().map(|s| s.t_us), Some(0), "{bad:?}");
        assert!(nav.history.is_empty());
        nav.propagate(20_000, &level_imu(), &level_imu());
        assert_eq!(nav.state().map(|s| s.t_us), Some(20_000));
    }
}

#[test]
fn the_skew_matrix_is_the_cross_product() {
    let v = Vector3::new(0.3, -1.2, 2.5);
    let w = Vector3::new(-0.7, 0.4, 1.1);
    assert!((skew(&v) * w - v.cross(&w)).norm() < 1e-15);
    assert_eq!(skew(&v).transpose(), -skew(&v));
}

#[test]
fn no_gravity_seen_by_the_calibration_gives_no_accelerometer_bias() {
    // A mean specific force of 1 m/s² or less is a dead accelerometer, not gravity plus bias.
    for z in [-1.0, -0.3, 0.0] {
        let mut nav = Navigator::new(NavConfig::default());
        nav.initialise(
            0,
            &ImuBiases {
                mean_accel_mps2: Vector3::new(0.0, 0.0, z),
                ..level_biases()
            },
        );
        assert_eq!(
            nav.state().map(|s| s.accel_bias_mps2),
            Some(Vector3::zeros())
        );
    }
}

#[test]
fn the_compass_heading_is_made_true_with_the_declination() {
    // The field points to magnetic north (x) and down; the declination is 0.1 rad east.
    let config = NavConfig {
        declination_rad: 0.1,
        ..NavConfig::default()
    };
    let mut nav = Navigator::new(config);
    nav.fuse_compass(&MagField {
        field_gauss: [0.19, 0.0, 0.48],
    });
    nav.initialise(0, &level_biases());
    let (_, _, yaw) = nav.state().map_or((0.0, 0.0, 0.0), |s| s.euler_rad());
    assert!((yaw - 0.1).abs() < 1e-12, "{yaw}");
}

#[test]
fn zero_and_negative_pressures_are_refused_and_counted() {
    let mut nav = Navigator::new(NavConfig::default());
    for p in [0.0, -5.0, f64::NAN, f64::INFINITY] {
        nav.fuse_baro(p);
    }
    assert_eq!(nav.stats().baro_rejected, 4);
    nav.fuse_baro(1000.0);
    nav.initialise(0, &level_biases());
    assert_eq!(nav.baro_reference_mbar(), Some(1000.0));
}

#[test]
fn the_reset_to_gps_comes_on_the_configured_refusal_and_takes_the_fix_carried_forward() {
    // Started at rest 6 s ago and never fused: a fix 100 m away is refused by the gate; on
    // the configured refusal in a row the position and velocity are reset to it.
    let c = NavConfig::default();
    let mut nav = at_rest(0);
    let vel = Vector3::new(1.0, -2.0, 0.5);
    let valid_pos = Vector3::new(100.0, 50.0, 0.0);
    let mut t = 0;
    while t < 6_000_000 {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
    }
    for refusal in 1..=c.gps_reset_rejections {
        for _ in 0..25 {
            t += 20_000;
            nav.propagate(t, &level_imu(), &level_imu());
        }
        // Valid 0.39 s before the present (it arrives 0.61 s from now, a latency late): 10 ms
        // after the start of the step it falls in.
        nav.fuse_gps(t + 610_000, &fix_at(valid_pos, vel));
        let stats = nav.stats();
        assert_eq!(stats.gps_fused, 0);
        if refusal < c.gps_reset_rejections {
            assert_eq!(stats.gps_resets, 0, "refusal {refusal}");
            continue;
        }
        assert_eq!(stats.gps_resets, 1);
        // Valid 0.39 s before the present: carried forward 0.39 s (level and unaccelerated,
        // on its own velocity).
        let s = nav
            .state()
            .copied()
            .unwrap_or_else(|| panic!("initialised"));
        let expected = valid_pos + vel * 0.39;
        assert!(
            (s.pos_ned_m.x - expected.x).abs() < 1e-6,
            "{:?}",
            s.pos_ned_m
        );
        assert!(
            (s.pos_ned_m.y - expected.y).abs() < 1e-6,
            "{:?}",
            s.pos_ned_m
        );
        assert!((s.vel_ned_mps - vel).norm() < 1e-9, "{:?}", s.vel_ned_mps);
        // Position and velocity knew nothing but the GPS where it was valid (its variances),
        // grown over the 0.39 s since by the propagation only.
        let (sp, sv) = (c.gps_pos_sigma_m.powi(2), c.gps_vel_sigma_mps.powi(2));
        for i in ix::VEL..ix::POS + 2 {
            let variance = if i >= ix::POS { sp } else { sv };
            let now = nav.cov[(i, i)];
            assert!(
                now >= variance && now < variance + 0.05,
                "state {i}: {now} from {variance}"
            );
        }
    }
}

#[test]
fn a_reset_on_a_fix_valid_now_takes_its_variances_and_no_correlations_and_the_next_fix_fuses() {
    // The fix arrives a latency after the last step: valid at the present state, nothing to
    // replay. Position and velocity are the GPS's, their variances its own, uncorrelated.
    let c = NavConfig::default();
    let mut nav = at_rest(0);
    let vel = Vector3::new(1.0, -2.0, 0.5);
    let mut t = 0;
    while t < 6_000_000 {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
    }
    for _ in 0..c.gps_reset_rejections {
        for _ in 0..50 {
            t += 20_000;
            nav.propagate(t, &level_imu(), &level_imu());
        }
        nav.fuse_gps(t + 1_000_000, &fix_at(Vector3::new(100.0, 50.0, 0.0), vel));
    }
    assert_eq!(nav.stats().gps_resets, 1);
    let (sp, sv) = (c.gps_pos_sigma_m.powi(2), c.gps_vel_sigma_mps.powi(2));
    for i in ix::VEL..ix::POS + 2 {
        let variance = if i >= ix::POS { sp } else { sv };
        assert_eq!(nav.cov[(i, i)], variance, "state {i}");
        for j in (0..N_ERR).filter(|&j| j != i) {
            assert_eq!(nav.cov[(i, j)], 0.0, "({i}, {j})");
            assert_eq!(nav.cov[(j, i)], 0.0, "({j}, {i})");
        }
    }
    // A second on, the next fix (valid at the reset) agrees, and is fused.
    let s = nav
        .state()
        .copied()
        .unwrap_or_else(|| panic!("initialised"));
    for _ in 0..50 {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
    }
    let fused = nav.stats().gps_fused;
    let reset_at = Vector3::new(s.pos_ned_m.x, s.pos_ned_m.y, 0.0);
    // Arriving now, a latency after the reset it was valid at.
    nav.fuse_gps(t, &fix_at(reset_at, vel));
    assert_eq!(nav.stats().gps_fused, fused + 1, "{:?}", nav.stats());
}

#[test]
fn a_reset_during_an_acceleration_takes_the_velocity_the_imu_carried_the_fix_to() {
    // Speeding up north at 3 m/s² when the reset comes: the fix, valid 0.4 s before the
    // present, gave the velocity of 0.4 s ago; the IMU has added 1.2 m/s since.
    let c = NavConfig::default();
    let mut nav = at_rest(0);
    let mut t = 0;
    while t < 6_000_000 {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
    }
    let speeding = ImuRepr {
        accel_mps2: [3.0, 0.0, -GRAVITY_MPS2],
        ..level_imu()
    };
    let vel = Vector3::new(5.0, 0.0, 0.0);
    for _ in 0..c.gps_reset_rejections {
        for _ in 0..25 {
            t += 20_000;
            nav.propagate(t, &speeding, &speeding);
        }
        nav.fuse_gps(t + 600_000, &fix_at(Vector3::new(100.0, 50.0, 0.0), vel));
    }
    assert_eq!(nav.stats().gps_resets, 1);
    let s = nav
        .state()
        .copied()
        .unwrap_or_else(|| panic!("initialised"));
    assert!(
        (s.vel_ned_mps.x - 6.2).abs() < 0.01,
        "{:?}: the fix's 5 m/s and 1.2 since",
        s.vel_ned_mps
    );
    // Where it was valid, plus 0.4 s at a speed rising from 5 to 6.2 m/s.
    assert!(
        (s.pos_ned_m.x - (100.0 + 5.0 * 0.4 + 0.5 * 3.0 * 0.16)).abs() < 0.01,
        "{:?}",
        s.pos_ned_m
    );
}

#[test]
fn started_in_the_air_it_moves_at_the_gps_velocity_with_roll_and_pitch_uncertain() {
    let c = NavConfig::default();
    let vel = Vector3::new(4.0, -1.0, 0.2);
    let mut nav = Navigator::new(c);
    nav.initialise_in_air(
        0,
        &ImuBiases {
            // Accelerating in a turn: more than gravity, which is not bias in the air.
            mean_accel_mps2: Vector3::new(0.0, 0.0, -12.0),
            ..level_biases()
        },
        Some(vel),
    );
    let s = nav
        .state()
        .copied()
        .unwrap_or_else(|| panic!("initialised"));
    assert_eq!(s.vel_ned_mps, vel);
    assert_eq!(s.accel_bias_mps2, Vector3::zeros());
    // The attitude (heading too: tilt-compensated with that levelling), the velocity and
    // the position uncertain as in the air, not as on the skids.
    let tilt = reset::IN_AIR_ATTITUDE_SIGMA_RAD * reset::IN_AIR_ATTITUDE_SIGMA_RAD;
    assert!(tilt > c.initial_heading_sigma_rad.powi(2));
    for i in 0..3 {
        assert_eq!(nav.cov[(ix::ATT + i, ix::ATT + i)], tilt);
        assert_eq!(
            nav.cov[(ix::VEL + i, ix::VEL + i)],
            reset::IN_AIR_VEL_SIGMA_MPS.powi(2)
        );
        assert_eq!(
            nav.cov[(ix::POS + i, ix::POS + i)],
            reset::IN_AIR_POS_SIGMA_M.powi(2)
        );
    }
    // Without a GPS velocity it starts at rest.
    let mut nav = Navigator::new(c);
    nav.initialise_in_air(0, &level_biases(), None);
    assert_eq!(nav.state().map(|s| s.vel_ned_mps), Some(Vector3::zeros()));
}

#[test]
fn started_again_in_the_air_it_keeps_the_ground_references_and_places_itself_where_the_fix_leads() {
    // On the skids: the altimeter's reference and the earth's field learned.
    let mut nav = Navigator::new(NavConfig::default());
    nav.set_origin(origin());
    nav.fuse_baro(1000.0);
    nav.fuse_gps(0, &fix_at(Vector3::zeros(), Vector3::zeros()));
    nav.fuse_compass(&MagField {
        field_gauss: [0.2, 0.0, 0.45],
    });
    nav.initialise(0, &level_biases());
    let field = nav.earth_field_ned;
    let reference = nav.baro_reference_mbar();
    assert!(field.is_some() && reference == Some(1000.0));
    // In the air, after a stall: a fix (1 s latency) of a helicopter at 5 m/s north, and a
    // compass read while tilted — which would teach it a wrong field.
    let vel = Vector3::new(5.0, 0.0, 0.0);
    let t_arrival = 10_000_000;
    nav.fuse_gps(t_arrival, &fix_at(Vector3::new(50.0, 0.0, -20.0), vel));
    nav.fuse_compass(&MagField {
        field_gauss: [0.0, 0.2, 0.45],
    });
    nav.fuse_baro(990.0);
    let t_us = t_arrival + 200_000;
    nav.initialise_in_air(t_us, &level_biases(), Some(vel));
    assert_eq!(nav.earth_field_ned, field);
    assert_eq!(nav.baro_reference_mbar(), reference);
    // Valid a latency before it arrived, 0.2 s before now: 1.2 s along at 5 m/s.
    let pos = nav.state().map(|s| s.pos_ned_m).unwrap_or_default();
    assert!((pos.x - 56.0).abs() < 1e-6, "{pos:?}");
    assert!((pos.z + 20.0).abs() < 1e-6, "{pos:?}");
}
