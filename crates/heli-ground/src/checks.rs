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

/// A battery discharge curve: terminal voltage against fraction of life remaining,
/// measured by bench tests as the thesis describes ("extensive battery tests comparing
/// voltage to battery life").
#[derive(Clone, Debug, PartialEq)]
pub struct BatteryCurve {
    /// (volts, fraction of life left) points, volts increasing.
    pub points: Vec<(f64, f64)>,
}

impl Default for BatteryCurve {
    /// A 10-cell NiMH flight pack (12 V nominal).
    fn default() -> Self {
        Self {
            points: vec![
                (10.0, 0.0),
                (11.0, 0.1),
                (11.6, 0.33),
                (12.0, 0.6),
                (12.4, 0.9),
                (12.8, 1.0),
            ],
        }
    }
}

impl BatteryCurve {
    /// Fraction of life left at `volts`, interpolated, 0..1.
    pub fn life_left(&self, volts: f64) -> f64 {
        let (Some(first), Some(last)) = (self.points.first(), self.points.last()) else {
            return 0.0;
        };
        if !volts.is_finite() || volts <= first.0 {
            return first.1;
        }
        if volts >= last.0 {
            return last.1;
        }
        self.points
            .windows(2)
            .find_map(|w| match w {
                [a, b] if volts <= b.0 => Some(a.1 + (b.1 - a.1) * (volts - a.0) / (b.0 - a.0)),
                _ => None,
            })
            .unwrap_or(last.1)
    }
}

/// The battery meter: percentage of a full charge, and whether it is still green (the
/// thesis turns it red with a third of the lifetime left).
pub fn battery_meter(curve: &BatteryCurve, volts: f64) -> (f64, bool) {
    let life = curve.life_left(volts);
    (100.0 * life, life > 1.0 / 3.0)
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
