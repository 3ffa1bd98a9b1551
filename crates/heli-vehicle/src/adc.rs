//! Analog channels the way Linux exposes an ADC: an IIO device directory with one
//! `in_voltageN_raw` file per channel holding the latest conversion in counts. The same code
//! reads `/sys/bus/iio/devices/iio:deviceN` on a vehicle and the HILSim's `DIR/adc`.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why a channel could not be read.
#[derive(Debug)]
pub struct AdcError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub reason: String,
}

impl fmt::Display for AdcError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ADC channel {}: {}", self.path.display(), self.reason)
    }
}

impl std::error::Error for AdcError {}

/// The file of channel `n` in an IIO device directory.
pub fn channel_path(dir: &Path, n: u8) -> PathBuf {
    dir.join(format!("in_voltage{n}_raw"))
}

/// Reads channel `n` (counts).
pub fn read_channel(dir: &Path, n: u8) -> Result<u16, AdcError> {
    let path = channel_path(dir, n);
    let text = std::fs::read_to_string(&path).map_err(|e| AdcError {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    parse_counts(&text).ok_or_else(|| AdcError {
        path,
        reason: format!(
            "'{}' is not a count from 0 to {}",
            text.trim(),
            heli_proto::adc::ADC_MAX_COUNTS
        ),
    })
}

/// Parses the text of an `in_voltageN_raw` file.
pub fn parse_counts(text: &str) -> Option<u16> {
    text.trim()
        .parse::<u16>()
        .ok()
        .filter(|c| *c <= heli_proto::adc::ADC_MAX_COUNTS)
}

/// Writes channel `n` atomically (a temporary file renamed over the old one), so a reader
/// never sees a half-written number. Used by the HILSim.
pub fn write_channel(dir: &Path, n: u8, counts: u16) -> std::io::Result<()> {
    let path = channel_path(dir, n);
    let tmp = dir.join(format!(".in_voltage{n}_raw.tmp"));
    std::fs::write(&tmp, format!("{counts}\n"))?;
    std::fs::rename(&tmp, &path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_round_trip_and_bad_contents_are_named() {
        let dir = tempfile::tempdir().unwrap();
        write_channel(dir.path(), 2, 2048).unwrap();
        assert_eq!(read_channel(dir.path(), 2).unwrap(), 2048);
        std::fs::write(channel_path(dir.path(), 1), "banana").unwrap();
        let e = read_channel(dir.path(), 1).unwrap_err().to_string();
        assert!(e.contains("in_voltage1_raw") && e.contains("banana"), "{e}");
        assert!(read_channel(dir.path(), 7).is_err());
        assert_eq!(parse_counts("5000\n"), None);
    }
}
