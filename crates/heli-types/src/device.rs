//! The devices the flight software watches and the serial ports of the flight computer,
//! by the names every side uses (log channels, device paths, displays, scenario files).

/// A device watched by the flight software (each has its watchdog).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Device {
    /// The inertial measurement unit (times the main loop).
    Imu,
    /// The servo controller board's pilot uplink.
    Uplink,
    /// The GPS receiver.
    Gps,
    /// The barometric altimeter.
    Baro,
    /// The compass (analog channels).
    Compass,
}

impl Device {
    /// Every device, in a fixed order.
    pub const ALL: [Device; 5] = [
        Device::Imu,
        Device::Uplink,
        Device::Gps,
        Device::Baro,
        Device::Compass,
    ];

    /// Short name for logs and displays.
    pub const fn name(self) -> &'static str {
        match self {
            Device::Imu => "imu",
            Device::Uplink => "uplink",
            Device::Gps => "gps",
            Device::Baro => "baro",
            Device::Compass => "compass",
        }
    }

    /// The device named `name` (see [`Device::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }
}

/// A serial port of the flight computer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Port {
    /// The IMU (in only).
    Imu,
    /// The servo controller board (pilot uplink in, servo commands out).
    Scb,
    /// The GPS receiver (in only).
    Gps,
    /// The barometric altimeter (readings in, handshake commands out).
    Baro,
}

impl Port {
    /// Every serial port, in a fixed order.
    pub const ALL: [Port; 4] = [Port::Imu, Port::Scb, Port::Gps, Port::Baro];

    /// Short name, as used for device paths and log channels.
    pub const fn name(self) -> &'static str {
        match self {
            Port::Imu => "imu",
            Port::Scb => "scb",
            Port::Gps => "gps",
            Port::Baro => "baro",
        }
    }

    /// The port named `name` (see [`Port::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The device whose samples arrive on this port.
    pub const fn device(self) -> Device {
        match self {
            Port::Imu => Device::Imu,
            Port::Scb => Device::Uplink,
            Port::Gps => Device::Gps,
            Port::Baro => Device::Baro,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_each_port_feeds_its_device() {
        for d in Device::ALL {
            assert_eq!(Device::from_name(d.name()), Some(d));
        }
        for p in Port::ALL {
            assert_eq!(Port::from_name(p.name()), Some(p));
        }
        assert_eq!(Device::from_name("battery"), None);
        assert_eq!(Port::from_name("uplink"), None);
        let fed: Vec<_> = Port::ALL.iter().map(|p| p.device().name()).collect();
        assert_eq!(fed, ["imu", "uplink", "gps", "baro"]);
        let ports: Vec<_> = Port::ALL.iter().map(|p| p.name()).collect();
        assert_eq!(ports, ["imu", "scb", "gps", "baro"]);
    }
}
