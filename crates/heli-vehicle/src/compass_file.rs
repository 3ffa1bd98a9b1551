//! The compass calibration file: the hard-iron bias and the scale of each axis, as the lab
//! measured them and the vehicle keeps them in its flash (TOML: `bias_gauss = [x, y, z]`,
//! `scale = [x, y, z]`). The HILSim writes its simulated compass's into its directory.

use std::fmt;
use std::path::{Path, PathBuf};

use heli_proto::compass::CompassCalibration;

/// The file the HILSim leaves in its directory for the vehicle.
pub const HIL_FILE_NAME: &str = "compass-cal.toml";

/// Why a calibration file cannot be used.
#[derive(Debug)]
pub struct CompassFileError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub why: String,
}

impl fmt::Display for CompassFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "compass calibration {}: {}",
            self.path.display(),
            self.why
        )
    }
}

impl std::error::Error for CompassFileError {}

/// Reads a calibration file.
pub fn read(path: &Path) -> Result<CompassCalibration, CompassFileError> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Cal {
        bias_gauss: [f64; 3],
        scale: [f64; 3],
    }
    let error = |why: String| CompassFileError {
        path: path.to_path_buf(),
        why,
    };
    let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    let cal: Cal = toml::from_str(&text).map_err(|e| error(e.to_string()))?;
    if !cal
        .bias_gauss
        .iter()
        .chain(&cal.scale)
        .all(|v| v.is_finite())
    {
        return Err(error("values must be finite".into()));
    }
    Ok(CompassCalibration {
        bias_gauss: cal.bias_gauss,
        scale: cal.scale,
    })
}

/// Writes a calibration file.
pub fn write(path: &Path, cal: &CompassCalibration) -> Result<(), CompassFileError> {
    let text = format!(
        "# Compass calibration (hard-iron bias and scale), as stored in the vehicle's flash.\nbias_gauss = {:?}\nscale = {:?}\n",
        cal.bias_gauss, cal.scale
    );
    std::fs::write(path, text).map_err(|e| CompassFileError {
        path: path.to_path_buf(),
        why: format!("writing: {e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_calibration_reads_back_and_a_bad_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(HIL_FILE_NAME);
        let cal = CompassCalibration {
            bias_gauss: [0.01, -0.02, 0.125],
            scale: [1.0, 0.98, 1.03],
        };
        write(&path, &cal).unwrap();
        assert_eq!(read(&path).unwrap(), cal);
        std::fs::write(
            &path,
            "bias_gauss = [0.0, 0.0, nan]\nscale = [1.0, 1.0, 1.0]\n",
        )
        .unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.ends_with("values must be finite"), "{e}");
        std::fs::write(&path, "bias_gauss = [0.0, 0.0, 0.0]\n").unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains("missing field `scale`"), "{e}");
        let e = read(&dir.path().join("none.toml")).unwrap_err().to_string();
        assert!(e.starts_with("compass calibration "), "{e}");
        let e = write(&dir.path().join("no/such/dir.toml"), &cal).unwrap_err();
        assert!(e.to_string().contains("writing: "), "{e}");
    }
}
