//! The simulated sensors against the thesis's figures, statistically, with fixed seeds.

use heli_model::noise::Noise;
use heli_proto::baro::{BaroReply, pressure_altitude_m};
use heli_proto::compass::heading_rad;
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use heli_sim::devices::baro::{BaroDevice, BaroErrors, ground_effect_mbar};
use heli_sim::devices::battery::BatteryDevice;
use heli_sim::devices::compass::{CompassDevice, CompassErrors};
use heli_sim::devices::gps::{GpsDevice, GpsErrors};
use heli_sim::devices::imu::{ImuDevice, ImuErrors, RotorPhase};
use heli_sim::lockstep::{FIELD_ORIGIN, calibrate_compass, field_earth_field_gauss};
use nalgebra::{UnitQuaternion, Vector3};

const STILL: RotorPhase = RotorPhase {
    azimuth_rad: 0.0,
    speed_ratio: 0.0,
};

fn decode_imu(bytes: &[u8]) -> ImuRepr {
    ImuRepr::parse(bytes).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn gyro_drift_stays_below_0_02_deg_per_s_over_ten_minutes() {
    let mut worst: f64 = 0.0;
    let mut sum_sq = 0.0;
    let mut n = 0.0;
    for seed in 0..300 {
        let mut imu = ImuDevice::new(ImuErrors::default(), Noise::new(seed, 1));
        // Warm (the warm-up is over after a few minutes), then ten minutes of drift.
        let mut start = Vector3::zeros();
        for t in 0..=900 {
            if t == 300 {
                start = imu.gyro_bias_rps(300.0, 15.0);
            }
            imu.packet(
                f64::from(t),
                &Vector3::zeros(),
                &Vector3::zeros(),
                STILL,
                15.0,
            );
        }
        let drift = (imu.gyro_bias_rps(900.0, 15.0) - start).map(|x| x.to_degrees());
        for d in drift.iter() {
            worst = worst.max(d.abs());
            sum_sq += d * d;
            n += 1.0;
        }
    }
    let rms = (sum_sq / n).sqrt();
    assert!(worst < 0.02, "worst drift {worst} deg/s");
    assert!(
        rms > 0.003 && rms < 0.01,
        "the bias does wander: rms {rms} deg/s"
    );
}

#[test]
fn gyro_bias_moves_with_temperature_while_the_imu_warms_up() {
    let e = ImuErrors {
        gyro_noise_rps: 0.0,
        gyro_bias_walk_rps_per_sqrt_s: 0.0,
        ..ImuErrors::default()
    };
    let mut imu = ImuDevice::new(e, Noise::new(5, 1));
    let cold = decode_imu(
        imu.packet(0.0, &Vector3::zeros(), &Vector3::zeros(), STILL, 15.0)
            .as_slice(),
    );
    let warm = decode_imu(
        imu.packet(200.0, &Vector3::zeros(), &Vector3::zeros(), STILL, 15.0)
            .as_slice(),
    );
    assert!(
        (warm.temp_c - cold.temp_c - e.warm_up_rise_c).abs() < 0.05,
        "{} -> {}",
        cold.temp_c,
        warm.temp_c
    );
    let expected = e.gyro_temp_coeff_rps_per_c * e.warm_up_rise_c;
    for i in 0..3 {
        let shift = warm.rate_rps[i] - cold.rate_rps[i];
        assert!(
            (shift - expected).abs() < 3e-4,
            "axis {i}: {shift} vs {expected}"
        );
    }
}

#[test]
fn rotor_vibration_shows_as_a_peak_near_27_hz() {
    let e = ImuErrors::default();
    let mut imu = ImuDevice::new(e, Noise::new(2, 1));
    let omega = 1600.0 * std::f64::consts::PI / 30.0;
    let n = 2000;
    let az: Vec<f64> = (0..n)
        .map(|k| {
            let t = f64::from(k) * 0.01;
            let rotor = RotorPhase {
                azimuth_rad: omega * t,
                speed_ratio: 1.0,
            };
            decode_imu(
                imu.packet(
                    t,
                    &Vector3::zeros(),
                    &Vector3::new(0.0, 0.0, -9.81),
                    rotor,
                    15.0,
                )
                .as_slice(),
            )
            .accel_mps2[2]
        })
        .collect();
    let power = |f_hz: f64| {
        let (mut s, mut c) = (0.0, 0.0);
        for (k, x) in az.iter().enumerate() {
            let w = 2.0 * std::f64::consts::PI * f_hz * k as f64 * 0.01;
            s += x * w.sin();
            c += x * w.cos();
        }
        (s * s + c * c) / (n as f64).powi(2)
    };
    let rev_hz = omega / (2.0 * std::f64::consts::PI);
    assert!((rev_hz - 26.7).abs() < 0.1);
    let peak = power(rev_hz);
    for other in [5.0, 12.0, 20.0, 33.0, 45.0] {
        assert!(
            peak > 100.0 * power(other),
            "{other} Hz: {} vs peak {peak}",
            power(other)
        );
    }
    // Amplitude through the isolators: a sine of amplitude A has DFT power A²/4.
    let amplitude = 2.0 * peak.sqrt();
    assert!(
        (amplitude - e.vibration_accel_mps2[2]).abs() < 0.05,
        "{amplitude}"
    );
}

fn gps_error(nav: &GpsNav, truth: [f64; 3]) -> Vector3<f64> {
    let ned = FIELD_ORIGIN_NAV.to_ned(nav.lat_deg, nav.lon_deg, nav.alt_m);
    Vector3::new(ned[0] - truth[0], ned[1] - truth[1], ned[2] - truth[2])
}

const FIELD_ORIGIN_NAV: heli_nav::GeoOrigin = FIELD_ORIGIN;

fn decode_gps(bytes: &[u8]) -> GpsNav {
    GpsNav::parse(bytes).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn gps_relative_position_has_about_2_m_circular_error_over_a_flight() {
    // Relative navigation over a ten-minute flight: the error of the position relative to
    // where the flight began. Its circular error probable (median radial error) is ~2 m.
    let errors = GpsErrors {
        satellite_drop_chance: 0.0,
        ..GpsErrors::default()
    };
    let mut radial: Vec<f64> = (0..2000)
        .map(|seed| {
            let mut gps = GpsDevice::new(errors, FIELD_ORIGIN, Noise::new(seed, 2));
            let truth = [0.0, 0.0, -10.0];
            let first = gps_error(
                &decode_gps(
                    gps.packet(0, &Vector3::from(truth), &Vector3::zeros())
                        .as_slice(),
                ),
                truth,
            );
            let mut last = first;
            for t in 1..=600u64 {
                last = gps_error(
                    &decode_gps(
                        gps.packet(t * 1_000_000, &Vector3::from(truth), &Vector3::zeros())
                            .as_slice(),
                    ),
                    truth,
                );
            }
            (last - first).xy().norm()
        })
        .collect();
    radial.sort_by(f64::total_cmp);
    let cep = radial[radial.len() / 2];
    assert!((cep - 2.0).abs() < 0.2, "CEP {cep} m");
}

#[test]
fn gps_horizontal_velocity_error_is_within_0_15_m_per_s() {
    let mut gps = GpsDevice::new(GpsErrors::default(), FIELD_ORIGIN, Noise::new(11, 2));
    let v = Vector3::new(3.0, -1.0, 0.5);
    let errors: Vec<f64> = (0..20_000u64)
        .map(|t| {
            let nav = decode_gps(gps.packet(t * 1_000_000, &Vector3::zeros(), &v).as_slice());
            (Vector3::from(nav.vel_ned_mps) - v).xy().norm()
        })
        .collect();
    let within = errors.iter().filter(|e| **e <= 0.15).count() as f64 / errors.len() as f64;
    assert!(within > 0.995, "{within}");
}

#[test]
fn gps_satellite_count_drops_now_and_then_and_recovers() {
    let mut gps = GpsDevice::new(GpsErrors::default(), FIELD_ORIGIN, Noise::new(4, 2));
    let fixes: Vec<GpsNav> = (0..36_000u64)
        .map(|t| {
            decode_gps(
                gps.packet(t * 1_000_000, &Vector3::zeros(), &Vector3::zeros())
                    .as_slice(),
            )
        })
        .collect();
    let low = fixes.iter().filter(|f| f.satellites < 8).count();
    let no_fix = fixes.iter().filter(|f| f.fix == FixType::NoFix).count();
    assert!(
        low > 100 && low < 3_000,
        "{low} epochs with fewer satellites"
    );
    assert!(no_fix > 0, "some drops lose the fix");
    assert!(fixes.iter().all(|f| f.satellites >= 3));
    assert_eq!(fixes.last().map(|f| f.fix), Some(FixType::Fix3D));
}

#[test]
fn gps_solutions_arrive_one_second_after_their_epoch() {
    use heli_sim::lockstep::Simulation;
    let mut scenario = heli_scenario::hover();
    scenario.duration_s = 20.0;
    let mut sim = Simulation::new(scenario).unwrap_or_else(|e| panic!("{e}"));
    let mut fixes = Vec::new();
    let mut cursor = 0;
    while sim.advance(20_000_000) {
        let (new, next, missed) = sim.streams().gps.read_since(cursor);
        assert_eq!(missed, 0);
        fixes.extend(new);
        cursor = next;
    }
    assert!(fixes.len() >= 18, "{} fixes", fixes.len());
    for fix in fixes {
        let epoch_ms = u64::from(fix.value.tow_ms) - 36_000_000;
        let age_s = (fix.t_us as f64 - epoch_ms as f64 * 1000.0) * 1e-6;
        assert!((age_s - 1.0).abs() < 0.002, "fix age {age_s} s");
    }
}

fn baro_altitude(dev: &mut BaroDevice, t_us: u64, alt_m: f64) -> f64 {
    let bytes = dev
        .transmit(t_us, alt_m, 1013.25)
        .unwrap_or_else(|| panic!("no reading at {t_us}"));
    match BaroReply::parse(bytes.as_slice()) {
        Ok(BaroReply::Pressure { pressure_mbar }) => pressure_altitude_m(pressure_mbar, 1013.25),
        other => panic!("{other:?}"),
    }
}

#[test]
fn altimeter_resolves_two_feet() {
    let mut dev = BaroDevice::new(BaroErrors::default(), Noise::new(3, 3));
    dev.receive(b"*00P2\r", 0);
    let mut readings = Vec::new();
    for k in 1..=500u64 {
        readings.push(baro_altitude(&mut dev, k * 200_000, 10.0 + 0.01 * k as f64));
    }
    // Every reading sits on the 2 ft grid (to the 0.001 mbar the ASCII format carries).
    for r in &readings {
        let steps = r / 0.6096;
        assert!(
            (steps - steps.round()).abs() < 0.03,
            "{r} m is not a multiple of 2 ft"
        );
    }
    let distinct: std::collections::BTreeSet<i64> = readings
        .iter()
        .map(|r| (r / 0.6096).round() as i64)
        .collect();
    assert!(
        distinct.len() >= 8,
        "the grid is walked as the altitude rises"
    );
}

#[test]
fn downwash_near_the_ground_makes_the_altimeter_read_low() {
    let e = BaroErrors::default();
    let mbar_per_m = 0.1201; // near sea level
    let near = ground_effect_mbar(&e, 1.225, 4.4, 0.6, 0.775) / mbar_per_m;
    let high = ground_effect_mbar(&e, 1.225, 4.4, 10.0, 0.775) / mbar_per_m;
    assert!(near > 0.2 && near < 1.0, "{near} m low near the ground");
    assert!(high < 0.01, "{high} m low at 10 m");
    assert_eq!(
        ground_effect_mbar(&e, 1.225, 0.0, 0.6, 0.775),
        0.0,
        "no thrust, no downwash"
    );
}

/// RMS and worst heading error (deg) over a full turn on the ground.
fn heading_error_deg(
    cal: &heli_proto::compass::CompassCalibration,
    errors: CompassErrors,
) -> (f64, f64) {
    let mut compass = CompassDevice::new(field_earth_field_gauss(), errors, Noise::new(8, 4));
    let mut worst: f64 = 0.0;
    let mut sum_sq = 0.0;
    for k in 0..36 {
        let yaw = f64::from(k) * 10f64.to_radians();
        let att = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
        let field = cal.apply(&compass.read(&att).raw_field());
        let h = heading_rad(&field, 0.0, 0.0).unwrap_or(f64::NAN);
        let err = heli_nav::navigator::wrap_pi(h - yaw).to_degrees();
        worst = worst.max(err.abs());
        sum_sq += err * err;
    }
    ((sum_sq / 36.0).sqrt(), worst)
}

#[test]
fn the_avionics_field_spoils_the_compass_until_it_is_calibrated() {
    let errors = CompassErrors::default();
    let (_, uncalibrated_worst) = heading_error_deg(&Default::default(), errors);
    let cal = calibrate_compass(errors, Noise::new(99, 7));
    let (calibrated_rms, calibrated_worst) = heading_error_deg(&cal, errors);
    assert!(uncalibrated_worst > 10.0, "{uncalibrated_worst} deg");
    // What is left is the sensor noise (0.002 gauss on a 0.19 gauss horizontal field).
    assert!(calibrated_rms < 1.0, "{calibrated_rms} deg rms");
    assert!(calibrated_worst < 3.0, "{calibrated_worst} deg");
}

#[test]
fn battery_sags_with_time_and_more_in_the_cold() {
    let pack = heli_power::PackType::FLIGHT;
    let mut warm = BatteryDevice::new(pack, 1.0, 20.0);
    let mut cold = BatteryDevice::new(pack, 1.0, 0.0);
    let fresh = warm.volts(1.8);
    warm.advance(600.0, 1.8);
    cold.advance(600.0, 1.8);
    let after_600 = warm.volts(1.8);
    assert!(warm.volts(1.8) - cold.volts(1.8) > 0.2);
    // The cold pack holds less: it has drawn the same charge from a smaller capacity.
    assert!(cold.soc() < warm.soc());
    warm.advance(1200.0, 1.8);
    assert!(fresh > warm.volts(1.8) + 0.2);
    assert!(after_600 > warm.volts(1.8));
    assert!(
        (warm.read(1.8).volts() - warm.volts(1.8)).abs() < 0.01,
        "through the ADC"
    );
}
