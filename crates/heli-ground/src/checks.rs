//! Automated safety checks on telemetry (thesis §2.4 and §4.3): truth values the operator
//! used to verify by eye, computed so that the display shows them and the checks can be
//! combined.

/// Fewest satellites for the GPS indicator to be green. The thesis's display turns red "if
/// GPS is receiving from fewer than five satellites" (§2.4); §4.3 mentions four as the bare
/// minimum for a fix, so five keeps a margin of one.
pub const GPS_MIN_SATELLITES: u8 = 5;

/// The GPS indicator: green when position and velocity updates can be trusted.
pub fn gps_ok(satellites: u8) -> bool {
    satellites >= GPS_MIN_SATELLITES
}

pub use heli_control::safety::BatteryCurve;

/// The battery meter: percentage of a full charge, and whether it is still green (the
/// thesis turns it red with a third of the lifetime left).
pub fn battery_meter(curve: &BatteryCurve, volts: f64) -> (f64, bool) {
    let life = curve.life_left(volts);
    (100.0 * life, heli_control::safety::battery_green(life))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gps_indicator_is_red_below_five_satellites() {
        assert!(!gps_ok(4));
        assert!(gps_ok(5));
    }

    #[test]
    fn battery_meter_turns_red_with_a_third_of_life_left() {
        let curve = BatteryCurve::default();
        let (pct, green) = battery_meter(&curve, 12.4);
        assert!((pct - 90.0).abs() < 1e-9 && green);
        let (pct, green) = battery_meter(&curve, 11.5);
        assert!(pct < 33.4 && !green, "{pct}");
        assert_eq!(battery_meter(&curve, f64::NAN).0, 0.0);
    }
}
