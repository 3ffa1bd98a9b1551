//! The JSON Schema of every channel: its fields, their types, and their units in each field's
//! `description` (units are also in the field names: `pos_ned_m`, `rate_body_rps`).
//!
//! The schemas describe exactly what [`crate::records::record_json`],
//! [`crate::events::event_json`] and [`crate::foxglove`] write: the tests check every kind of
//! message against its schema with [`validate`], a checker for the part of JSON Schema used
//! here (`type`, `properties` with no others allowed, `required`, `items`, `minItems`,
//! `maxItems`, `enum`, `oneOf` of `const`s, `minimum`, `maximum`).

use std::fmt;

use serde_json::{Value, json};

use crate::foxglove;

/// A channel's schema: its name (the MCAP Schema record's) and its JSON Schema.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelSchema {
    /// `heli.<topic>` for heli's channels, `foxglove.<Type>` for the Foxglove views.
    pub name: String,
    /// The JSON Schema.
    pub json: Value,
}

fn number(description: &str) -> Value {
    json!({ "type": "number", "description": description })
}

fn integer(description: &str, minimum: u64, maximum: u64) -> Value {
    json!({ "type": "integer", "minimum": minimum, "maximum": maximum, "description": description })
}

fn boolean(description: &str) -> Value {
    json!({ "type": "boolean", "description": description })
}

fn string(description: &str) -> Value {
    json!({ "type": "string", "description": description })
}

fn vec3(description: &str) -> Value {
    json!({
        "type": "array", "items": { "type": "number" }, "minItems": 3, "maxItems": 3,
        "description": description,
    })
}

fn or_null(mut schema: Value) -> Value {
    let kind = schema["type"].clone();
    schema["type"] = json!([kind, "null"]);
    schema
}

fn object(topic: &str, description: &str, fields: &[(&str, Value)]) -> ChannelSchema {
    let properties: serde_json::Map<String, Value> = fields
        .iter()
        .map(|(name, schema)| (name.to_string(), schema.clone()))
        .collect();
    let required: Vec<&str> = fields.iter().map(|(name, _)| *name).collect();
    let name = format!("heli.{topic}");
    ChannelSchema {
        json: json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": name,
            "description": description,
            "type": "object",
            "properties": properties,
            "required": required,
            "additionalProperties": false,
        }),
        name,
    }
}

/// The schema of a channel. A topic heli does not write gets an open object schema named
/// `heli.<topic>`.
pub fn for_topic(topic: &str) -> ChannelSchema {
    let normalised = "(normalised: -1 full left/down/nose left .. 1; dimensionless)";
    match topic {
        "imu" => object(
            topic,
            "IMU sample, every main-loop iteration (100 Hz)",
            &[
                ("rate_rps", vec3("body angular rates p, q, r (rad/s)")),
                (
                    "accel_mps2",
                    vec3("specific force along body x, y, z, FRD (m/s^2)"),
                ),
                ("temp_c", number("sensor temperature (degC)")),
                (
                    "repeated",
                    boolean("no packet came in time: the watchdog repeated the previous sample"),
                ),
            ],
        ),
        "state" => object(
            topic,
            "state estimate, phase and target, every control step (50 Hz)",
            &[
                (
                    "phase",
                    string(
                        "what the flight software is doing (calibrating, manual, takeoff, hold, ...)",
                    ),
                ),
                (
                    "roll_rad",
                    number("roll angle, ZYX Euler, body to NED (rad)"),
                ),
                ("pitch_rad", number("pitch angle, ZYX Euler (rad)")),
                ("yaw_rad", number("heading, ZYX Euler, from north (rad)")),
                (
                    "pos_ned_m",
                    vec3(
                        "position, north-east-down about the navigation origin, the first GPS fix (m)",
                    ),
                ),
                ("vel_ned_mps", vec3("velocity, north-east-down (m/s)")),
                (
                    "rate_body_rps",
                    vec3("bias-corrected body angular rates p, q, r (rad/s)"),
                ),
                ("gyro_bias_rps", vec3("estimated gyro biases (rad/s)")),
                (
                    "accel_bias_mps2",
                    vec3("estimated accelerometer biases (m/s^2)"),
                ),
                (
                    "target_ned_m",
                    or_null(vec3(
                        "where the controller holds the helicopter, NED (m); null outside autonomous phases",
                    )),
                ),
            ],
        ),
        "servo" => object(
            topic,
            "servo command sent to the servo controller board (50 Hz)",
            &[
                ("aileron", number(&format!("lateral cyclic {normalised}"))),
                (
                    "elevator",
                    number(&format!("longitudinal cyclic {normalised}")),
                ),
                ("rudder", number(&format!("tail rotor pitch {normalised}"))),
                (
                    "collective",
                    number(&format!("main rotor collective pitch {normalised}")),
                ),
                (
                    "throttle",
                    number("throttle (0 closed .. 1 open; dimensionless)"),
                ),
                ("rotor_rpm", integer("governor set point (rpm)", 0, 65535)),
            ],
        ),
        "uplink" => object(
            topic,
            "pilot uplink from the servo controller board (50 Hz)",
            &[
                (
                    "rotor_rpm",
                    integer("main rotor speed from the governor pick-up (rpm)", 0, 65535),
                ),
                (
                    "aileron_us",
                    integer("pilot's aileron pulse width (us)", 0, 65535),
                ),
                (
                    "elevator_us",
                    integer("pilot's elevator pulse width (us)", 0, 65535),
                ),
                (
                    "rudder_us",
                    integer("pilot's rudder pulse width (us)", 0, 65535),
                ),
                (
                    "collective_us",
                    integer("pilot's collective pulse width (us)", 0, 65535),
                ),
                (
                    "throttle_us",
                    integer("pilot's throttle pulse width (us)", 0, 65535),
                ),
                (
                    "auto",
                    boolean("auto/manual switch: true = the computer flies"),
                ),
                (
                    "bypass",
                    boolean(
                        "emergency bypass engaged: the pilot's pulses go straight to the servos",
                    ),
                ),
                ("receiver_batt_v", number("receiver battery voltage (V)")),
                ("servo_batt_v", number("servo battery voltage (V)")),
            ],
        ),
        "gps" => object(
            topic,
            "GPS navigation solution (1 Hz)",
            &[
                (
                    "tow_ms",
                    integer(
                        "GPS time of week of the solution (ms)",
                        0,
                        u64::from(u32::MAX),
                    ),
                ),
                ("lat_deg", number("geodetic latitude, north positive (deg)")),
                ("lon_deg", number("longitude, east positive (deg)")),
                ("alt_m", number("altitude above mean sea level (m)")),
                ("vel_ned_mps", vec3("velocity, north-east-down (m/s)")),
                (
                    "satellites",
                    integer("satellites used in the solution (count)", 0, 255),
                ),
                (
                    "fix",
                    string("kind of fix: NoFix, Fix2D, Fix3D or Unknown(n)"),
                ),
            ],
        ),
        "baro" => object(
            topic,
            "barometric altimeter reading (5 Hz)",
            &[
                ("pressure_mbar", number("static pressure (mbar)")),
                (
                    "alt_m",
                    or_null(number(
                        "pressure altitude (m); null before the altimeter's reference is set",
                    )),
                ),
            ],
        ),
        "compass" => object(
            topic,
            "compass reading (20 Hz)",
            &[
                (
                    "counts",
                    json!({
                        "type": "array", "items": { "type": "integer", "minimum": 0, "maximum": 65535 },
                        "minItems": 3, "maxItems": 3, "description": "ADC counts of the x, y, z outputs, body FRD (counts)",
                    }),
                ),
                (
                    "field_gauss",
                    vec3("magnetic field along body x, y, z, FRD, calibrated (gauss)"),
                ),
                (
                    "heading_rad",
                    or_null(number(
                        "magnetic heading from north (rad); null when the horizontal field is too weak",
                    )),
                ),
            ],
        ),
        "events" => object(
            topic,
            "flight-software events: calibration, phases, rolls, watchdog, GPS and transmitter loss",
            &[
                (
                    "text",
                    string("what happened, beginning with its vehicle time: t=<s> s ..."),
                ),
                (
                    "level",
                    json!({
                        "type": "string",
                        "enum": crate::EventLevel::ALL.map(|l| l.name()),
                        "description": "how much it matters: info, warning (handled), error (changes what the software does), fatal",
                    }),
                ),
            ],
        ),
        "device" => device_schema(),
        foxglove::TF_TOPIC => ChannelSchema {
            name: "foxglove.FrameTransform".into(),
            json: foxglove::frame_transform_schema(),
        },
        foxglove::FIX_TOPIC => ChannelSchema {
            name: "foxglove.LocationFix".into(),
            json: foxglove::location_fix_schema(),
        },
        crate::scene::SCENE_TOPIC => ChannelSchema {
            name: "foxglove.SceneUpdate".into(),
            json: crate::scene::scene_update_schema(),
        },
        foxglove::LOG_TOPIC => ChannelSchema {
            name: "foxglove.Log".into(),
            json: foxglove::log_schema(),
        },
        other => ChannelSchema {
            name: format!("heli.{other}"),
            json: json!({
                "title": format!("heli.{other}"),
                "description": "a channel of the log's owner, not described by heli-log",
                "type": "object",
            }),
        },
    }
}

/// The `device` channel the vehicle runtime writes (heli-vehicle's `inputs` module): every
/// device input the flight computer took, in order, so that a flight can be replayed from its
/// log. Only `kind` is always there; the other fields belong to some kinds.
fn device_schema() -> ChannelSchema {
    let ports: Vec<&str> = heli_types::Port::ALL.iter().map(|p| p.name()).collect();
    let name = "heli.device".to_string();
    ChannelSchema {
        json: json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": name,
            "description": "device inputs of the flight computer, in the order it took them (for replay)",
            "type": "object",
            "properties": {
                "kind": {
                    "type": "string", "enum": ["start", "restart", "bytes", "compass", "port_failed", "tick", "battery", "ground_link", "power_line", "stop_requested"],
                    "description": "the flight computer started (the origin of a replay), a new one started in place of the one before (a simulated brown-out's end), bytes read from a port, a compass reading, a port that failed, a timer tick, a battery reading, whether the bootstrap hears a ground station, the hot-swap's power line, or the operator's Stop",
                },
                "port": { "type": "string", "enum": ports, "description": "serial port (kinds bytes and port_failed)" },
                "hex": string("the bytes read, two lowercase hex digits per byte (kind bytes)"),
                "warm_start": {
                    "type": ["string", "null"],
                    "description": "the record the new flight computer started from, in the vehicle's warm-start file format, or null for a cold start (kind restart)",
                },
                "counts": {
                    "type": "array", "items": { "type": "integer", "minimum": 0, "maximum": 65535 },
                    "minItems": 3, "maxItems": 3,
                    "description": "compass ADC counts of x, y, z, body FRD (counts; kind compass)",
                },
                "adc": {
                    "type": "integer", "minimum": 0, "maximum": 65535,
                    "description": "the battery channel's ADC counts (kind battery)",
                },
                "fresh": {
                    "type": "boolean",
                    "description": "a ground station heard in the last 5 s (kind ground_link)",
                },
                "high": {
                    "type": "boolean",
                    "description": "the hot-swap's digital input: high when the ground battery powers the avionics (kind power_line)",
                },
            },
            "required": ["kind"],
            "additionalProperties": false,
        }),
        name,
    }
}

/// A value that breaks its schema: where (`state.pos_ned_m[2]`) and how.
#[derive(Clone, Debug, PartialEq)]
pub struct SchemaViolation {
    /// The field's path.
    pub at: String,
    /// What is wrong with it.
    pub problem: Violation,
}

/// What is wrong with a value.
#[derive(Clone, Debug, PartialEq)]
pub enum Violation {
    /// It is of none of the schema's types.
    WrongType {
        /// The value.
        value: Value,
        /// The types allowed.
        kinds: Vec<String>,
    },
    /// It is none of the `oneOf` constants.
    NoneOf(Value),
    /// It is not one of the `enum` values.
    NotInEnum {
        /// The value.
        value: Value,
        /// The values allowed.
        allowed: Vec<Value>,
    },
    /// A number below the minimum.
    BelowMinimum(f64),
    /// A number above the maximum.
    AboveMaximum(f64),
    /// A required field is missing.
    Missing(String),
    /// A field the schema does not have.
    Unknown(String),
    /// An array with too few or too many items.
    ItemCount(u64),
}

impl fmt::Display for SchemaViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let at = &self.at;
        match &self.problem {
            Violation::WrongType { value, kinds } => {
                write!(f, "{at}: {value} is not of type {kinds:?}")
            }
            Violation::NoneOf(value) => write!(f, "{at}: {value} is none of the allowed values"),
            Violation::NotInEnum { value, allowed } => {
                write!(f, "{at}: {value} is not one of {allowed:?}")
            }
            Violation::BelowMinimum(x) => write!(f, "{at}: {x} is below the minimum"),
            Violation::AboveMaximum(x) => write!(f, "{at}: {x} is above the maximum"),
            Violation::Missing(name) => write!(f, "{at}: required field {name} missing"),
            Violation::Unknown(name) => write!(f, "{at}: field {name} is not in the schema"),
            Violation::ItemCount(n) => write!(f, "{at}: {n} items"),
        }
    }
}

impl std::error::Error for SchemaViolation {}

/// Checks `value` against `schema` (the part of JSON Schema this module uses); the error
/// names the field (`state.pos_ned_m[2]`) and what is wrong with it.
pub fn validate(schema: &Value, value: &Value, at: &str) -> Result<(), SchemaViolation> {
    let fail = |problem| {
        Err(SchemaViolation {
            at: at.to_string(),
            problem,
        })
    };
    let type_ok = |kind: &str| match kind {
        "object" => value.is_object(),
        "array" => value.is_array(),
        "number" => value.is_number(),
        "integer" => value.is_u64() || value.is_i64(),
        "string" => value.is_string(),
        "boolean" => value.is_boolean(),
        "null" => value.is_null(),
        _ => false,
    };
    let kinds: Vec<&str> = match &schema["type"] {
        Value::String(kind) => vec![kind.as_str()],
        Value::Array(kinds) => kinds.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    if !kinds.is_empty() && !kinds.iter().any(|k| type_ok(k)) {
        return fail(Violation::WrongType {
            value: value.clone(),
            kinds: kinds.iter().map(|k| (*k).to_string()).collect(),
        });
    }
    if let Some(options) = schema["oneOf"].as_array()
        && !options.iter().any(|o| o["const"] == *value)
    {
        return fail(Violation::NoneOf(value.clone()));
    }
    if let Some(allowed) = schema["enum"].as_array()
        && !allowed.contains(value)
    {
        return fail(Violation::NotInEnum {
            value: value.clone(),
            allowed: allowed.clone(),
        });
    }
    if let Some(x) = value.as_f64() {
        if schema["minimum"].as_f64().is_some_and(|min| x < min) {
            return fail(Violation::BelowMinimum(x));
        }
        if schema["maximum"].as_f64().is_some_and(|max| x > max) {
            return fail(Violation::AboveMaximum(x));
        }
    }
    if let Value::Object(fields) = value {
        let properties = schema["properties"].as_object();
        for name in schema["required"].as_array().into_iter().flatten() {
            let name = name.as_str().unwrap_or_default();
            if !fields.contains_key(name) {
                return fail(Violation::Missing(name.to_string()));
            }
        }
        for (name, field) in fields {
            match properties.and_then(|p| p.get(name)) {
                Some(field_schema) => validate(field_schema, field, &format!("{at}.{name}"))?,
                None if properties.is_some() => {
                    return fail(Violation::Unknown(name.clone()));
                }
                None => {}
            }
        }
    }
    if let Value::Array(items) = value {
        let n = items.len() as u64;
        if schema["minItems"].as_u64().is_some_and(|min| n < min)
            || schema["maxItems"].as_u64().is_some_and(|max| n > max)
        {
            return fail(Violation::ItemCount(n));
        }
        for (i, item) in items.iter().enumerate() {
            validate(&schema["items"], item, &format!("{at}[{i}]"))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_heli_channel_has_a_described_schema_with_units() {
        for topic in crate::STREAMS.iter().chain(&["events"]) {
            let schema = for_topic(topic);
            assert_eq!(schema.name, format!("heli.{topic}"));
            let properties = schema.json["properties"]
                .as_object()
                .cloned()
                .unwrap_or_default();
            assert!(!properties.is_empty(), "{topic}");
            for (name, field) in properties {
                let description = field["description"].as_str().unwrap_or_default();
                assert!(description.len() > 10, "{topic}.{name} needs a description");
                // A field whose name carries a unit says it in its description too.
                let unit_suffix = name.rsplit('_').next().unwrap_or_default();
                if name.to_string().contains('_')
                    && [
                        "m", "mps", "rps", "rad", "c", "us", "v", "mbar", "gauss", "mps2", "ms",
                        "deg",
                    ]
                    .contains(&unit_suffix)
                {
                    assert!(
                        description.contains('('),
                        "{topic}.{name}: unit in parentheses"
                    );
                }
            }
        }
        assert_eq!(
            for_topic(foxglove::TF_TOPIC).name,
            "foxglove.FrameTransform"
        );
        assert_eq!(for_topic("mine").json["type"], "object");
        // The vehicle's device inputs, as heli-vehicle's inputs module documents them.
        let device = for_topic("device").json;
        for message in [
            json!({"kind": "bytes", "port": "imu", "hex": "a5010203"}),
            json!({"kind": "compass", "counts": [2048, 2000, 2100]}),
            json!({"kind": "port_failed", "port": "baro"}),
            json!({"kind": "tick"}),
            json!({"kind": "start"}),
            json!({"kind": "battery", "adc": 3012}),
            json!({"kind": "ground_link", "fresh": false}),
            json!({"kind": "power_line", "high": true}),
            json!({"kind": "stop_requested"}),
        ] {
            assert_eq!(validate(&device, &message, "device"), Ok(()), "{message}");
        }
        let usb = json!({"kind": "bytes", "port": "usb", "hex": ""});
        assert!(validate(&device, &usb, "device").is_err());
    }

    #[test]
    fn the_checker_names_what_is_wrong() {
        let schema = for_topic("baro").json;
        assert_eq!(
            validate(
                &schema,
                &json!({"pressure_mbar": 1013.0, "alt_m": null}),
                "baro"
            ),
            Ok(())
        );
        let missing = validate(&schema, &json!({"pressure_mbar": 1013.0}), "baro");
        assert!(missing.is_err_and(|e| e.to_string().contains("alt_m missing")));
        let extra = validate(
            &schema,
            &json!({"pressure_mbar": 1.0, "alt_m": 2.0, "x": 1}),
            "baro",
        );
        assert!(extra.is_err_and(|e| e.to_string().contains("field x")));
        let wrong = validate(
            &schema,
            &json!({"pressure_mbar": "high", "alt_m": 2.0}),
            "baro",
        );
        assert!(wrong.is_err_and(|e| e.to_string().contains("baro.pressure_mbar")));
        let compass = for_topic("compass").json;
        let short = json!({"counts": [1, 2], "field_gauss": [0.1, 0.2, 0.3], "heading_rad": 0.0});
        assert!(validate(&compass, &short, "compass").is_err());
    }
}
