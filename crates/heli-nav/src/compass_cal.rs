//! The compass calibration routine: with the helicopter turned through many headings and
//! tilts on the ground, the readings lie on a sphere whose centre is the field the avionics
//! themselves make (hard iron). A least-squares sphere fit finds it; the flight software
//! subtracts it from every reading (the thesis's "bias parameters stored in the onboard flash
//! memory following a simple calibration routine").

use heli_proto::compass::{CompassCalibration, MagField};
use nalgebra::{Matrix4, Vector4};

/// Why a calibration could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrationError {
    /// Fewer than ten readings.
    TooFewReadings,
    /// The readings do not span enough orientations to locate the sphere's centre.
    PoorCoverage,
    /// A reading holds a value that is not a number, or one so large that the fit's sums
    /// of squares are not.
    NotFinite,
}

/// Fits the hard-iron bias to readings taken in many orientations.
pub fn fit_hard_iron(readings: &[MagField]) -> Result<CompassCalibration, CalibrationError> {
    if readings.len() < 10 {
        return Err(CalibrationError::TooFewReadings);
    }
    // |m − c|² = r²  ⇔  2 m·c + (r² − |c|²) = |m|²: linear in (c, k).
    let mut ata = Matrix4::<f64>::zeros();
    let mut atb = Vector4::<f64>::zeros();
    for r in readings {
        let [x, y, z] = r.field_gauss;
        let row = Vector4::new(2.0 * x, 2.0 * y, 2.0 * z, 1.0);
        ata += row * row.transpose();
        atb += row * (x * x + y * y + z * z);
    }
    if !(ata.iter().all(|x| x.is_finite()) && atb.iter().all(|x| x.is_finite())) {
        return Err(CalibrationError::NotFinite);
    }
    // Ill-conditioned when the readings cover too little of the sphere: the smallest
    // eigenvalue of the normal equations under a millionth of the largest.
    let eig = ata.symmetric_eigenvalues();
    let (min, max) = eig.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &e| {
        (lo.min(e), hi.max(e))
    });
    if min <= 1e-6 * max {
        return Err(CalibrationError::PoorCoverage);
    }
    let sol = ata
        .cholesky()
        .ok_or(CalibrationError::PoorCoverage)?
        .solve(&atb);
    Ok(CompassCalibration {
        bias_gauss: [sol.x, sol.y, sol.z],
        scale: [1.0; 3],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn finds_the_avionics_field_from_readings_on_the_ground() {
        let hard = Vector3::new(0.06, -0.04, 0.09);
        let readings = turned(&[-0.5, 0.0, 0.5], 24, hard);
        let cal = fit_hard_iron(&readings).unwrap_or_else(|e| panic!("{e:?}"));
        for i in 0..3 {
            assert!((cal.bias_gauss[i] - hard[i]).abs() < 1e-9, "{cal:?}");
        }
    }

    #[test]
    fn one_orientation_is_not_a_calibration() {
        let same = vec![
            MagField {
                field_gauss: [0.2, 0.0, 0.5]
            };
            50
        ];
        assert_eq!(fit_hard_iron(&same), Err(CalibrationError::PoorCoverage));
        assert_eq!(
            fit_hard_iron(&same[..3]),
            Err(CalibrationError::TooFewReadings)
        );
    }

    /// Readings of the earth's field plus `hard`, turned through 24 headings at each of
    /// `tilts` (rad).
    fn turned(tilts: &[f64], headings: u32, hard: Vector3<f64>) -> Vec<MagField> {
        let earth = Vector3::new(0.19, 0.0, 0.48);
        let mut readings = Vec::new();
        for &tilt in tilts {
            for k in 0..headings {
                let yaw = f64::from(k) * std::f64::consts::TAU / f64::from(headings);
                let att = UnitQuaternion::from_euler_angles(tilt, 0.3 * tilt, yaw);
                let b = att.inverse() * earth + hard;
                readings.push(MagField {
                    field_gauss: [b.x, b.y, b.z],
                });
            }
        }
        readings
    }

    #[test]
    fn ten_readings_are_enough_and_nine_are_not() {
        let hard = Vector3::new(0.05, 0.02, -0.03);
        let mut readings = turned(&[-0.6, 0.6], 5, hard);
        assert_eq!(readings.len(), 10);
        let cal = fit_hard_iron(&readings).unwrap_or_else(|e| panic!("{e:?}"));
        assert!(
            (Vector3::from(cal.bias_gauss) - hard).norm() < 1e-9,
            "{cal:?}"
        );
        readings.pop();
        assert_eq!(
            fit_hard_iron(&readings),
            Err(CalibrationError::TooFewReadings)
        );
    }

    #[test]
    fn a_turn_with_hardly_any_tilt_does_not_locate_the_centre() {
        // Level turns put the readings on a circle: any sphere through it fits. Tilted by a
        // ten-thousandth of a radian, the fit is possible but meaningless; refused.
        let flat = turned(&[-1e-4, 1e-4], 24, Vector3::zeros());
        assert_eq!(fit_hard_iron(&flat), Err(CalibrationError::PoorCoverage));
        let tilted = turned(&[-0.3, 0.3], 24, Vector3::zeros());
        assert!(fit_hard_iron(&tilted).is_ok());
    }

    #[test]
    fn a_reading_that_is_not_a_number_is_refused() {
        let mut readings = turned(&[-0.5, 0.5], 12, Vector3::zeros());
        readings[7].field_gauss[1] = f64::NAN;
        assert_eq!(fit_hard_iron(&readings), Err(CalibrationError::NotFinite));
        readings[7].field_gauss[1] = f64::INFINITY;
        assert_eq!(fit_hard_iron(&readings), Err(CalibrationError::NotFinite));
        // Absurd readings whose squares (1e200) or whose squares' products with the
        // reading (1e110: 1e330) overflow.
        for absurd in [1e200, 1e110] {
            readings[7].field_gauss[1] = absurd;
            assert_eq!(fit_hard_iron(&readings), Err(CalibrationError::NotFinite));
        }
    }
}
