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

/// A battery discharge curve: terminal voltage against the fraction of life remaining,
/// measured by bench tests as the thesis describes ("extensive battery tests comparing
/// voltage to battery life"). The ground's meter falls back on it when the telemetry
/// carries no gauge (the flight software's own gauge is `heli_power`'s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryCurve {
    /// (volts, fraction of life left) points, volts increasing.
    pub points: [(f64, f64); 6],
}

impl Default for BatteryCurve {
    /// A 10-cell NiMH flight pack (12 V nominal).
    fn default() -> Self {
        Self {
            points: [
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
    /// Fraction of life left at `volts`, interpolated, 0..1 (0 for a reading that is not a
    /// number).
    pub fn life_left(&self, volts: f64) -> f64 {
        let [first, .., last] = self.points;
        if !volts.is_finite() || volts <= first.0 {
            return first.1;
        }
        if volts >= last.0 {
            return last.1;
        }
        self.points
            .windows(2)
            .find_map(|w| match w {
                [a, b] if volts <= b.0 && b.0 > a.0 => {
                    Some(a.1 + (b.1 - a.1) * (volts - a.0) / (b.0 - a.0))
                }
                _ => None,
            })
            .unwrap_or(last.1)
    }
}

/// The `battery` condition: more than a third of the battery's life left (the thesis's
/// meter turns red at a third).
pub fn battery_green(life_left: f64) -> bool {
    life_left > 1.0 / 3.0
}

/// The battery meter: percentage of a full charge, and whether it is still green (the
/// thesis turns it red with a third of the lifetime left).
pub fn battery_meter(curve: &BatteryCurve, volts: f64) -> (f64, bool) {
    let life = curve.life_left(volts);
    (100.0 * life, battery_green(life))
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

    #[test]
    fn the_curve_is_interpolated_between_its_points_and_held_beyond_them() {
        let curve = BatteryCurve::default();
        let life = |v| curve.life_left(v);
        // Between (11.6, 0.33) and (12.0, 0.6): a quarter of the way is 0.33 + 0.27 / 4.
        assert!(
            (life(11.7) - (0.33 + 0.27 * 0.25)).abs() < 1e-12,
            "{}",
            life(11.7)
        );
        // Between (10.0, 0.0) and (11.0, 0.1).
        assert!((life(10.3) - 0.03).abs() < 1e-12, "{}", life(10.3));
        assert_eq!(life(11.0), 0.1);
        assert_eq!(life(9.0), 0.0);
        assert_eq!(life(10.0), 0.0);
        assert_eq!(life(12.8), 1.0);
        assert_eq!(life(14.0), 1.0);
        assert_eq!(life(f64::INFINITY), 0.0);
        // A curve with a step (two points at one voltage) takes the upper side's value.
        let step = BatteryCurve {
            points: [
                (10.0, 0.0),
                (11.0, 0.2),
                (11.0, 0.4),
                (12.0, 0.8),
                (12.5, 0.9),
                (13.0, 1.0),
            ],
        };
        assert!((step.life_left(11.5) - 0.6).abs() < 1e-12);
        assert!(!battery_green(1.0 / 3.0));
        assert!(battery_green(0.34));
    }
}
