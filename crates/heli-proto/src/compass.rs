//! Three-axis magnetoresistive compass: Honeywell HMC2003 on three ADC
//! channels.
//!
//! There is no protocol: the flight computer samples the HMC2003's three
//! analog outputs at 20 Hz, and the "frame" is the three ADC counts
//! ([`CompassAdc`]). The conversion chain is
//!
//! ```text
//! counts --(adc: ×5/4096 V)--> volts --((V − 2.5 V) / 1 V/gauss)--> raw field, gauss
//!        --(calibration: (raw − bias) · scale)--> field, gauss
//!        --(tilt compensation with roll, pitch)--> magnetic heading, rad
//! ```
//!
//! The HMC2003 gives 1 V/gauss about a 2.5 V null over ±2 gauss; its axes are
//! mounted aligned with the body FRD axes.

use crate::adc;

/// Output sensitivity, V per gauss.
pub const SENSITIVITY_V_PER_GAUSS: f64 = 1.0;
/// Output voltage at zero field, V.
pub const NULL_V: f64 = 2.5;
/// Samples per second.
pub const RATE_HZ: u32 = 20;
/// Measurement range, ± gauss.
pub const RANGE_GAUSS: f64 = 2.0;
/// Horizontal field strength below which no heading is given, gauss.
pub const MIN_HORIZONTAL_GAUSS: f64 = 1e-6;

/// One compass sample: the ADC counts of the x, y, z outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CompassAdc {
    /// Counts of the x, y, z channels (body FRD).
    pub counts: [u16; 3],
}

/// Hard-iron bias and per-axis scale correction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompassCalibration {
    /// Bias subtracted from each raw axis, gauss.
    pub bias_gauss: [f64; 3],
    /// Factor applied to each axis after removing the bias.
    pub scale: [f64; 3],
}

impl Default for CompassCalibration {
    /// Zero bias, unit scale: no correction.
    fn default() -> Self {
        CompassCalibration {
            bias_gauss: [0.0; 3],
            scale: [1.0; 3],
        }
    }
}

/// A magnetic field vector in the body frame (FRD).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct MagField {
    /// Field along body x, y, z, gauss.
    pub field_gauss: [f64; 3],
}

impl CompassAdc {
    /// The uncalibrated field: `(volts − 2.5) / 1 V/gauss` on each axis.
    pub fn raw_field(&self) -> MagField {
        MagField {
            field_gauss: self
                .counts
                .map(|c| (adc::counts_to_volts(c) - NULL_V) / SENSITIVITY_V_PER_GAUSS),
        }
    }

    /// The counts the sensor and ADC would give for a field: the inverse of
    /// [`raw_field`](Self::raw_field), rounded and clamped to the ADC range.
    pub fn from_field(field: &MagField) -> Self {
        CompassAdc {
            counts: field
                .field_gauss
                .map(|b| adc::volts_to_counts(NULL_V + b * SENSITIVITY_V_PER_GAUSS)),
        }
    }
}

impl CompassCalibration {
    /// The corrected field, `(raw − bias) · scale` per axis.
    pub fn apply(&self, raw: &MagField) -> MagField {
        let mut out = [0.0; 3];
        for (i, o) in out.iter_mut().enumerate() {
            let r = raw.field_gauss.get(i).copied().unwrap_or(0.0);
            let b = self.bias_gauss.get(i).copied().unwrap_or(0.0);
            let s = self.scale.get(i).copied().unwrap_or(1.0);
            *o = (r - b) * s;
        }
        MagField { field_gauss: out }
    }
}

/// Magnetic heading (rad, (-pi, pi], 0 = magnetic north, positive clockwise seen from above) of a body-frame field,
/// tilt-compensated with roll and pitch (rad, ZYX Euler). Returns None if the horizontal field is too small (< 1e-6 gauss).
///
/// The body field is rotated into the level frame,
/// `Xh = bx cosθ + by sinφ sinθ + bz cosφ sinθ`, `Yh = by cosφ − bz sinφ`,
/// and the heading is `atan2(−Yh, Xh)`. Non-finite inputs give `None`.
pub fn heading_rad(field: &MagField, roll_rad: f64, pitch_rad: f64) -> Option<f64> {
    let [bx, by, bz] = field.field_gauss;
    let (sr, cr) = (libm::sin(roll_rad), libm::cos(roll_rad));
    let (sp, cp) = (libm::sin(pitch_rad), libm::cos(pitch_rad));
    let xh = bx * cp + by * sr * sp + bz * cr * sp;
    let yh = by * cr - bz * sr;
    let horizontal = libm::sqrt(xh * xh + yh * yh);
    if !horizontal.is_finite() || horizontal < MIN_HORIZONTAL_GAUSS {
        return None;
    }
    let psi = libm::atan2(-yh, xh);
    // atan2 gives [-pi, pi]; fold -pi onto pi.
    if psi <= -core::f64::consts::PI {
        Some(core::f64::consts::PI)
    } else {
        Some(psi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use proptest::prelude::*;

    /// Body-from-NED rotation R(ψ,θ,φ)^T applied to a NED vector (ZYX Euler).
    fn ned_to_body(v: [f64; 3], roll: f64, pitch: f64, yaw: f64) -> [f64; 3] {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        // R = Rz(yaw) Ry(pitch) Rx(roll), body -> NED.
        let r = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        let mut out = [0.0; 3];
        for (i, o) in out.iter_mut().enumerate() {
            *o = (0..3).map(|k| r[k][i] * v[k]).sum();
        }
        out
    }

    fn angle_diff(a: f64, b: f64) -> f64 {
        let d = (a - b).rem_euclid(2.0 * PI);
        d.min(2.0 * PI - d)
    }

    const NED_FIELD: [f64; 3] = [0.2, 0.0, 0.4];

    #[test]
    fn level_cardinal_headings() {
        for (yaw, want) in [
            (0.0, 0.0),
            (PI / 2.0, PI / 2.0),
            (-PI / 2.0, -PI / 2.0),
            (PI, PI),
        ] {
            let b = ned_to_body(NED_FIELD, 0.0, 0.0, yaw);
            let h = heading_rad(&MagField { field_gauss: b }, 0.0, 0.0).unwrap();
            assert!(angle_diff(h, want) < 1e-12, "yaw {yaw}: {h}");
            assert!(h > -PI && h <= PI);
        }
        // Exactly south with a -0.0 east component folds to +pi.
        let h = heading_rad(
            &MagField {
                field_gauss: [-0.2, 0.0, 0.4],
            },
            0.0,
            0.0,
        )
        .unwrap();
        assert_eq!(h, PI);
        let h = heading_rad(
            &MagField {
                field_gauss: [-0.2, -0.0, 0.4],
            },
            0.0,
            0.0,
        )
        .unwrap();
        assert_eq!(h, PI);
    }

    #[test]
    fn vertical_or_bad_field_gives_none() {
        assert_eq!(
            heading_rad(
                &MagField {
                    field_gauss: [0.0, 0.0, 0.5]
                },
                0.0,
                0.0
            ),
            None
        );
        assert_eq!(heading_rad(&MagField::default(), 0.3, 0.2), None);
        assert_eq!(
            heading_rad(
                &MagField {
                    field_gauss: [f64::NAN, 0.0, 0.0]
                },
                0.0,
                0.0
            ),
            None
        );
        assert_eq!(
            heading_rad(
                &MagField {
                    field_gauss: [0.2, 0.0, 0.4]
                },
                f64::NAN,
                0.0
            ),
            None
        );
    }

    #[test]
    fn a_horizontal_field_of_at_least_a_microgauss_has_a_heading() {
        let level = |x: f64, y: f64| {
            heading_rad(
                &MagField {
                    field_gauss: [x, y, 0.5],
                },
                0.0,
                0.0,
            )
        };
        assert_eq!(
            level(MIN_HORIZONTAL_GAUSS, 0.0),
            Some(0.0),
            "exactly the least"
        );
        assert_eq!(level(0.1 * MIN_HORIZONTAL_GAUSS, 0.0), None);
        assert_eq!(level(0.0, 0.1 * MIN_HORIZONTAL_GAUSS), None);
    }

    #[test]
    fn adc_chain() {
        let zero = CompassAdc { counts: [2048; 3] };
        assert_eq!(zero.raw_field(), MagField::default());
        let f = MagField {
            field_gauss: [2.0, -2.0, 0.5],
        };
        let a = CompassAdc::from_field(&f);
        assert_eq!(a.counts, [3686, 410, 2458]); // 4.5 V, 0.5 V, 3.0 V
        let over = CompassAdc::from_field(&MagField {
            field_gauss: [5.0, -5.0, f64::NAN],
        });
        assert_eq!(over.counts, [4095, 0, 0]);
    }

    #[test]
    fn calibration() {
        let cal = CompassCalibration {
            bias_gauss: [0.1, -0.1, 0.0],
            scale: [2.0, 1.0, 0.5],
        };
        let out = cal.apply(&MagField {
            field_gauss: [0.3, 0.1, 0.4],
        });
        let want = [0.4, 0.2, 0.2];
        for (got, want) in out.field_gauss.iter().zip(want) {
            assert!((got - want).abs() < 1e-12);
        }
        let raw = MagField {
            field_gauss: [0.3, -0.2, 0.1],
        };
        assert_eq!(CompassCalibration::default().apply(&raw), raw);
    }

    proptest! {
        #[test]
        fn heading_recovers_yaw(
            yaw in -PI..PI,
            roll in -1.2f64..1.2,
            pitch in -1.2f64..1.2,
        ) {
            let b = ned_to_body(NED_FIELD, roll, pitch, yaw);
            let h = heading_rad(&MagField { field_gauss: b }, roll, pitch).unwrap();
            prop_assert!(angle_diff(h, yaw) < 1e-9, "yaw {} got {}", yaw, h);
            prop_assert!(h > -PI && h <= PI);
        }

        #[test]
        fn heading_through_adc_within_quantisation(yaw in -PI..PI, roll in -0.5f64..0.5, pitch in -0.5f64..0.5) {
            let b = ned_to_body(NED_FIELD, roll, pitch, yaw);
            let adc = CompassAdc::from_field(&MagField { field_gauss: b });
            let h = heading_rad(&adc.raw_field(), roll, pitch).unwrap();
            // 0.6 mV quantisation on a 0.2 gauss horizontal field: < 0.01 rad.
            prop_assert!(angle_diff(h, yaw) < 0.01);
        }

        #[test]
        fn field_round_trip(x in -2.0f64..2.0, y in -2.0f64..2.0, z in -2.0f64..2.0) {
            let f = MagField { field_gauss: [x, y, z] };
            let back = CompassAdc::from_field(&f).raw_field();
            for i in 0..3 {
                prop_assert!((back.field_gauss[i] - f.field_gauss[i]).abs() <= adc::ADC_LSB_V / 2.0 + 1e-12);
            }
        }

        #[test]
        fn counts_round_trip(c in any::<[u16; 3]>()) {
            let c = c.map(|v| v % 4096);
            let a = CompassAdc { counts: c };
            prop_assert_eq!(CompassAdc::from_field(&a.raw_field()), a);
        }
    }
}
