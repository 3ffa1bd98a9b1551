//! The pilot's transmitter: its five channels and two switches, as a person flies them (a
//! gamepad or an RC transmitter on the pilot page; the scripted pilot of a scenario).

/// The sticks and switches of the pilot's transmitter. Stick conventions are the servos':
/// aileron right, elevator aft (nose up), rudder right, collective up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields)
)]
pub struct Transmitter {
    /// Lateral cyclic, −1..1 (right positive).
    pub aileron: f64,
    /// Longitudinal cyclic, −1..1 (aft positive).
    pub elevator: f64,
    /// Tail, −1..1.
    pub rudder: f64,
    /// Collective, −1..1.
    pub collective: f64,
    /// Throttle, 0..1.
    pub throttle: f64,
    /// The auto switch (the computer flies).
    pub auto: bool,
    /// The emergency bypass switch (the servo board passes the sticks straight through).
    pub bypass: bool,
}

/// A channel outside its range, or not a number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutOfRange {
    /// The channel's name.
    pub channel: &'static str,
    /// Its value.
    pub value: f64,
    /// The lowest it may be (the highest is 1).
    pub low: f64,
}

impl core::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "pilot {} {}: must be within {}..1",
            self.channel, self.value, self.low
        )
    }
}

impl std::error::Error for OutOfRange {}

impl Transmitter {
    /// Checks every channel is a number in its range, naming the first that is not.
    pub fn check(&self) -> Result<(), OutOfRange> {
        for (channel, value, low) in [
            ("aileron", self.aileron, -1.0),
            ("elevator", self.elevator, -1.0),
            ("rudder", self.rudder, -1.0),
            ("collective", self.collective, -1.0),
            ("throttle", self.throttle, 0.0),
        ] {
            if !(value.is_finite() && (low..=1.0).contains(&value)) {
                return Err(OutOfRange {
                    channel,
                    value,
                    low,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_channel_is_checked_against_its_range() {
        let centred = Transmitter {
            throttle: 0.8,
            ..Transmitter::default()
        };
        assert_eq!(centred.check(), Ok(()));
        let full = Transmitter {
            aileron: 1.0,
            elevator: -1.0,
            rudder: 1.0,
            collective: -1.0,
            throttle: 0.0,
            auto: true,
            bypass: true,
        };
        assert_eq!(full.check(), Ok(()));
        let cases = [
            (
                Transmitter {
                    aileron: 1.01,
                    ..centred
                },
                "aileron",
            ),
            (
                Transmitter {
                    elevator: -1.01,
                    ..centred
                },
                "elevator",
            ),
            (
                Transmitter {
                    rudder: f64::NAN,
                    ..centred
                },
                "rudder",
            ),
            (
                Transmitter {
                    collective: 2.0,
                    ..centred
                },
                "collective",
            ),
            (
                Transmitter {
                    throttle: -0.1,
                    ..centred
                },
                "throttle",
            ),
            (
                Transmitter {
                    throttle: 1.1,
                    ..centred
                },
                "throttle",
            ),
        ];
        for (t, channel) in cases {
            assert_eq!(t.check().map_err(|e| e.channel), Err(channel));
        }
        assert_eq!(
            Transmitter {
                throttle: -0.1,
                ..centred
            }
            .check()
            .unwrap_err()
            .to_string(),
            "pilot throttle -0.1: must be within 0..1"
        );
    }
}
