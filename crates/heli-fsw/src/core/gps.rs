//! GPS fixes checked for plausibility on board, before the filter sees them: a receiver
//! that reports a place off the globe, or a position that jumps faster than any helicopter
//! flies since the last good fix (a multipath glitch, a corrupted frame that passed its
//! checksum), is refused, counted and reported. The filter's own innovation gate then only
//! has to judge fixes that could be true.

use heli_nav::geo::GeoOrigin;
use heli_proto::gps::GpsNav;

/// Fastest the helicopter can move between two fixes (m/s); the X-Cell 60 tops out near
/// 30 m/s, and a wind adds at most 30 more.
pub const MAX_SPEED_MPS: f64 = 100.0;
/// Position jump always allowed between two fixes, for the receiver's own noise (m).
pub const JUMP_SLACK_M: f64 = 20.0;
/// Lowest and highest altitude a fix may report (m above the ellipsoid).
pub const ALT_RANGE_M: (f64, f64) = (-500.0, 10_000.0);

/// Why a fix was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Implausible {
    /// Latitude, longitude or altitude outside the globe's ranges.
    OffTheGlobe,
    /// The position moved this far (m) from the last good fix, faster than allowed.
    Jump {
        /// Distance from the last good fix (m).
        distance_m: f64,
    },
}

/// Why `fix`, arriving at `now_us`, cannot be true, given the last good fix; `None` if it
/// can.
pub fn implausible(fix: &GpsNav, last: Option<(u64, GpsNav)>, now_us: u64) -> Option<Implausible> {
    let on_globe = (-90.0..=90.0).contains(&fix.lat_deg)
        && (-180.0..=180.0).contains(&fix.lon_deg)
        && (ALT_RANGE_M.0..=ALT_RANGE_M.1).contains(&fix.alt_m);
    if !on_globe {
        return Some(Implausible::OffTheGlobe);
    }
    let (t_us, last) = last?;
    let origin = GeoOrigin {
        lat_deg: last.lat_deg,
        lon_deg: last.lon_deg,
        alt_m: last.alt_m,
    };
    let [n, e, d] = origin.to_ned(fix.lat_deg, fix.lon_deg, fix.alt_m);
    let distance_m = (n * n + e * e + d * d).sqrt();
    let dt_s = heli_nav::seconds_between(t_us, now_us).max(0.0);
    let allowed_m = JUMP_SLACK_M + MAX_SPEED_MPS * dt_s;
    (distance_m > allowed_m || !distance_m.is_finite()).then_some(Implausible::Jump { distance_m })
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_proto::gps::FixType;

    fn fix(lat_deg: f64, lon_deg: f64) -> GpsNav {
        GpsNav {
            tow_ms: 0,
            lat_deg,
            lon_deg,
            alt_m: 10.0,
            vel_ned_mps: [0.0; 3],
            satellites: 8,
            fix: FixType::Fix3D,
        }
    }

    #[test]
    fn off_the_globe_and_jumps_are_refused_real_motion_is_not() {
        let a = fix(42.3581, -71.0966);
        assert_eq!(
            implausible(&fix(91.0, 0.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
        assert_eq!(
            implausible(&fix(0.0, 181.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
        assert_eq!(
            implausible(&a, None, 0),
            None,
            "the first fix has nothing to jump from"
        );
        // 10 m north in a second: flying.
        let b = fix(42.3581 + 10.0 / 111_000.0, -71.0966);
        assert_eq!(implausible(&b, Some((0, a)), 1_000_000), None);
        // 1 km in a second: a glitch.
        let c = fix(42.3581 + 1_000.0 / 111_000.0, -71.0966);
        assert!(matches!(
            implausible(&c, Some((0, a)), 1_000_000),
            Some(Implausible::Jump { distance_m }) if (distance_m - 1_000.0).abs() < 20.0
        ));
        // The same kilometre after a 20 s outage: possible, accepted.
        assert_eq!(implausible(&c, Some((0, a)), 20_000_000), None);
    }

    #[test]
    fn a_jump_is_measured_in_every_direction() {
        let a = fix(42.3581, -71.0966);
        let north = |m: f64| fix(42.3581 + m / 111_000.0, -71.0966);
        let east = |m: f64| {
            fix(
                42.3581,
                -71.0966 + m / (111_000.0 * 42.3581f64.to_radians().cos()),
            )
        };
        let up = |m: f64| GpsNav {
            alt_m: 10.0 + m,
            ..a
        };
        // At the same instant, 20 m is the receiver's slack.
        for (moved, name) in [
            (north(15.0), "north"),
            (east(15.0), "east"),
            (up(15.0), "up"),
        ] {
            assert_eq!(implausible(&moved, Some((0, a)), 0), None, "{name}");
        }
        for (moved, name) in [
            (north(25.0), "north"),
            (east(25.0), "east"),
            (up(25.0), "up"),
        ] {
            match implausible(&moved, Some((0, a)), 0) {
                Some(Implausible::Jump { distance_m }) => {
                    assert!((distance_m - 25.0).abs() < 0.5, "{name}: {distance_m}")
                }
                other => panic!("{name}: {other:?}"),
            }
        }
        // 12 m north, 12 m east and 12 m up: 20.8 m together.
        let diagonal = GpsNav {
            alt_m: 22.0,
            ..fix(42.3581 + 12.0 / 111_000.0, east(12.0).lon_deg)
        };
        assert!(implausible(&diagonal, Some((0, a)), 0).is_some());
        // Each second allows 100 m more: 115 m after one second is fine, 125 m is not.
        assert_eq!(implausible(&north(115.0), Some((0, a)), 1_000_000), None);
        assert!(implausible(&north(125.0), Some((0, a)), 1_000_000).is_some());
        // A height outside the globe's range.
        assert_eq!(
            implausible(&up(20_000.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
        assert_eq!(
            implausible(&up(-600.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
        assert_eq!(
            implausible(&fix(-91.0, 0.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
        assert_eq!(
            implausible(&fix(0.0, -181.0), None, 0),
            Some(Implausible::OffTheGlobe)
        );
    }

    #[test]
    fn a_reset_of_the_estimate_to_gps_is_raised_and_a_fused_fix_raises_nothing() {
        use crate::core::{Action, CoreConfig, CoreEvent, FlightCore, FlightParams, Input};
        use heli_nav::NavConfig;
        use nalgebra::Vector3;
        let mut core = FlightCore::new(CoreConfig::default(), FlightParams::default());
        // The estimate started 100 m south of where the GPS puts it, and has coasted since.
        let here = fix(42.3581, -71.0966);
        core.nav.set_origin(heli_nav::GeoOrigin {
            lat_deg: here.lat_deg - 100.0 / 111_000.0,
            lon_deg: here.lon_deg,
            alt_m: here.alt_m,
        });
        core.nav.initialise(
            0,
            &heli_nav::ImuBiases {
                gyro_rps: Vector3::zeros(),
                mean_accel_mps2: Vector3::new(0.0, 0.0, -heli_nav::GRAVITY_MPS2),
                samples: 100,
            },
        );
        let resets = |out: &[Action]| {
            out.iter()
                .filter(|a| matches!(a, Action::Event(e) if e.value == CoreEvent::GpsReset))
                .count()
        };
        let mut out = Vec::new();
        let refusals = NavConfig::default().gps_reset_rejections;
        for k in 1..refusals {
            core.handle(
                Input::Gps(here),
                6_000_000 + u64::from(k) * 200_000,
                &mut out,
            );
        }
        assert_eq!(resets(&out), 0, "refused, not yet reset");
        core.handle(Input::Gps(here), 7_000_000, &mut out);
        assert_eq!(resets(&out), 1);
        assert_eq!(core.nav.stats().gps_resets, 1);
        // Now the estimate agrees: the next fix is fused, and that is no reset.
        out.clear();
        core.handle(Input::Gps(here), 7_200_000, &mut out);
        assert_eq!(core.nav.stats().gps_fused, 1);
        assert_eq!(resets(&out), 0);
    }
}
