//! Where the flight computer's devices are: serial port paths and baud rates, and the ADC
//! channels of the compass and the battery.
//!
//! Read from a TOML file (`heli vehicle --devices FILE`):
//!
//! ```toml
//! [ports]
//! imu = "/dev/ttyS0"
//! scb = "/dev/ttyS1"
//! gps = "/dev/ttyS2"
//! baro = "/dev/ttyS3"
//!
//! [adc]
//! dir = "/sys/bus/iio/devices/iio:device0"
//! compass = [0, 1, 2]   # in_voltageN_raw channels of the compass x, y, z
//! battery = 3
//!
//! [gpio]                # optional: the hot-swap's line (high on the flight batteries)
//! hotswap = "gpiochip0:17"   # a GPIO character-device line, or a value file's path
//! ```
//!
//! or made for the HILSim's directory (`--hilsim DIR`): `DIR/imu`, `DIR/scb`, `DIR/gps`,
//! `DIR/baro`, `DIR/adc` with the same channel numbers, and `DIR/hotswap`.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::error::VehicleError;
use heli_types::Port;
use serde::Deserialize;

/// ADC channel numbers of the compass x, y, z in the HILSim's directory.
pub const HIL_COMPASS_CHANNELS: [u8; 3] = [0, 1, 2];
/// ADC channel number of the battery in the HILSim's directory.
pub const HIL_BATTERY_CHANNEL: u8 = 3;

/// Serial port paths.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ports {
    /// IMU.
    pub imu: PathBuf,
    /// Servo controller board.
    pub scb: PathBuf,
    /// GPS receiver.
    pub gps: PathBuf,
    /// Barometric altimeter.
    pub baro: PathBuf,
}

/// The analog channels.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adc {
    /// An IIO device directory holding `in_voltageN_raw` files.
    pub dir: PathBuf,
    /// Channels of the compass x, y, z.
    pub compass: [u8; 3],
    /// Channel of the battery divider.
    pub battery: u8,
}

/// The digital inputs.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gpio {
    /// The hot-swap's line (`gpiochipN:OFFSET`, or a value file): which battery powers the
    /// avionics. Unset: not wired, the time on each battery is not logged.
    pub hotswap: Option<String>,
}

/// Every device of the flight computer.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Devices {
    /// Serial ports.
    pub ports: Ports,
    /// Analog channels.
    pub adc: Adc,
    /// Digital inputs.
    #[serde(default)]
    pub gpio: Gpio,
}

/// A devices file that could not be used.
#[derive(Debug)]
pub enum DevicesError {
    /// The file could not be read.
    Read(PathBuf, std::io::Error),
    /// The file is not a valid devices description.
    Parse(PathBuf, VehicleError),
}

impl fmt::Display for DevicesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DevicesError::Read(p, e) => write!(f, "devices file {}: {e}", p.display()),
            DevicesError::Parse(p, e) => write!(
                f,
                "devices file {}: {e}\n(expected [ports] imu, scb, gps, baro and [adc] dir, compass = [x, y, z], battery; see docs/architecture.md)",
                p.display()
            ),
        }
    }
}

impl std::error::Error for DevicesError {}

/// Where the hot-swap's line is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HotSwapLine {
    /// A GPIO character device and the line's offset on it.
    Chip {
        /// The chip (`/dev/gpiochipN`).
        chip: PathBuf,
        /// The line's offset.
        offset: u32,
    },
    /// A file holding the line's value, `0` or `1`.
    ValueFile(PathBuf),
}

impl HotSwapLine {
    /// `gpiochipN:OFFSET` or `/dev/gpiochipN:OFFSET` is a character-device line; anything
    /// else is a value file's path.
    pub fn parse(spec: &str) -> Result<Self, VehicleError> {
        let spec = spec.trim();
        if spec.is_empty() {
            return Err(VehicleError::invalid("hotswap", "an empty line name"));
        }
        let chip_part = spec.rsplit_once(':').filter(|(chip, _)| {
            Path::new(chip)
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("gpiochip"))
        });
        match chip_part {
            Some((chip, offset)) => {
                let offset: u32 = offset.parse().map_err(|_| {
                    VehicleError::invalid(
                        format!("hotswap '{spec}'"),
                        format!("the line offset '{offset}' is not a number"),
                    )
                })?;
                let chip = if chip.contains('/') {
                    PathBuf::from(chip)
                } else {
                    Path::new("/dev").join(chip)
                };
                Ok(HotSwapLine::Chip { chip, offset })
            }
            None => Ok(HotSwapLine::ValueFile(PathBuf::from(spec))),
        }
    }
}

impl Devices {
    /// Reads a devices file.
    pub fn from_file(path: &Path) -> Result<Self, DevicesError> {
        let text = std::fs::read_to_string(path).map_err(|e| DevicesError::Read(path.into(), e))?;
        Self::from_toml(&text).map_err(|e| DevicesError::Parse(path.into(), e))
    }

    /// Parses a devices description.
    pub fn from_toml(text: &str) -> Result<Self, VehicleError> {
        let devices: Devices = toml::from_str(text).map_err(|e| VehicleError::invalid("", e))?;
        if let Some(line) = &devices.gpio.hotswap {
            HotSwapLine::parse(line).map_err(|e| e.within("gpio"))?;
        }
        let mut channels: Vec<u8> = devices.adc.compass.to_vec();
        channels.push(devices.adc.battery);
        channels.sort_unstable();
        channels.dedup();
        if channels.len() != 4 {
            return Err(VehicleError::invalid(
                "adc",
                "the compass and battery channels must be four different channels",
            ));
        }
        Ok(devices)
    }

    /// The devices of a HILSim started with `heli hilsim --ptys DIR`.
    pub fn hilsim(dir: &Path) -> Self {
        Self {
            ports: Ports {
                imu: dir.join("imu"),
                scb: dir.join("scb"),
                gps: dir.join("gps"),
                baro: dir.join("baro"),
            },
            adc: Adc {
                dir: dir.join("adc"),
                compass: HIL_COMPASS_CHANNELS,
                battery: HIL_BATTERY_CHANNEL,
            },
            gpio: Gpio {
                hotswap: Some(dir.join("hotswap").display().to_string()),
            },
        }
    }

    /// The path of a serial port.
    pub fn port(&self, port: Port) -> &Path {
        match port {
            Port::Imu => &self.ports.imu,
            Port::Scb => &self.ports.scb,
            Port::Gps => &self.ports.gps,
            Port::Baro => &self.ports.baro,
        }
    }
}

/// The line speed of a port (bit/s).
pub fn baud(port: Port) -> u32 {
    match port {
        Port::Imu => heli_proto::imu::BAUD,
        Port::Scb => heli_proto::scb::BAUD,
        Port::Gps => heli_proto::gps::BAUD,
        Port::Baro => heli_proto::baro::BAUD,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_devices_file_parses_and_bad_ones_say_what_is_wrong() {
        let good = r#"
            [ports]
            imu = "/dev/ttyS0"
            scb = "/dev/ttyS1"
            gps = "/dev/ttyS2"
            baro = "/dev/ttyS3"
            [adc]
            dir = "/sys/bus/iio/devices/iio:device0"
            compass = [0, 1, 2]
            battery = 3
        "#;
        let d = Devices::from_toml(good).unwrap();
        assert_eq!(d.port(Port::Gps), Path::new("/dev/ttyS2"));
        let missing = good.replace("baro = \"/dev/ttyS3\"", "");
        assert!(
            Devices::from_toml(&missing)
                .unwrap_err()
                .to_string()
                .contains("baro")
        );
        let clash = good.replace("battery = 3", "battery = 2");
        assert!(
            Devices::from_toml(&clash)
                .unwrap_err()
                .to_string()
                .contains("different")
        );
        let typo = good.replace("gps =", "gsp =");
        assert!(Devices::from_toml(&typo).is_err());
    }

    #[test]
    fn each_port_opens_at_its_devices_baud_rate_and_errors_name_the_file() {
        assert_eq!(baud(Port::Imu), heli_proto::imu::BAUD);
        assert_eq!(baud(Port::Scb), heli_proto::scb::BAUD);
        assert_eq!(baud(Port::Gps), heli_proto::gps::BAUD);
        assert_eq!(baud(Port::Baro), heli_proto::baro::BAUD);
        let missing = Devices::from_file(Path::new("/nonexistent/devices.toml")).unwrap_err();
        assert!(
            missing
                .to_string()
                .starts_with("devices file /nonexistent/devices.toml: "),
            "{missing}"
        );
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("devices.toml");
        std::fs::write(&bad, "[ports]\nimu = 3\n").unwrap();
        let e = Devices::from_file(&bad).unwrap_err().to_string();
        assert!(
            e.contains(&bad.display().to_string()) && e.contains("expected [ports]"),
            "{e}"
        );
    }
}
