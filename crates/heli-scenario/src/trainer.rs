//! The trainer's panel: failures of the fault catalog triggered by hand during a live flight
//! (`heli hilsim --view ADDR --pilot`), so that a pilot learns to answer them (thesis §3.2).
//!
//! Each failure is a request from a page, checked here before anything changes, and then
//! written into the scenario's fault catalog from the current simulated time on — the same
//! faults a scenario file schedules, acting through the same devices and physics. A request
//! that makes no sense (a negative duration, an unknown channel, a field too many) is
//! refused with the reason; the flight goes on.

use serde::Deserialize;

use crate::faults::{
    EngineFault, ForcedSatellites, GpsGlitch, ServoFault, ServoFaultKind, WindChange, WindShape,
};
use crate::pilot::Channel;
use crate::scenario::Scenario;

/// Longest a triggered failure may last (s); the engine failure lasts the flight.
pub const MAX_SECONDS: f64 = 600.0;

/// A failure the trainer can trigger.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TrainerFault {
    /// The engine quits for the rest of the flight.
    EngineFailure,
    /// The engine gives at most `power` (0..1) of its full power for `seconds`.
    EnginePower {
        /// Fraction of full power.
        power: f64,
        /// How long (s).
        seconds: f64,
    },
    /// No GPS fix for `seconds`.
    GpsOutage {
        /// How long (s).
        seconds: f64,
    },
    /// The GPS reports only `satellites` for `seconds` (its fixes go on).
    GpsSatellites {
        /// Satellites reported (0-40).
        satellites: u8,
        /// How long (s).
        seconds: f64,
    },
    /// The GPS position jumps by `north_m`, `east_m` for `seconds`.
    GpsGlitch {
        /// North jump (m).
        north_m: f64,
        /// East jump (m).
        east_m: f64,
        /// How long (s).
        seconds: f64,
    },
    /// The IMU sends nothing for `seconds` (the main loop's 12 ms watchdog fires).
    ImuSilent {
        /// How long (s).
        seconds: f64,
    },
    /// The altimeter sends nothing for `seconds`.
    AltimeterSilent {
        /// How long (s).
        seconds: f64,
    },
    /// The compass reads nothing for `seconds`.
    CompassSilent {
        /// How long (s).
        seconds: f64,
    },
    /// The servo controller board sends nothing for `seconds` (no uplink frames at all,
    /// unlike a lost transmitter).
    ServoBoardSilent {
        /// How long (s).
        seconds: f64,
    },
    /// The transmitter's signal is lost for `seconds`.
    TransmitterLost {
        /// How long (s).
        seconds: f64,
    },
    /// One servo stays where it is for `seconds`.
    ServoStuck {
        /// Which servo.
        channel: Channel,
        /// How long (s).
        seconds: f64,
    },
    /// A gust of `north_mps`, `east_mps` for `seconds`.
    Gust {
        /// North component (m/s).
        north_mps: f64,
        /// East component (m/s).
        east_mps: f64,
        /// How long (s).
        seconds: f64,
    },
}

/// Why a trainer's request is refused.
#[derive(Debug)]
pub enum TrainerError {
    /// Not a request (JSON, with a known `kind`).
    Request {
        /// The request as the page wrote it (its first 120 characters).
        json: String,
        /// What is wrong.
        error: serde_json::Error,
    },
    /// A number out of its range.
    OutOfRange {
        /// Its name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The range, in words.
        range: String,
    },
}

impl std::fmt::Display for TrainerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TrainerError::Request { json, error } => write!(f, "trainer fault {json}: {error}"),
            TrainerError::OutOfRange { name, value, range } => {
                write!(f, "{name} {value}: must be {range}")
            }
        }
    }
}

impl std::error::Error for TrainerError {}

fn seconds_ok(seconds: f64) -> Result<f64, TrainerError> {
    if seconds.is_finite() && seconds > 0.0 && seconds <= MAX_SECONDS {
        Ok(seconds)
    } else {
        Err(TrainerError::OutOfRange {
            name: "seconds",
            value: seconds,
            range: format!("more than 0 and at most {MAX_SECONDS}"),
        })
    }
}

fn within(name: &'static str, value: f64, limit: f64) -> Result<f64, TrainerError> {
    if value.is_finite() && value.abs() <= limit {
        Ok(value)
    } else {
        Err(TrainerError::OutOfRange {
            name,
            value,
            range: format!("within ±{limit}"),
        })
    }
}

impl TrainerFault {
    /// Parses a request (JSON with a `kind`), naming what is wrong.
    pub fn parse(json: &str) -> Result<Self, TrainerError> {
        let fault: Self = serde_json::from_str(json).map_err(|error| TrainerError::Request {
            json: json.chars().take(120).collect(),
            error,
        })?;
        fault.check()?;
        Ok(fault)
    }

    /// Checks the numbers: durations, power, sizes.
    pub fn check(&self) -> Result<(), TrainerError> {
        match *self {
            TrainerFault::EngineFailure => Ok(()),
            TrainerFault::EnginePower { power, seconds } => {
                seconds_ok(seconds)?;
                if (0.0..=1.0).contains(&power) {
                    Ok(())
                } else {
                    Err(TrainerError::OutOfRange {
                        name: "power",
                        value: power,
                        range: "within 0..1".into(),
                    })
                }
            }
            TrainerFault::GpsGlitch {
                north_m,
                east_m,
                seconds,
            } => {
                within("north_m", north_m, 1000.0)?;
                within("east_m", east_m, 1000.0)?;
                seconds_ok(seconds).map(|_| ())
            }
            TrainerFault::Gust {
                north_mps,
                east_mps,
                seconds,
            } => {
                within("north_mps", north_mps, 30.0)?;
                within("east_mps", east_mps, 30.0)?;
                seconds_ok(seconds).map(|_| ())
            }
            TrainerFault::GpsSatellites {
                satellites,
                seconds,
            } => {
                within("satellites", f64::from(satellites), 40.0)?;
                seconds_ok(seconds).map(|_| ())
            }
            TrainerFault::GpsOutage { seconds }
            | TrainerFault::ImuSilent { seconds }
            | TrainerFault::AltimeterSilent { seconds }
            | TrainerFault::CompassSilent { seconds }
            | TrainerFault::ServoBoardSilent { seconds }
            | TrainerFault::TransmitterLost { seconds }
            | TrainerFault::ServoStuck { seconds, .. } => seconds_ok(seconds).map(|_| ()),
        }
    }

    /// Writes the failure into `scenario`'s fault catalog from `now_s` on; returns what was
    /// done, in words.
    pub fn apply(&self, scenario: &mut Scenario, now_s: f64) -> Result<String, TrainerError> {
        self.check()?;
        let until = |seconds: f64| now_s + seconds;
        let f = &mut scenario.faults;
        let said = match *self {
            TrainerFault::EngineFailure => {
                f.engine.push(EngineFault {
                    start_s: now_s,
                    end_s: f64::MAX,
                    power: 0.0,
                });
                "engine failure".to_string()
            }
            TrainerFault::EnginePower { power, seconds } => {
                f.engine.push(EngineFault {
                    start_s: now_s,
                    end_s: until(seconds),
                    power,
                });
                format!("engine at {:.0} % power for {seconds} s", power * 100.0)
            }
            TrainerFault::GpsOutage { seconds } => {
                f.gps_outages.push([now_s, until(seconds)]);
                format!("GPS outage for {seconds} s")
            }
            TrainerFault::GpsSatellites {
                satellites,
                seconds,
            } => {
                f.gps_satellites.push(ForcedSatellites {
                    start_s: now_s,
                    end_s: until(seconds),
                    satellites,
                });
                format!("GPS reports {satellites} satellites for {seconds} s")
            }
            TrainerFault::GpsGlitch {
                north_m,
                east_m,
                seconds,
            } => {
                f.gps_glitches.push(GpsGlitch {
                    start_s: now_s,
                    end_s: until(seconds),
                    north_m,
                    east_m,
                });
                format!("GPS glitch {north_m} m north, {east_m} m east for {seconds} s")
            }
            TrainerFault::ImuSilent { seconds } => {
                f.imu_silent.push([now_s, until(seconds)]);
                format!("IMU silent for {seconds} s")
            }
            TrainerFault::AltimeterSilent { seconds } => {
                f.baro_silent.push([now_s, until(seconds)]);
                format!("altimeter silent for {seconds} s")
            }
            TrainerFault::CompassSilent { seconds } => {
                f.compass_silent.push([now_s, until(seconds)]);
                format!("compass silent for {seconds} s")
            }
            TrainerFault::ServoBoardSilent { seconds } => {
                f.uplink_silent.push([now_s, until(seconds)]);
                format!("servo board silent for {seconds} s")
            }
            TrainerFault::TransmitterLost { seconds } => {
                f.transmitter_lost.push([now_s, until(seconds)]);
                format!("transmitter lost for {seconds} s")
            }
            TrainerFault::ServoStuck { channel, seconds } => {
                f.servos.push(ServoFault {
                    channel,
                    kind: ServoFaultKind::Stuck,
                    start_s: now_s,
                    end_s: until(seconds),
                    factor: 0.0,
                });
                format!("{channel:?} servo stuck for {seconds} s").to_lowercase()
            }
            TrainerFault::Gust {
                north_mps,
                east_mps,
                seconds,
            } => {
                scenario.wind_changes.push(WindChange {
                    shape: WindShape::Gust,
                    start_s: now_s,
                    end_s: until(seconds),
                    wind_ned_mps: [north_mps, east_mps, 0.0],
                });
                format!("gust {north_mps} m/s north, {east_mps} m/s east for {seconds} s")
            }
        };
        Ok(said)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_becomes_a_fault_of_the_catalog_from_now_on() {
        let mut s = crate::hover();
        let f = TrainerFault::parse(r#"{"kind":"gps-outage","seconds":5}"#).unwrap();
        assert_eq!(f.apply(&mut s, 100.0).unwrap(), "GPS outage for 5 s");
        assert_eq!(s.faults.gps_outages, vec![[100.0, 105.0]]);
        let silent = TrainerFault::parse(r#"{"kind":"servo-board-silent","seconds":3}"#).unwrap();
        assert_eq!(
            silent.apply(&mut s, 50.0).unwrap(),
            "servo board silent for 3 s"
        );
        assert_eq!(s.faults.uplink_silent, vec![[50.0, 53.0]]);
        let e = TrainerFault::parse(r#"{"kind":"engine-failure"}"#).unwrap();
        e.apply(&mut s, 101.0).unwrap();
        assert_eq!(s.faults.engine_power(100.9), 1.0);
        assert_eq!(s.faults.engine_power(101.0), 0.0);
        assert_eq!(s.faults.engine_power(1e6), 0.0);
        let stuck =
            TrainerFault::parse(r#"{"kind":"servo-stuck","channel":"aileron","seconds":2}"#)
                .unwrap();
        assert_eq!(
            stuck.apply(&mut s, 102.0).unwrap(),
            "aileron servo stuck for 2 s"
        );
        let gust = TrainerFault::parse(r#"{"kind":"gust","north_mps":0,"east_mps":6,"seconds":3}"#)
            .unwrap();
        gust.apply(&mut s, 103.0).unwrap();
        assert!((s.wind_at(104.0, 10.0).y - 6.0).abs() < 1e-9);
        assert_eq!(s.wind_at(107.0, 10.0).y, 0.0);
    }

    #[test]
    fn nonsense_is_refused_with_the_reason() {
        for (json, says) in [
            (r#"{"kind":"gps-outage","seconds":-1}"#, "seconds -1"),
            (
                r#"{"kind":"gps-satellites","satellites":41,"seconds":5}"#,
                "satellites 41",
            ),
            (r#"{"kind":"gps-outage","seconds":1e9}"#, "at most 600"),
            (r#"{"kind":"gps-outage"}"#, "missing field `seconds`"),
            (
                r#"{"kind":"engine-power","power":2,"seconds":3}"#,
                "power 2",
            ),
            (
                r#"{"kind":"meteor","seconds":3}"#,
                "unknown variant `meteor`",
            ),
            (
                r#"{"kind":"servo-stuck","channel":"wing","seconds":3}"#,
                "wing",
            ),
            (
                r#"{"kind":"gust","north_mps":99,"east_mps":0,"seconds":3}"#,
                "north_mps 99",
            ),
            (
                r#"{"kind":"imu-silent","seconds":1,"extra":1}"#,
                "unknown field `extra`",
            ),
            ("not json", "trainer fault not json"),
        ] {
            let err = TrainerFault::parse(json).unwrap_err().to_string();
            assert!(err.contains(says), "{json}: {err}");
        }
    }
}
