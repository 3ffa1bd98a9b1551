//! Foxglove's well-known schemas, so that Foxglove's 3D, map and log panels show a flight with
//! no configuration: the pose as `foxglove.FrameTransform` (`foxglove/tf`), GPS fixes as
//! `foxglove.LocationFix` (`foxglove/fix`) and events as `foxglove.Log` (`foxglove/log`),
//! JSON-encoded with the schemas' JSON Schema form. The schemas here were written from the
//! definitions in Foxglove's `foxglove-sdk` repository (`schemas/jsonschema/*.json`): same
//! titles, fields, types and required fields; the optional fields heli does not fill are left
//! out.
//!
//! Frames. Foxglove, like ROS (REP 103), expects right-handed frames with z up; the flight
//! software works in NED (world) and FRD (body). The transform is written as
//!
//! - parent `world`: East-North-Up, origin at the navigation origin (the first GPS fix), so
//!   `x` = east, `y` = north, `z` = up (m);
//! - child `heli`: the body in Forward-Left-Up, origin at the centre of gravity.
//!
//! Translation: `(e, n, u) = (pos_ned_m[1], pos_ned_m[0], −pos_ned_m[2])`. Rotation:
//! `q_world_heli = q(NED→ENU) ⊗ q_ned_frd ⊗ q(FLU→FRD)`, where NED→ENU is a half turn about
//! the (north + east) axis and FLU→FRD a half turn about x. A level helicopter pointing north
//! has a rotation of +90° about `z` (its nose along ENU `y`).

use serde_json::{Value, json};

use crate::EventLevel;

/// Topic of the `foxglove.FrameTransform` view of the state stream.
pub const TF_TOPIC: &str = "foxglove/tf";
/// Topic of the `foxglove.LocationFix` view of the GPS stream.
pub const FIX_TOPIC: &str = "foxglove/fix";
/// Topic of the `foxglove.Log` view of the events.
pub const LOG_TOPIC: &str = "foxglove/log";
/// The world frame of the transforms: East-North-Up at the navigation origin.
pub const WORLD_FRAME: &str = "world";
/// The body frame of the transforms: Forward-Left-Up.
pub const BODY_FRAME: &str = "heli";
/// Frame of the GPS fixes.
pub const GPS_FRAME: &str = "gps";
/// The `name` field of the log messages.
pub const LOG_NAME: &str = "heli-fsw";

/// A covariance the receiver does not give.
const NO_COVARIANCE: [f64; 9] = [0.0; 9];

/// A quaternion `[w, x, y, z]`.
type Quat = [f64; 4];

/// Hamilton product `a ⊗ b`.
fn mul(a: Quat, b: Quat) -> Quat {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

/// Half turn about the north + east axis: NED coordinates to ENU.
const NED_TO_ENU: Quat = [
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
    std::f64::consts::FRAC_1_SQRT_2,
    0.0,
];
/// Half turn about x: FLU coordinates to FRD.
const FLU_TO_FRD: Quat = [0.0, 1.0, 0.0, 0.0];

/// The body-to-world rotation in Foxglove's frames (`[w, x, y, z]`, w ≥ 0) from the
/// body(FRD)-to-NED attitude `[w, x, y, z]`.
pub fn enu_flu_rotation(q_ned_frd: Quat) -> Quat {
    let q = mul(mul(NED_TO_ENU, q_ned_frd), FLU_TO_FRD);
    if q[0] < 0.0 { q.map(|c| -c) } else { q }
}

/// Foxglove's `time`: seconds and nanoseconds.
pub fn timestamp(t_us: u64) -> Value {
    json!({ "sec": t_us / 1_000_000, "nsec": (t_us % 1_000_000) * 1000 })
}

/// The pose of the helicopter as a `foxglove.FrameTransform` from `world` to `heli`, from the
/// NED position (m) and the body(FRD)-to-NED attitude `[w, x, y, z]`.
pub fn frame_transform(t_us: u64, pos_ned_m: [f64; 3], att_ned_frd: Quat) -> Value {
    let [w, x, y, z] = enu_flu_rotation(att_ned_frd);
    let [n, e, d] = pos_ned_m;
    json!({
        "timestamp": timestamp(t_us),
        "parent_frame_id": WORLD_FRAME,
        "child_frame_id": BODY_FRAME,
        "translation": { "x": e, "y": n, "z": -d },
        "rotation": { "x": x, "y": y, "z": z, "w": w },
    })
}

/// A GPS position (deg, deg, m above mean sea level) as a `foxglove.LocationFix`. The
/// receiver gives no accuracy, so the covariance is zero and its type `UNKNOWN` (0).
pub fn location_fix(t_us: u64, lat_deg: f64, lon_deg: f64, alt_m: f64) -> Value {
    json!({
        "timestamp": timestamp(t_us),
        "frame_id": GPS_FRAME,
        "latitude": lat_deg,
        "longitude": lon_deg,
        "altitude": alt_m,
        "position_covariance": NO_COVARIANCE,
        "position_covariance_type": 0,
    })
}

/// An event as a `foxglove.Log` message.
pub fn log(t_us: u64, level: EventLevel, text: &str) -> Value {
    json!({
        "timestamp": timestamp(t_us),
        "level": level.foxglove(),
        "message": text,
        "name": LOG_NAME,
        "file": "",
        "line": 0,
    })
}

fn time_schema(description: &str) -> Value {
    json!({
        "type": "object",
        "title": "time",
        "description": description,
        "properties": {
            "sec": { "type": "integer", "minimum": 0, "description": "whole seconds of vehicle clock (s)" },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999, "description": "nanoseconds past sec (ns)" },
        },
        "required": ["sec", "nsec"],
    })
}

fn xyz_schema(title: &str, description: &str, unit: &str, with_w: bool) -> Value {
    let mut properties = serde_json::Map::new();
    let axes: &[&str] = if with_w {
        &["x", "y", "z", "w"]
    } else {
        &["x", "y", "z"]
    };
    for axis in axes {
        properties.insert(
            axis.to_string(),
            json!({ "type": "number", "description": format!("{axis} component{unit}") }),
        );
    }
    json!({
        "title": title,
        "type": "object",
        "description": description,
        "properties": properties,
        "required": axes,
    })
}

/// The JSON Schema of `foxglove.FrameTransform`.
pub fn frame_transform_schema() -> Value {
    json!({
        "title": "foxglove.FrameTransform",
        "description": "Pose of the helicopter: body frame `heli` (Forward-Left-Up) in frame `world` (East-North-Up at the navigation origin)",
        "type": "object",
        "properties": {
            "timestamp": time_schema("time of the estimate (vehicle clock)"),
            "parent_frame_id": { "type": "string", "description": "parent frame: world (ENU)" },
            "child_frame_id": { "type": "string", "description": "child frame: heli (FLU body)" },
            "translation": xyz_schema("foxglove.Vector3", "position of the body origin in the world frame", " (m)", false),
            "rotation": xyz_schema("foxglove.Quaternion", "orientation of the body frame in the world frame", " (unit quaternion)", true),
        },
        "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"],
    })
}

/// The JSON Schema of `foxglove.LocationFix`.
pub fn location_fix_schema() -> Value {
    json!({
        "title": "foxglove.LocationFix",
        "description": "GPS fix (2D or 3D fixes only)",
        "type": "object",
        "properties": {
            "timestamp": time_schema("time the solution arrived (vehicle clock)"),
            "frame_id": { "type": "string", "description": "frame of the antenna: gps" },
            "latitude": { "type": "number", "description": "latitude (deg, north positive)" },
            "longitude": { "type": "number", "description": "longitude (deg, east positive)" },
            "altitude": { "type": "number", "description": "altitude above mean sea level (m)" },
            "position_covariance": {
                "type": "array", "items": { "type": "number" }, "minItems": 9, "maxItems": 9,
                "description": "position covariance, ENU, row-major (m^2); zero: not given by the receiver",
            },
            "position_covariance_type": {
                "title": "foxglove.PositionCovarianceType",
                "description": "0 UNKNOWN, 1 APPROXIMATED, 2 DIAGONAL_KNOWN, 3 KNOWN",
                "oneOf": [
                    { "title": "UNKNOWN", "const": 0 },
                    { "title": "APPROXIMATED", "const": 1 },
                    { "title": "DIAGONAL_KNOWN", "const": 2 },
                    { "title": "KNOWN", "const": 3 },
                ],
            },
        },
        "required": ["timestamp", "frame_id", "latitude", "longitude", "altitude", "position_covariance", "position_covariance_type"],
    })
}

/// The JSON Schema of `foxglove.Log`.
pub fn log_schema() -> Value {
    let levels: Vec<Value> = EventLevel::ALL
        .iter()
        .map(|l| json!({ "title": l.name().to_uppercase(), "const": l.foxglove() }))
        .collect();
    json!({
        "title": "foxglove.Log",
        "description": "A flight-software event",
        "type": "object",
        "properties": {
            "timestamp": time_schema("time of the event (vehicle clock)"),
            "level": {
                "title": "foxglove.LogLevel",
                "description": "0 UNKNOWN, 1 DEBUG, 2 INFO, 3 WARNING, 4 ERROR, 5 FATAL",
                "oneOf": levels,
            },
            "message": { "type": "string", "description": "the event's text, beginning with its time" },
            "name": { "type": "string", "description": "who raised it: heli-fsw" },
            "file": { "type": "string", "description": "source file (empty)" },
            "line": { "type": "integer", "minimum": 0, "description": "source line (0)" },
        },
        "required": ["timestamp", "level", "message", "name", "file", "line"],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_6;

    /// `v` rotated by the unit quaternion `q`.
    fn rotate(q: Quat, v: [f64; 3]) -> [f64; 3] {
        let conj = [q[0], -q[1], -q[2], -q[3]];
        let r = mul(mul(q, [0.0, v[0], v[1], v[2]]), conj);
        [r[1], r[2], r[3]]
    }

    fn yaw_pitch(yaw: f64, pitch: f64) -> Quat {
        let (sy, cy) = (yaw / 2.0).sin_cos();
        let (sp, cp) = (pitch / 2.0).sin_cos();
        // Z then Y (body to NED).
        mul([cy, 0.0, 0.0, sy], [cp, 0.0, sp, 0.0])
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn the_nose_and_the_belly_point_the_same_way_in_both_conventions() {
        // Heading east (yaw 90° in NED), nose 30° up.
        let q = enu_flu_rotation(yaw_pitch(std::f64::consts::FRAC_PI_2, FRAC_PI_6));
        // Forward (FLU x) in ENU: east and up.
        let nose = rotate(q, [1.0, 0.0, 0.0]);
        assert!(
            close(nose, [FRAC_PI_6.cos(), 0.0, FRAC_PI_6.sin()]),
            "{nose:?}"
        );
        // Left (FLU y) of an east-pointing helicopter is north.
        assert!(close(rotate(q, [0.0, 1.0, 0.0]), [0.0, 1.0, 0.0]));
        // Level, pointing north: +90° about z, nose along ENU y, up along z.
        let level = enu_flu_rotation([1.0, 0.0, 0.0, 0.0]);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            close([level[0], level[1], level[2]], [s, 0.0, 0.0]) && (level[3] - s).abs() < 1e-12
        );
        assert!(close(rotate(level, [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0]));
    }

    #[test]
    fn timestamps_split_into_seconds_and_nanoseconds() {
        assert_eq!(
            timestamp(85_020_003),
            json!({"sec": 85, "nsec": 20_003_000})
        );
        assert_eq!(
            log(0, EventLevel::Warning, "t=0.00 s watchdog fired")["level"],
            3
        );
    }

    #[test]
    fn a_transform_is_in_enu_and_a_fix_has_its_covariance_slots() {
        let tf = frame_transform(0, [10.0, 20.0, -5.0], [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(tf["translation"], json!({"x": 20.0, "y": 10.0, "z": 5.0}));
        let fix = location_fix(1_000_000, 42.36, -71.09, 12.0);
        assert_eq!(fix["latitude"], 42.36);
        assert_eq!(fix["position_covariance"].as_array().map(Vec::len), Some(9));
    }
}
