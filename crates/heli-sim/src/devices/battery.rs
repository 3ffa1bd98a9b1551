//! Simulated flight battery on the battery ADC channel: a 10-cell NiMH pack feeding the
//! computer and sensors. The terminal voltage follows the charge left (open-circuit curve)
//! minus the drop across the internal resistance, which grows in the cold — so, as the
//! thesis found in the field, voltage is only weakly tied to time left, and temperature
//! matters a great deal.

use heli_proto::battery::BatteryAdc;

/// The simulated flight battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryDevice {
    /// Capacity (A h).
    pub capacity_ah: f64,
    /// Current drawn by the avionics (A).
    pub load_a: f64,
    /// Internal resistance at 20 °C (Ω).
    pub resistance_ohm: f64,
    /// Relative increase of the resistance per °C below 20 °C.
    pub resistance_cold_per_c: f64,
    /// Charge at power-on, fraction of capacity.
    pub initial_charge: f64,
    /// Ambient temperature (°C).
    pub temperature_c: f64,
}

impl Default for BatteryDevice {
    fn default() -> Self {
        Self {
            capacity_ah: 1.7,
            load_a: 1.8,
            resistance_ohm: 0.25,
            resistance_cold_per_c: 0.03,
            initial_charge: 1.0,
            temperature_c: 15.0,
        }
    }
}

/// Open-circuit voltage of ten NiMH cells against charge left (fraction).
fn open_circuit_v(charge: f64) -> f64 {
    const CURVE: [(f64, f64); 6] = [
        (0.0, 10.0),
        (0.05, 11.5),
        (0.2, 12.1),
        (0.6, 12.5),
        (0.9, 12.9),
        (1.0, 13.4),
    ];
    let c = charge.clamp(0.0, 1.0);
    CURVE
        .windows(2)
        .find_map(|w| {
            let ((c0, v0), (c1, v1)) = (w[0], w[1]);
            (c <= c1).then(|| v0 + (v1 - v0) * (c - c0) / (c1 - c0))
        })
        .unwrap_or(13.4)
}

impl BatteryDevice {
    /// Charge left after `t_s` seconds of load (fraction).
    pub fn charge(&self, t_s: f64) -> f64 {
        (self.initial_charge - self.load_a * t_s / 3600.0 / self.capacity_ah).max(0.0)
    }

    /// Terminal voltage after `t_s` seconds.
    pub fn volts(&self, t_s: f64) -> f64 {
        let cold = (20.0 - self.temperature_c).max(0.0);
        let resistance = self.resistance_ohm * (1.0 + self.resistance_cold_per_c * cold);
        open_circuit_v(self.charge(t_s)) - self.load_a * resistance
    }

    /// The ADC reading after `t_s` seconds.
    pub fn read(&self, t_s: f64) -> BatteryAdc {
        BatteryAdc::from_volts(self.volts(t_s))
    }
}
