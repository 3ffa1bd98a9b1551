//! Component tests of the filter's parts through its public API: the initialisation from the
//! calibration, the GPS outage, the origin, the health report, a fix refused before fusion,
//! the geodetic frame.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::arithmetic_side_effects
)]

use heli_nav::{GeoOrigin, ImuBiases, NavConfig, Navigator};
use heli_proto::gps::{FixType, GpsNav};
use nalgebra::Vector3;

fn biases(accel: Vector3<f64>) -> ImuBiases {
    ImuBiases {
        gyro_rps: Vector3::new(0.001, -0.002, 0.003),
        mean_accel_mps2: accel,
        samples: 100,
    }
}

fn fix(satellites: u8) -> GpsNav {
    GpsNav {
        tow_ms: 0,
        lat_deg: 42.3581,
        lon_deg: -71.0966,
        alt_m: 5.0,
        vel_ned_mps: [0.0; 3],
        satellites,
        fix: FixType::Fix3D,
    }
}

#[test]
fn the_estimate_starts_level_or_tilted_as_gravity_says_with_the_biases_found() {
    let mut nav = Navigator::new(NavConfig::default());
    // Rolled 0.2 rad right and pitched 0.1 rad up, reading 1 g plus 0.1 m/s² of bias.
    let (roll, pitch) = (0.2f64, 0.1f64);
    let g = 9.81 + 0.1;
    let f = Vector3::new(
        g * pitch.sin(),
        -g * roll.sin() * pitch.cos(),
        -g * roll.cos() * pitch.cos(),
    );
    nav.initialise(7, &biases(f));
    let s = nav.state().unwrap();
    let (r, p, y) = s.euler_rad();
    assert!(
        (r - roll).abs() < 1e-9 && (p - pitch).abs() < 1e-9 && y.abs() < 1e-12,
        "{r} {p}"
    );
    assert_eq!(s.t_us, 7);
    assert_eq!(s.gyro_bias_rps, Vector3::new(0.001, -0.002, 0.003));
    // The reading beyond 1 g along gravity is accelerometer bias.
    assert!(
        (s.accel_bias_mps2 - f * (0.1 / g)).norm() < 1e-9,
        "{:?}",
        s.accel_bias_mps2
    );
    assert_eq!(s.vel_ned_mps, Vector3::zeros());
    // A reading under 1 m/s² (no accelerometer) gives no bias.
    let mut nav = Navigator::new(NavConfig::default());
    nav.initialise(0, &biases(Vector3::new(0.0, 0.0, -0.5)));
    assert_eq!(nav.state().unwrap().accel_bias_mps2, Vector3::zeros());
    // The covariance starts with the configured uncertainties.
    let c = NavConfig::default();
    let p = nav.covariance();
    assert!((p[(3, 3)] - c.initial_vel_sigma_mps.powi(2)).abs() < 1e-12);
    assert!((p[(6, 6)] - c.initial_pos_sigma_m.powi(2)).abs() < 1e-12);
}

#[test]
fn the_altimeters_reference_is_the_mean_pressure_before_the_start() {
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_baro(1000.0);
    nav.fuse_baro(1002.0);
    assert_eq!(nav.baro_reference_mbar(), None);
    nav.initialise(0, &biases(Vector3::new(0.0, 0.0, -9.81)));
    assert_eq!(nav.baro_reference_mbar(), Some(1001.0));
}

#[test]
fn a_gps_outage_counts_from_the_last_fix_or_the_start() {
    let mut nav = Navigator::new(NavConfig::default());
    assert!(!nav.gps_outage(100_000_000), "no estimate, no outage");
    nav.initialise(1_000_000, &biases(Vector3::new(0.0, 0.0, -9.81)));
    assert!(!nav.gps_outage(4_000_000), "3 s is not more than 3 s");
    assert!(nav.gps_outage(4_000_001));
    nav.fuse_gps(5_000_000, &fix(8));
    nav.fuse_gps(5_200_000, &fix(8));
    assert_eq!(nav.stats().last_gps_fused_us, 5_200_000);
    assert!(!nav.gps_outage(8_200_000));
    assert!(nav.gps_outage(8_200_001));
}

#[test]
fn a_fix_that_cannot_be_used_is_refused_before_fusion() {
    let good = fix(8);
    for bad in [
        GpsNav {
            fix: FixType::Fix2D,
            ..good
        },
        GpsNav {
            satellites: 3,
            ..good
        },
        GpsNav {
            lat_deg: f64::NAN,
            ..good
        },
        GpsNav {
            lon_deg: f64::INFINITY,
            ..good
        },
        GpsNav {
            alt_m: f64::NAN,
            ..good
        },
        GpsNav {
            vel_ned_mps: [0.0, 0.0, f64::NAN],
            ..good
        },
    ] {
        let mut nav = Navigator::new(NavConfig::default());
        nav.initialise(0, &biases(Vector3::new(0.0, 0.0, -9.81)));
        nav.fuse_gps(100_000, &bad);
        assert_eq!(nav.stats().gps_rejected, 1, "{bad:?}");
        assert_eq!(nav.stats().gps_fused, 0);
        assert_eq!(nav.origin(), None);
    }
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_gps(
        100_000,
        &GpsNav {
            satellites: 4,
            ..good
        },
    );
    assert_eq!(nav.stats().gps_rejected, 0, "four satellites are enough");
}

#[test]
fn the_frames_origin_is_the_first_fix_and_a_restart_keeps_the_old_one() {
    let mut nav = Navigator::new(NavConfig::default());
    let origin = GeoOrigin {
        lat_deg: 10.0,
        lon_deg: 20.0,
        alt_m: 30.0,
    };
    nav.set_origin(origin);
    assert_eq!(nav.origin(), Some(origin));
    nav.set_origin(GeoOrigin {
        lat_deg: 0.0,
        ..origin
    });
    assert_eq!(nav.origin(), Some(origin), "an origin set is kept");
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_gps(0, &fix(8));
    assert_eq!(nav.origin().map(|o| o.lat_deg), Some(42.3581));
}

#[test]
fn the_health_report_says_how_long_since_each_aid() {
    let mut nav = Navigator::new(NavConfig::default());
    let h = nav.health(5_000_000);
    assert_eq!(
        (h.since_gps_s, h.since_baro_s, h.since_compass_s),
        (None, None, None)
    );
    nav.initialise(0, &biases(Vector3::new(0.0, 0.0, -9.81)));
    nav.fuse_gps(1_000_000, &fix(8));
    nav.fuse_gps(2_000_000, &fix(8));
    let h = nav.health(5_000_000);
    assert!((h.since_gps_s.unwrap() - 3.0).abs() < 1e-9);
}

#[test]
fn the_local_frame_uses_the_ellipsoids_radii() {
    // At 45 deg: a degree of latitude is 111 132 m, of longitude 78 847 m (WGS-84).
    let o = GeoOrigin {
        lat_deg: 45.0,
        lon_deg: 0.0,
        alt_m: 0.0,
    };
    let [n, e, d] = o.to_ned(46.0, 1.0, -10.0);
    assert!((n - 111_132.0).abs() < 200.0, "{n}");
    assert!((e - 78_847.0).abs() < 200.0, "{e}");
    assert!((d - 10.0).abs() < 1e-9);
    // At the equator: 110 574 m and 111 320 m.
    let o = GeoOrigin {
        lat_deg: 0.0,
        lon_deg: 0.0,
        alt_m: 0.0,
    };
    let [n, e, _] = o.to_ned(0.01, 0.01, 0.0);
    assert!((n - 1105.74).abs() < 1.0, "{n}");
    assert!((e - 1113.2).abs() < 1.0, "{e}");
}

mod calibration {
    use heli_nav::calibration::{MOTION_RATE_RPS, MOTION_TILT_RAD, Motion};
    use heli_nav::{BiasCalibration, CalibrationPhase};
    use heli_proto::imu::ImuRepr;

    fn sample(rate_x: f64, accel_y: f64) -> ImuRepr {
        ImuRepr {
            rate_rps: [rate_x, 0.0, 0.0],
            accel_mps2: [0.0, accel_y, -9.81],
            temp_c: 20.0,
        }
    }

    /// Feeds `samples` samples.
    fn feed(cal: &mut BiasCalibration, samples: u32, s: ImuRepr) {
        for _ in 0..samples {
            cal.push(&s);
        }
    }

    #[test]
    fn a_second_turning_or_tilting_is_left_out_of_the_window() {
        // The window opens at the 11th sample (0.1 s of warm-up after the first), which begins
        // its first second; 211 still samples fill two and begin the third, which ends on the
        // 99th turning sample. It is compared with the median of the window's seconds.
        for (rate, moved) in [
            (MOTION_RATE_RPS * 0.5, false),
            (MOTION_RATE_RPS * 2.0, true),
        ] {
            let mut cal = BiasCalibration::new(0.1, 10.0);
            feed(&mut cal, 211, sample(0.0, 0.0));
            feed(&mut cal, 100, sample(rate, 0.0));
            assert_eq!(cal.take_left_out().is_some(), moved, "{rate}");
            // With the second before it, the turn's edge.
            assert_eq!(cal.left_out_s(), 2 * u32::from(moved));
            assert_eq!(cal.restarts(), 0, "a second is left out, not a restart");
        }
        // Tilted: gravity's direction moved.
        for (tilt, moved) in [
            (MOTION_TILT_RAD * 0.5, false),
            (MOTION_TILT_RAD * 2.0, true),
        ] {
            let mut cal = BiasCalibration::new(0.1, 10.0);
            feed(&mut cal, 211, sample(0.0, 0.0));
            feed(&mut cal, 100, sample(0.0, 9.81 * tilt.tan()));
            assert_eq!(cal.take_left_out().is_some(), moved, "{tilt}");
        }
    }

    #[test]
    fn the_biases_are_the_windows_means_once_it_closes() {
        let mut cal = BiasCalibration::new(0.1, 2.0);
        assert_eq!(cal.biases(), None);
        feed(&mut cal, 250, sample(0.004, 0.0));
        assert!(
            matches!(cal.phase(), CalibrationPhase::Done(_)),
            "{:?}",
            cal.phase()
        );
        let b = cal.biases().unwrap();
        assert!((b.gyro_rps.x - 0.004).abs() < 1e-12);
        assert!((b.mean_accel_mps2.z + 9.81).abs() < 1e-12);
        // A restart asked for after the window closed changes nothing.
        cal.restart(Motion {
            rate_rps: 0.0,
            tilt_rad: 0.0,
            turn_rad: 1.0,
        });
        assert_eq!(cal.restarts(), 0);
        assert!(cal.biases().is_some());
    }
}
