//! The onboard computer's analog inputs: 12-bit, unipolar 0..5 V.
//!
//! One count is `ADC_FULL_SCALE_V / 2^ADC_BITS` = 1.220703125 mV, so count
//! 2048 is exactly 2.5 V and the top count, 4095, is 5 V less one LSB.

/// Resolution of the converter, bits.
pub const ADC_BITS: u32 = 12;
/// Full-scale input voltage (the voltage of count `2^ADC_BITS`), V.
pub const ADC_FULL_SCALE_V: f64 = 5.0;
/// Largest count the converter reports.
pub const ADC_MAX_COUNTS: u16 = 4095;
/// Voltage of one count, V.
pub const ADC_LSB_V: f64 = ADC_FULL_SCALE_V / 4096.0;

/// Input voltage of an ADC reading, V. Counts above [`ADC_MAX_COUNTS`] are
/// taken at face value.
pub fn counts_to_volts(counts: u16) -> f64 {
    f64::from(counts) * ADC_LSB_V
}

/// ADC reading of an input voltage: rounded to the nearest count and clamped
/// to `0..=4095` (NaN gives 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub fn volts_to_counts(volts: f64) -> u16 {
    // NaN stays NaN through the clamp, and `as` makes it 0.
    libm::round(volts / ADC_LSB_V).clamp(0.0, f64::from(ADC_MAX_COUNTS)) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn fixed_points() {
        assert_eq!(counts_to_volts(0), 0.0);
        assert_eq!(counts_to_volts(2048), 2.5);
        assert_eq!(volts_to_counts(2.5), 2048);
        assert_eq!(volts_to_counts(5.0), 4095);
        assert_eq!(volts_to_counts(7.0), 4095);
        assert_eq!(volts_to_counts(-1.0), 0);
        assert_eq!(volts_to_counts(f64::NAN), 0);
        assert_eq!(volts_to_counts(f64::INFINITY), 4095);
        assert_eq!(ADC_MAX_COUNTS, (1u32 << ADC_BITS) as u16 - 1);
    }

    proptest! {
        #[test]
        fn counts_round_trip(c in 0u16..=4095) {
            prop_assert_eq!(volts_to_counts(counts_to_volts(c)), c);
        }

        #[test]
        fn volts_round_trip_within_half_lsb(v in 0.0f64..(4095.0 * ADC_LSB_V)) {
            let back = counts_to_volts(volts_to_counts(v));
            prop_assert!((back - v).abs() <= ADC_LSB_V / 2.0 + 1e-12);
        }
    }
}
