//! Simulated flight battery on the battery ADC channel: a linear discharge from full charge.

use heli_proto::battery::BatteryAdc;

/// The simulated flight battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryDevice {
    /// Voltage at full charge (V).
    pub full_v: f64,
    /// Voltage lost per second of operation (V/s).
    pub drain_v_per_s: f64,
}

impl Default for BatteryDevice {
    fn default() -> Self {
        Self {
            full_v: 12.4,
            drain_v_per_s: 0.0008,
        }
    }
}

impl BatteryDevice {
    /// Terminal voltage after `t_s` seconds.
    pub fn volts(&self, t_s: f64) -> f64 {
        self.full_v - self.drain_v_per_s * t_s
    }

    /// The ADC reading after `t_s` seconds.
    pub fn read(&self, t_s: f64) -> BatteryAdc {
        BatteryAdc::from_volts(self.volts(t_s))
    }
}
