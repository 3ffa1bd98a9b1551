//! The helicopter itself for Foxglove's 3D panel: the X-Cell 60's parts
//! ([`heli_types::shape::XCELL_60`]) as a `foxglove.SceneUpdate` on `foxglove/scene`, one
//! entity of boxes, ellipsoids and cylinders locked to the body frame `heli` that
//! `foxglove/tf` moves. A log opened in Foxglove shows the helicopter flying, its rotor and
//! skids, not only a pair of axes.
//!
//! The channel's schema is Foxglove's own, as published (`schemas/foxglove/SceneUpdate.json`,
//! from the `@foxglove/schemas` package 2.1.0, MIT licence), so a validator that knows
//! nothing of heli checks the messages against what Foxglove reads. The entity never expires
//! (lifetime zero) and is written again every [`SCENE_EVERY_US`] so that a reader that starts
//! part-way through a log, or a log that begins after a restart, still has it.

use heli_types::shape::{Axis, Part, Solid, XCELL_60};
use serde_json::{Value, json};

use crate::foxglove::{BODY_FRAME, timestamp};

/// Topic of the `foxglove.SceneUpdate` with the helicopter.
pub const SCENE_TOPIC: &str = "foxglove/scene";

/// The entity's id.
pub const ENTITY_ID: &str = "x-cell-60";

/// The scene is written again at most this often (µs of log time).
pub const SCENE_EVERY_US: u64 = 10_000_000;

/// Foxglove's published JSON Schema of `foxglove.SceneUpdate` (the channel's schema).
pub const SCENE_UPDATE_SCHEMA: &str = include_str!("../schemas/foxglove/SceneUpdate.json");

/// `cos 45°` (= `sin 45°`).
const H: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The rotation `[x, y, z, w]` that turns a Foxglove primitive's own `z` axis (a cylinder's
/// length) onto `axis`, in the body frame Forward-Left-Up.
fn onto(axis: Axis) -> [f64; 4] {
    match axis {
        // z onto x: a quarter turn about y.
        Axis::Forward => [0.0, H, 0.0, H],
        // z onto −y (right): a quarter turn about x.
        Axis::Right => [H, 0.0, 0.0, H],
        // z onto −z (down): a half turn about x.
        Axis::Down => [1.0, 0.0, 0.0, 0.0],
    }
}

fn pose(part: &Part, rotation: [f64; 4]) -> Value {
    let [f, r, d] = part.center_frd_m;
    let [x, y, z, w] = rotation;
    json!({
        "position": { "x": f, "y": -r, "z": -d },
        "orientation": { "x": x, "y": y, "z": z, "w": w },
    })
}

fn color(part: &Part) -> Value {
    let [r, g, b, a] = part.rgba;
    json!({ "r": r, "g": g, "b": b, "a": a })
}

fn size([x, y, z]: [f64; 3]) -> Value {
    json!({ "x": x, "y": y, "z": z })
}

/// The `foxglove.SceneUpdate` at `t_us` that puts the X-Cell 60 on the body frame.
pub fn scene_update(t_us: u64) -> Value {
    let (mut cubes, mut spheres, mut cylinders) = (Vec::new(), Vec::new(), Vec::new());
    let level = [0.0, 0.0, 0.0, 1.0];
    for part in XCELL_60 {
        match part.solid {
            Solid::Box { size_m } => cubes.push(json!({
                "pose": pose(part, level),
                "size": size(size_m),
                "color": color(part),
            })),
            Solid::Ellipsoid { size_m } => spheres.push(json!({
                "pose": pose(part, level),
                "size": size(size_m),
                "color": color(part),
            })),
            Solid::Cylinder {
                axis,
                length_m,
                start_radius_m,
                end_radius_m,
            } => {
                let radius = start_radius_m.max(end_radius_m).max(f64::MIN_POSITIVE);
                cylinders.push(json!({
                    "pose": pose(part, onto(axis)),
                    "size": size([2.0 * radius, 2.0 * radius, length_m]),
                    "bottom_scale": start_radius_m / radius,
                    "top_scale": end_radius_m / radius,
                    "color": color(part),
                }));
            }
        }
    }
    json!({
        "deletions": [],
        "entities": [{
            "timestamp": timestamp(t_us),
            "frame_id": BODY_FRAME,
            "id": ENTITY_ID,
            "lifetime": { "sec": 0, "nsec": 0 },
            "frame_locked": true,
            "metadata": [
                { "key": "airframe", "value": "X-Cell 60" },
                { "key": "rotor_diameter_m", "value": format!("{:.2}", 2.0 * heli_types::shape::MAIN_ROTOR_RADIUS_M) },
            ],
            "arrows": [],
            "cubes": cubes,
            "spheres": spheres,
            "cylinders": cylinders,
            "lines": [],
            "triangles": [],
            "texts": [],
            "models": [],
        }],
    })
}

/// The schema as a value (the vendored file is valid JSON: a test reads it).
pub fn scene_update_schema() -> Value {
    serde_json::from_str(SCENE_UPDATE_SCHEMA).unwrap_or_else(|_| json!({"type": "object"}))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_holds_every_part_and_conforms_to_foxglove_s_published_schema() {
        let schema: Value = serde_json::from_str(SCENE_UPDATE_SCHEMA).unwrap();
        assert_eq!(schema["title"], "foxglove.SceneUpdate");
        let scene = scene_update(12_500_000);
        crate::schema::validate(&schema, &scene, SCENE_TOPIC).unwrap();
        let entity = &scene["entities"][0];
        assert_eq!(entity["frame_id"], "heli");
        assert_eq!(entity["frame_locked"], true);
        assert_eq!(entity["timestamp"]["sec"], 12);
        let parts = ["cubes", "spheres", "cylinders"]
            .iter()
            .map(|k| entity[k].as_array().unwrap().len())
            .sum::<usize>();
        assert_eq!(parts, XCELL_60.len());
    }

    #[test]
    fn a_cylinder_lies_along_its_axis_in_foxglove_s_frame() {
        // Rotating the primitive's z axis by each rotation lands on the axis (FLU).
        let rotate = |[x, y, z, w]: [f64; 4]| {
            // v' = q v q*, v = (0, 0, 1).
            [
                2.0 * (x * z + w * y),
                2.0 * (y * z - w * x),
                1.0 - 2.0 * (x * x + y * y),
            ]
        };
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(p, q)| (p - q).abs() < 1e-12);
        assert!(close(rotate(onto(Axis::Forward)), [1.0, 0.0, 0.0]));
        assert!(close(rotate(onto(Axis::Right)), [0.0, -1.0, 0.0]));
        assert!(close(rotate(onto(Axis::Down)), [0.0, 0.0, -1.0]));
        // The skids hang below: FRD down is Foxglove's −z.
        let scene = scene_update(0);
        let skid = scene["entities"][0]["cylinders"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["size"]["z"].as_f64() == Some(heli_types::shape::SKID_LENGTH_M))
            .unwrap()
            .clone();
        assert_eq!(
            skid["pose"]["position"]["z"].as_f64(),
            Some(-heli_types::shape::SKID_DEPTH_M)
        );
    }
}
