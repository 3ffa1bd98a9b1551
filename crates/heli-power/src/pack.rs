//! A battery pack type's characterization: what "extensive battery tests" measure of a pack
//! (thesis §2.4), written down once and shared by the fuel gauge on board and the simulator's
//! batteries, so that one can be checked against the other.
//!
//! The model is the usual equivalent circuit of a fuel gauge: the open-circuit voltage as a
//! function of the state of charge, a series resistance that grows in the cold, a capacity
//! that shrinks in the cold and with every charge cycle. The terminal voltage under a load
//! `I` is `OCV(soc) − I R(T)`.

use serde::{Deserialize, Serialize};

/// Number of points of the open-circuit curve.
pub const CURVE_POINTS: usize = 6;

/// The temperature the capacity and resistance are given at (°C).
pub const REFERENCE_C: f64 = 20.0;

/// One pack type.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PackType {
    /// Cells in series.
    pub cells: u32,
    /// Capacity of a new pack at [`REFERENCE_C`] (A h).
    pub capacity_ah: f64,
    /// Open-circuit voltage of one cell against the state of charge: (charge fraction,
    /// volts) points, both increasing, from empty (0) to full (1).
    pub ocv_per_cell: [(f64, f64); CURVE_POINTS],
    /// Series resistance of one cell at [`REFERENCE_C`] (Ω).
    pub resistance_per_cell_ohm: f64,
    /// Relative growth of the resistance per °C below [`REFERENCE_C`].
    pub resistance_cold_per_c: f64,
    /// Relative loss of capacity per °C below [`REFERENCE_C`].
    pub capacity_cold_per_c: f64,
    /// Relative loss of capacity per charge cycle (capacity fade).
    pub fade_per_cycle: f64,
}

/// Why a pack type is refused.
#[derive(Clone, Debug, PartialEq)]
pub struct PackError(pub String);

impl core::fmt::Display for PackError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PackError {}

/// The open-circuit curve of a nickel-metal-hydride cell: flat from a fifth to nine tenths
/// of its charge, falling steeply at both ends (the shape of a NiMH discharge at C/5).
pub const NIMH_OCV: [(f64, f64); CURVE_POINTS] = [
    (0.0, 1.00),
    (0.05, 1.15),
    (0.2, 1.21),
    (0.6, 1.25),
    (0.9, 1.29),
    (1.0, 1.34),
];

impl PackType {
    /// A NiMH pack of `cells` cells and `capacity_ah` (the thesis's packs were NiMH).
    pub const fn nimh(cells: u32, capacity_ah: f64) -> Self {
        Self {
            cells,
            capacity_ah,
            ocv_per_cell: NIMH_OCV,
            resistance_per_cell_ohm: 0.025,
            resistance_cold_per_c: 0.03,
            capacity_cold_per_c: 0.01,
            fade_per_cycle: 0.001,
        }
    }

    /// The flight pack: ten NiMH cells, 12 V, 1.7 A h (the computer, IMU, GPS, altimeter
    /// and compass).
    pub const FLIGHT: PackType = PackType::nimh(10, 1.7);
    /// The servo board's logic and receiver pack: four NiMH cells, 4.8 V, 0.6 A h.
    pub const RECEIVER: PackType = PackType::nimh(4, 0.6);
    /// The servo pack: four NiMH cells, 4.8 V, 1.1 A h.
    pub const SERVO: PackType = PackType::nimh(4, 1.1);

    /// Checks the characterization: cells and capacity positive, the curve increasing in
    /// both charge and voltage from 0 to 1, the coefficients finite and not negative.
    pub fn validate(&self) -> Result<(), PackError> {
        let err = |what: &str| Err(PackError(what.to_string()));
        if self.cells == 0 {
            return err("cells must be at least 1");
        }
        if !(self.capacity_ah.is_finite() && self.capacity_ah > 0.0) {
            return err("capacity_ah must be a positive number");
        }
        let [first, .., last] = self.ocv_per_cell;
        if first.0 != 0.0 || last.0 != 1.0 {
            return err("ocv_per_cell must run from charge 0 to charge 1");
        }
        let increasing = self
            .ocv_per_cell
            .windows(2)
            .all(|w| matches!(w, [a, b] if b.0 > a.0 && b.1 > a.1));
        let finite = self
            .ocv_per_cell
            .iter()
            .all(|(c, v)| c.is_finite() && v.is_finite() && *v > 0.0);
        if !(increasing && finite) {
            return err("ocv_per_cell must increase in both charge and volts");
        }
        for (name, x) in [
            ("resistance_per_cell_ohm", self.resistance_per_cell_ohm),
            ("resistance_cold_per_c", self.resistance_cold_per_c),
            ("capacity_cold_per_c", self.capacity_cold_per_c),
            ("fade_per_cycle", self.fade_per_cycle),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(PackError(format!("{name} must be a number, at least 0")));
            }
        }
        Ok(())
    }

    /// Open-circuit voltage of the pack at charge `soc` (clamped to 0..1).
    pub fn open_circuit_v(&self, soc: f64) -> f64 {
        let c = if soc.is_finite() {
            soc.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let per_cell = interpolate(&self.ocv_per_cell, c, |p| p.0, |p| p.1);
        per_cell * f64::from(self.cells)
    }

    /// The charge whose open-circuit voltage is `volts` (0 below the curve, 1 above).
    pub fn soc_at_open_circuit(&self, volts: f64) -> f64 {
        if !volts.is_finite() {
            return 0.0;
        }
        let per_cell = volts / f64::from(self.cells.max(1));
        interpolate(&self.ocv_per_cell, per_cell, |p| p.1, |p| p.0)
    }

    /// Series resistance of the pack at `temp_c` (Ω).
    pub fn resistance_ohm(&self, temp_c: f64) -> f64 {
        let cold = cold_degrees(temp_c);
        self.resistance_per_cell_ohm
            * f64::from(self.cells)
            * (1.0 + self.resistance_cold_per_c * cold)
    }

    /// Capacity at `temp_c` after `cycles` charge cycles (A h).
    pub fn capacity_at(&self, temp_c: f64, cycles: f64) -> f64 {
        let cold = cold_degrees(temp_c);
        let cycles = if cycles.is_finite() {
            cycles.max(0.0)
        } else {
            0.0
        };
        let factor = ((1.0 - self.capacity_cold_per_c * cold)
            * (1.0 - self.fade_per_cycle * cycles))
            .max(0.05);
        self.capacity_ah * factor
    }

    /// Terminal voltage at charge `soc` with `current_a` drawn at `temp_c`.
    pub fn terminal_v(&self, soc: f64, current_a: f64, temp_c: f64) -> f64 {
        self.open_circuit_v(soc) - current_a * self.resistance_ohm(temp_c)
    }
}

/// Degrees below the reference temperature (0 when warmer or unknown).
fn cold_degrees(temp_c: f64) -> f64 {
    if temp_c.is_finite() {
        (REFERENCE_C - temp_c).max(0.0)
    } else {
        0.0
    }
}

/// Piecewise-linear interpolation of `y` against `x` over points increasing in `x`,
/// clamped at both ends.
fn interpolate<P: Copy>(points: &[P], at: f64, x: impl Fn(P) -> f64, y: impl Fn(P) -> f64) -> f64 {
    let (Some(&first), Some(&last)) = (points.first(), points.last()) else {
        return 0.0;
    };
    if at <= x(first) {
        return y(first);
    }
    if at >= x(last) {
        return y(last);
    }
    points
        .windows(2)
        .find_map(|w| match w {
            [a, b] if at <= x(*b) && x(*b) > x(*a) => {
                Some(y(*a) + (y(*b) - y(*a)) * (at - x(*a)) / (x(*b) - x(*a)))
            }
            _ => None,
        })
        .unwrap_or(y(last))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_flight_pack_matches_its_nominal_figures() {
        let p = PackType::FLIGHT;
        p.validate().unwrap();
        assert!((p.open_circuit_v(1.0) - 13.4).abs() < 1e-9);
        assert!((p.open_circuit_v(0.6) - 12.5).abs() < 1e-9);
        assert!((p.resistance_ohm(20.0) - 0.25).abs() < 1e-12);
        // 20 °C colder: 60 % more resistance, 20 % less capacity.
        assert!((p.resistance_ohm(0.0) - 0.4).abs() < 1e-12);
        assert!((p.capacity_at(0.0, 0.0) - 1.36).abs() < 1e-12);
        assert!((p.capacity_at(30.0, 100.0) - 1.53).abs() < 1e-12);
    }

    #[test]
    fn a_bad_characterization_is_refused_with_its_field_named() {
        let mut p = PackType::FLIGHT;
        p.ocv_per_cell[3].1 = 1.0;
        assert!(p.validate().unwrap_err().0.contains("ocv_per_cell"));
        let mut p = PackType::FLIGHT;
        p.capacity_ah = f64::NAN;
        assert!(p.validate().unwrap_err().0.contains("capacity_ah"));
        let mut p = PackType::FLIGHT;
        p.fade_per_cycle = -1.0;
        assert!(p.validate().unwrap_err().0.contains("fade_per_cycle"));
        let p = PackType {
            cells: 0,
            ..PackType::FLIGHT
        };
        assert!(p.validate().unwrap_err().0.contains("cells"));
    }

    proptest! {
        #[test]
        fn the_open_circuit_curve_inverts(soc in 0.0f64..=1.0) {
            let p = PackType::FLIGHT;
            let back = p.soc_at_open_circuit(p.open_circuit_v(soc));
            prop_assert!((back - soc).abs() < 1e-9, "{soc} -> {back}");
        }

        #[test]
        fn more_load_or_more_cold_gives_less_voltage(
            soc in 0.0f64..=1.0, i in 0.0f64..5.0, t in -20.0f64..40.0
        ) {
            let p = PackType::FLIGHT;
            prop_assert!(p.terminal_v(soc, i + 0.5, t) < p.terminal_v(soc, i, t));
            prop_assert!(p.terminal_v(soc, i + 0.5, t - 5.0) <= p.terminal_v(soc, i + 0.5, t));
        }
    }
}
