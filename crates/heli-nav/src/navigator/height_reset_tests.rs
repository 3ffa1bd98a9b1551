//! The height's way back to the altimeter (`reset.rs`): an inertial height run off, the
//! altimeter refused by the gate for ever after, is set to the altimeter's once the GPS's
//! height sides with it — and not when the GPS sides with the estimate (the altimeter is the
//! one gone wrong), nor with no GPS to ask.

use super::algebra_tests::{at_rest, fix_at, level_imu};
use super::*;

/// The pressure at the altimeter's reference: the helicopter at the origin's height.
const GROUND_MBAR: f64 = 1013.25;

/// A filter at rest at the origin whose altimeter was referenced there, then its height set
/// 30 m up (as an estimate gone wrong would have it); flown `seconds` at rest with the
/// altimeter read at 5 Hz (the origin's pressure) and, when `gps_z_m` is given, a GPS fix a
/// second (its height that z, its latency 1 s). Returns the filter.
fn run_off(gps_z_m: Option<f64>, seconds: u64) -> Navigator {
    run_off_over(GROUND_MBAR, -30.0, gps_z_m, seconds)
}

/// As [`run_off`], the altimeter reading `baro_mbar` and the estimate's height set to
/// `z_m` (NED).
fn run_off_over(baro_mbar: f64, z_m: f64, gps_z_m: Option<f64>, seconds: u64) -> Navigator {
    let mut nav = at_rest(0);
    nav.fuse_baro(GROUND_MBAR);
    assert_eq!(nav.stats().baro_fused, 1);
    if let Some(state) = nav.state.as_mut() {
        state.pos_ned_m.z = z_m;
    }
    let mut t = 0;
    for step in 1..=seconds * 50 {
        t += 20_000;
        nav.propagate(t, &level_imu(), &level_imu());
        if step % 10 == 0 {
            let resets = nav.stats().height_resets;
            let reset = nav.fuse_baro(baro_mbar);
            assert_eq!(reset, nav.stats().height_resets != resets, "step {step}");
        }
        if let Some(z) = gps_z_m
            && step % 50 == 0
        {
            nav.fuse_gps(t, &fix_at(Vector3::new(0.0, 0.0, z), Vector3::zeros()));
        }
    }
    nav
}

fn height_m(nav: &Navigator) -> f64 {
    -nav.state().map_or(f64::NAN, |s| s.pos_ned_m.z)
}

#[test]
fn a_height_run_off_is_reset_to_the_altimeter_the_gps_agrees_with() {
    let c = NavConfig::default();
    // Not before 5 s without a fused reading (and 10 refused in a row).
    let early = run_off(Some(0.5), 4);
    assert_eq!(early.stats().height_resets, 0);
    assert!(
        (height_m(&early) - 30.0).abs() < 0.5,
        "{}",
        height_m(&early)
    );
    assert!(early.stats().baro_rejected_in_row >= c.height_reset_rejections);
    // Then, on the reading 5 s after the last fused one, onto the altimeter's height: its
    // variance the altimeter's, no correlation, the vertical velocity 1 m/s uncertain.
    let at = run_off(Some(0.5), 5);
    assert_eq!(at.stats().height_resets, 1, "{:?}", at.stats());
    assert!(height_m(&at).abs() < 1e-9, "{}", height_m(&at));
    let z = ix::POS + 2;
    assert_eq!(at.cov[(z, z)], c.baro_sigma_m.powi(2));
    for j in (0..N_ERR).filter(|&j| j != z) {
        assert_eq!(at.cov[(z, j)], 0.0, "({z}, {j})");
        assert_eq!(at.cov[(j, z)], 0.0, "({j}, {z})");
    }
    assert!(at.cov[(ix::VEL + 2, ix::VEL + 2)] >= 1.0);
    let nav = run_off(Some(0.5), 6);
    assert_eq!(nav.stats().height_resets, 1, "{:?}", nav.stats());
    assert!(height_m(&nav).abs() < 0.3, "{}", height_m(&nav));
    // The altimeter is fused again after it, and the fixes replayed over the reset (each
    // valid a second before it arrives) keep it.
    assert!(nav.stats().baro_rejected_in_row < 3, "{:?}", nav.stats());
    let later = run_off(Some(0.5), 12);
    assert_eq!(later.stats().height_resets, 1);
    assert!(height_m(&later).abs() < 0.3, "{}", height_m(&later));
}

#[test]
fn no_reset_where_the_gps_sides_with_the_estimate_or_is_not_there() {
    // The GPS's height 30 m up, as the estimate's: the altimeter is the one gone wrong.
    let nav = run_off(Some(-30.0), 12);
    assert_eq!(nav.stats().height_resets, 0);
    assert!((height_m(&nav) - 30.0).abs() < 0.5, "{}", height_m(&nav));
    // 5.5 m from the altimeter's: beyond the agreement asked for.
    let nav = run_off(Some(-5.5), 12);
    assert_eq!(nav.stats().height_resets, 0);
    // 4.5 m: within it.
    let nav = run_off(Some(-4.5), 12);
    assert_eq!(nav.stats().height_resets, 1);
    // No GPS at all: nothing to side with either.
    let nav = run_off(None, 12);
    assert_eq!(nav.stats().height_resets, 0);
}

#[test]
fn the_height_reset_to_is_the_altimeters_above_its_reference() {
    // The altimeter says 20 m up (referenced on the ground), the GPS 21 m, the estimate 50:
    // reset to the altimeter's 20 m — not to its reference, not to the GPS's.
    let up_20_mbar = GROUND_MBAR * (1.0 - 2.25577e-5 * 20.0_f64).powf(5.25588);
    let baro_up_m = pressure_altitude_m(up_20_mbar, GROUND_MBAR);
    assert!((baro_up_m - 20.0).abs() < 0.1, "{baro_up_m}");
    let nav = run_off_over(up_20_mbar, -50.0, Some(-21.0), 5);
    assert_eq!(nav.stats().height_resets, 1, "{:?}", nav.stats());
    assert!(
        (height_m(&nav) - baro_up_m).abs() < 1e-9,
        "{}",
        height_m(&nav)
    );
    // The GPS 26 m up: 6 m from the altimeter, no reset.
    let nav = run_off_over(up_20_mbar, -50.0, Some(-26.0), 12);
    assert_eq!(nav.stats().height_resets, 0);
}
