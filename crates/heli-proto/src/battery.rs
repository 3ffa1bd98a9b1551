//! Flight battery voltage on one ADC channel through a 3:1 resistor divider.
//!
//! Conversion chain: `counts --(adc: ×5/4096 V)--> divider output, V
//! --(×3)--> battery voltage, V`. The ADC's 0..5 V span covers a 0..15 V
//! battery, in 3.66 mV steps.

use crate::adc;

/// Battery voltage divided by the voltage at the ADC input.
pub const DIVIDER_RATIO: f64 = 3.0;

/// One battery sample: the ADC count of the divider output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BatteryAdc {
    /// ADC counts.
    pub counts: u16,
}

impl BatteryAdc {
    /// Battery voltage, V.
    pub fn volts(&self) -> f64 {
        adc::counts_to_volts(self.counts) * DIVIDER_RATIO
    }

    /// The sample the ADC would give for a battery voltage: rounded to the
    /// nearest count, clamped to the ADC range (NaN gives 0).
    pub fn from_volts(v: f64) -> Self {
        BatteryAdc {
            counts: adc::volts_to_counts(v / DIVIDER_RATIO),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn fixed_points() {
        assert_eq!(BatteryAdc { counts: 2048 }.volts(), 7.5);
        assert_eq!(BatteryAdc::from_volts(7.5).counts, 2048);
        assert_eq!(BatteryAdc::from_volts(20.0).counts, 4095);
        assert_eq!(BatteryAdc::from_volts(-3.0).counts, 0);
        assert_eq!(BatteryAdc::from_volts(f64::NAN).counts, 0);
    }

    proptest! {
        #[test]
        fn counts_round_trip(c in 0u16..=4095) {
            let b = BatteryAdc { counts: c };
            prop_assert_eq!(BatteryAdc::from_volts(b.volts()), b);
        }

        #[test]
        fn volts_round_trip(v in 0.0f64..(4095.0 * adc::ADC_LSB_V * DIVIDER_RATIO)) {
            let back = BatteryAdc::from_volts(v).volts();
            prop_assert!((back - v).abs() <= adc::ADC_LSB_V * DIVIDER_RATIO / 2.0 + 1e-9);
        }
    }
}
