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
    // Ill-conditioned when the readings cover too little of the sphere.
    let eig = ata.symmetric_eigenvalues();
    let (min, max) = eig.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &e| {
        (lo.min(e), hi.max(e))
    });
    if !(min.is_finite() && min > 1e-6 * max) {
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
        let earth = Vector3::new(0.19, 0.0, 0.48);
        let hard = Vector3::new(0.06, -0.04, 0.09);
        let mut readings = Vec::new();
        for tilt in [-0.5_f64, 0.0, 0.5] {
            for k in 0..24 {
                let yaw = f64::from(k) * std::f64::consts::TAU / 24.0;
                let att = UnitQuaternion::from_euler_angles(tilt, 0.3 * tilt, yaw);
                let b = att.inverse() * earth + hard;
                readings.push(MagField {
                    field_gauss: [b.x, b.y, b.z],
                });
            }
        }
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
}
