//! The flight computer's device inputs as log messages (channel `device`), so a flight can be
//! replayed from its log: every byte each port delivered, every compass reading and every
//! timer tick, with the time the flight computer took it and in the order it took them.
//!
//! Message fields: `kind` (`start`, `restart`, `bytes`, `compass`, `port_failed`, `tick`, …), and for bytes `port`
//! (`imu`, `scb`, `gps`, `baro`) and `hex` (the bytes, two lowercase hex digits each); for a
//! compass reading `counts` (x, y, z); for a failed port `port`.

use heli_fsw::RecordedInput;
use heli_proto::battery::BatteryAdc;
use heli_proto::compass::CompassAdc;
use heli_types::Port;
use serde_json::{Value, json};

/// The log channel of the device inputs.
pub const CHANNEL: &str = "device";

/// What the channel holds: the moment the flight computer was started, then its inputs.
#[derive(Clone, Debug, PartialEq)]
pub enum Logged {
    /// [`heli_fsw::FlightComputer::start`] was called at this message's time.
    Start,
    /// A new flight computer was started at this message's time in place of the one before
    /// (a simulated brown-out's end: the lockstep's one log holds both processes), from the
    /// record its predecessor left — the text of the vehicle's warm-start file — or, `None`,
    /// from nothing (a cold start).
    Restart {
        /// The warm-start record, in the vehicle's warm-start file format.
        warm_start: Option<String>,
    },
    /// An input.
    Input(RecordedInput),
}

/// What is wrong with a message of the channel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InputError {
    /// No `kind`.
    NoKind,
    /// A `kind` that is no input's.
    UnknownKind(String),
    /// A port name that is no port's.
    UnknownPort(String),
    /// A field the kind needs is missing or not what it must be.
    Field {
        /// The kind.
        kind: &'static str,
        /// What it needs.
        needs: &'static str,
    },
    /// `hex` that is not bytes in hex.
    NotHex(String),
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InputError::NoKind => write!(f, "input without 'kind'"),
            InputError::UnknownKind(k) => write!(f, "unknown input kind '{k}'"),
            InputError::UnknownPort(p) => write!(f, "unknown port '{p}'"),
            InputError::Field { kind, needs } => write!(f, "{kind} without {needs}"),
            InputError::NotHex(hex) => write!(f, "not hex: '{hex:.64}'"),
        }
    }
}

impl std::error::Error for InputError {}

/// The message that marks the flight computer's start.
pub fn start_json() -> Value {
    json!({"kind": "start"})
}

/// The message that marks a new flight computer started in place of the one before, from
/// `warm_start` (the warm-start file's text) or from nothing.
pub fn restart_json(warm_start: Option<&str>) -> Value {
    json!({"kind": "restart", "warm_start": warm_start})
}

/// A message of the channel back; `Err` says what is wrong with it.
pub fn logged_from_json(value: &Value) -> Result<Logged, InputError> {
    match value.get("kind").and_then(Value::as_str) {
        Some("start") => Ok(Logged::Start),
        Some("restart") => match value.get("warm_start") {
            None | Some(Value::Null) => Ok(Logged::Restart { warm_start: None }),
            Some(Value::String(text)) => Ok(Logged::Restart {
                warm_start: Some(text.clone()),
            }),
            Some(_) => Err(InputError::Field {
                kind: "restart",
                needs: "'warm_start' text or null",
            }),
        },
        _ => input_from_json(value).map(Logged::Input),
    }
}

/// An input as a log message.
pub fn input_json(input: &RecordedInput) -> Value {
    match input {
        RecordedInput::Bytes(port, bytes) => {
            json!({"kind": "bytes", "port": port.name(), "hex": to_hex(bytes)})
        }
        RecordedInput::Compass(adc) => json!({"kind": "compass", "counts": adc.counts}),
        RecordedInput::PortFailed(port) => json!({"kind": "port_failed", "port": port.name()}),
        RecordedInput::Tick => json!({"kind": "tick"}),
        RecordedInput::Battery(adc) => json!({"kind": "battery", "adc": adc.counts}),
        RecordedInput::GroundLink(fresh) => json!({"kind": "ground_link", "fresh": fresh}),
        RecordedInput::PowerLine(high) => json!({"kind": "power_line", "high": high}),
        RecordedInput::StopRequested => json!({"kind": "stop_requested"}),
    }
}

/// A log message back as an input; `Err` says what is wrong with it.
pub fn input_from_json(value: &Value) -> Result<RecordedInput, InputError> {
    let port = || {
        let name = value.get("port").and_then(Value::as_str).unwrap_or("");
        Port::from_name(name).ok_or_else(|| InputError::UnknownPort(name.to_string()))
    };
    match value.get("kind").and_then(Value::as_str) {
        Some("bytes") => {
            let hex = value
                .get("hex")
                .and_then(Value::as_str)
                .ok_or(InputError::Field {
                    kind: "bytes",
                    needs: "'hex'",
                })?;
            Ok(RecordedInput::Bytes(port()?, from_hex(hex)?))
        }
        Some("compass") => {
            let counts: Vec<u16> = value
                .get("counts")
                .and_then(Value::as_array)
                .map(|a| {
                    a.iter()
                        .filter_map(|c| c.as_u64().and_then(|c| u16::try_from(c).ok()))
                        .collect()
                })
                .unwrap_or_default();
            match counts.as_slice() {
                [x, y, z] => Ok(RecordedInput::Compass(CompassAdc {
                    counts: [*x, *y, *z],
                })),
                _ => Err(InputError::Field {
                    kind: "compass",
                    needs: "three counts",
                }),
            }
        }
        Some("port_failed") => Ok(RecordedInput::PortFailed(port()?)),
        Some("tick") => Ok(RecordedInput::Tick),
        Some("battery") => value
            .get("adc")
            .and_then(Value::as_u64)
            .and_then(|c| u16::try_from(c).ok())
            .map(|counts| RecordedInput::Battery(BatteryAdc { counts }))
            .ok_or(InputError::Field {
                kind: "battery",
                needs: "its 'adc' counts",
            }),
        Some("ground_link") => value
            .get("fresh")
            .and_then(Value::as_bool)
            .map(RecordedInput::GroundLink)
            .ok_or(InputError::Field {
                kind: "ground_link",
                needs: "'fresh'",
            }),
        Some("power_line") => value
            .get("high")
            .and_then(Value::as_bool)
            .map(RecordedInput::PowerLine)
            .ok_or(InputError::Field {
                kind: "power_line",
                needs: "'high'",
            }),
        Some("stop_requested") => Ok(RecordedInput::StopRequested),
        Some(other) => Err(InputError::UnknownKind(other.to_string())),
        None => Err(InputError::NoKind),
    }
}

fn to_hex(bytes: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(bytes.len().saturating_mul(2));
    for b in bytes {
        for nibble in [b >> 4, b & 0x0f] {
            if let Some(d) = DIGITS.get(usize::from(nibble)) {
                s.push(char::from(*d));
            }
        }
    }
    s
}

fn from_hex(hex: &str) -> Result<Vec<u8>, InputError> {
    let digit = |c: u8| match c {
        b'0'..=b'9' => Some(c.wrapping_sub(b'0')),
        b'a'..=b'f' => Some(c.wrapping_sub(b'a').wrapping_add(10)),
        b'A'..=b'F' => Some(c.wrapping_sub(b'A').wrapping_add(10)),
        _ => None,
    };
    let bytes = hex.as_bytes();
    if !bytes.len().is_multiple_of(2) {
        return Err(InputError::NotHex(hex.to_string()));
    }
    bytes
        .chunks(2)
        .map(|pair| match pair {
            [h, l] => match (digit(*h), digit(*l)) {
                (Some(h), Some(l)) => Ok((h << 4) | l),
                _ => Err(InputError::NotHex(hex.to_string())),
            },
            _ => Err(InputError::NotHex(hex.to_string())),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_round_trips_and_bad_messages_are_named() {
        let inputs = [
            RecordedInput::Bytes(Port::Scb, vec![0x00, 0xa5, 0xff, 0x10]),
            RecordedInput::Compass(CompassAdc {
                counts: [1, 2048, 4095],
            }),
            RecordedInput::PortFailed(Port::Gps),
            RecordedInput::Tick,
            RecordedInput::Battery(BatteryAdc { counts: 3012 }),
            RecordedInput::GroundLink(false),
            RecordedInput::PowerLine(true),
            RecordedInput::StopRequested,
        ];
        for i in &inputs {
            // Every kind is listed above: a new one fails to compile here until it is.
            match i {
                RecordedInput::Bytes(..)
                | RecordedInput::Compass(_)
                | RecordedInput::PortFailed(_)
                | RecordedInput::Tick
                | RecordedInput::Battery(_)
                | RecordedInput::GroundLink(_)
                | RecordedInput::PowerLine(_)
                | RecordedInput::StopRequested => {}
            }
            assert_eq!(input_from_json(&input_json(i)).as_ref(), Ok(i));
            // And each as written conforms to the channel's schema.
            let schema = crate::schema::for_topic(CHANNEL).json;
            assert_eq!(
                crate::schema::validate(&schema, &input_json(i), CHANNEL),
                Ok(()),
                "{i:?}"
            );
        }
        assert_eq!(
            crate::schema::validate(
                &crate::schema::for_topic(CHANNEL).json,
                &start_json(),
                CHANNEL
            ),
            Ok(())
        );
        let bad = json!({"kind": "bytes", "port": "imu", "hex": "0g"});
        assert!(
            input_from_json(&bad)
                .unwrap_err()
                .to_string()
                .contains("not hex")
        );
        let bad = json!({"kind": "bytes", "port": "tty", "hex": "00"});
        assert!(
            input_from_json(&bad)
                .unwrap_err()
                .to_string()
                .contains("tty")
        );
        assert!(input_from_json(&json!({"kind": "x"})).is_err());
        assert!(input_from_json(&json!(3)).is_err());
        assert_eq!(logged_from_json(&start_json()), Ok(Logged::Start));
    }

    #[test]
    fn a_restart_marker_carries_its_record_or_none_and_conforms_to_the_schema() {
        let schema = crate::schema::for_topic(CHANNEL).json;
        for warm in [Some("start = sim autonomous\nairborne = true\n"), None] {
            let message = restart_json(warm);
            assert_eq!(
                logged_from_json(&message),
                Ok(Logged::Restart {
                    warm_start: warm.map(str::to_string)
                })
            );
            assert_eq!(crate::schema::validate(&schema, &message, CHANNEL), Ok(()));
        }
        let bad = json!({"kind": "restart", "warm_start": 3});
        let why = logged_from_json(&bad).unwrap_err().to_string();
        assert!(
            why.contains("restart") && why.contains("warm_start"),
            "{why}"
        );
        // A restart that is not one of the channel's kinds would be refused by the schema.
        let wrong = json!({"kind": "reboot"});
        assert!(crate::schema::validate(&schema, &wrong, CHANNEL).is_err());
    }
}
