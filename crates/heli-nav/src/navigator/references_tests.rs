//! Tests of what a start in the air takes on from a predecessor (`reset.rs`): the ground
//! references handed on, refused when they are not physical, kept through the start, and an
//! attitude carried from a record set over the levelling.

use super::algebra_tests::level_biases;
use super::*;

/// A navigator calibrated on the skids with a compass and an altimeter: its references.
fn on_the_ground() -> Navigator {
    let mut nav = Navigator::new(NavConfig::default());
    nav.fuse_compass(&MagField {
        field_gauss: [0.19, 0.02, 0.48],
    });
    nav.fuse_baro(1012.5);
    nav.initialise(0, &level_biases());
    nav
}

#[test]
fn the_ground_references_are_handed_on_and_kept_through_a_start_in_the_air() {
    let ground = on_the_ground().ground_references();
    let field = ground.earth_field_ned_gauss.unwrap();
    assert!((field[2] - 0.48).abs() < 1e-12, "{field:?}");
    assert_eq!(ground.baro_reference, Some((1012.5, 0.0)));
    // A successor: its own compass reading is taken while banked and would teach it another
    // field, and its altimeter reads in flight; it keeps what it was handed.
    let mut next = Navigator::new(NavConfig::default());
    assert_eq!(next.ground_references(), GroundReferences::default());
    next.restore_ground_references(ground);
    assert_eq!(next.ground_references(), ground);
    next.fuse_compass(&MagField {
        field_gauss: [0.05, 0.3, 0.4],
    });
    next.fuse_baro(1008.0);
    next.initialise_in_air(1_000_000, &level_biases(), None);
    assert_eq!(next.ground_references(), ground);
}

#[test]
fn references_that_are_not_physical_are_not_taken_on() {
    let good = on_the_ground().ground_references();
    for bad in [
        GroundReferences {
            earth_field_ned_gauss: Some([0.2, f64::NAN, 0.4]),
            baro_reference: None,
        },
        GroundReferences {
            earth_field_ned_gauss: None,
            baro_reference: Some((0.0, 0.0)),
        },
        GroundReferences {
            earth_field_ned_gauss: None,
            baro_reference: Some((-1000.0, 0.0)),
        },
        GroundReferences {
            earth_field_ned_gauss: None,
            baro_reference: Some((f64::INFINITY, 0.0)),
        },
        GroundReferences {
            earth_field_ned_gauss: None,
            baro_reference: Some((1012.0, f64::NAN)),
        },
    ] {
        let mut nav = Navigator::new(NavConfig::default());
        nav.restore_ground_references(bad);
        assert_eq!(
            nav.ground_references(),
            GroundReferences::default(),
            "{bad:?}"
        );
        // Nor do they replace good ones.
        nav.restore_ground_references(good);
        nav.restore_ground_references(bad);
        assert_eq!(nav.ground_references(), good, "{bad:?}");
    }
}

#[test]
fn an_attitude_carried_from_a_record_is_set_over_the_levelling() {
    let mut nav = Navigator::new(NavConfig::default());
    let carried = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    // Nothing to set before the estimate starts.
    nav.set_attitude_in_air(carried);
    assert!(nav.state().is_none());
    nav.initialise_in_air(0, &level_biases(), None);
    nav.set_attitude_in_air(carried);
    let att = nav.state().unwrap().att;
    assert!((att.inverse() * carried).angle() < 1e-12);
    // One that is not a number is not taken.
    let broken = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
    nav.set_attitude_in_air(broken);
    let att = nav.state().unwrap().att;
    assert!((att.inverse() * carried).angle() < 1e-12);
}
