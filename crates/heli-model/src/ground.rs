//! Skid contact with flat ground at NED z = 0: a spring and damper under each skid end, and
//! friction with stiction. Each touching skid end is tied to an anchor on the ground by a
//! stiff tangential spring; while the spring force stays inside the friction cone the skid
//! sticks (no creep under the rotor's torque), and when it would leave the cone the skid
//! slides and the anchor is dragged along.

use nalgebra::{Matrix3, UnitQuaternion, Vector2, Vector3};

use crate::params::Airframe;

/// Forces and moments from the ground, body axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Contact {
    /// Force at the centre of gravity (N).
    pub force_body_n: Vector3<f64>,
    /// Moment about the centre of gravity (N m).
    pub moment_body_nm: Vector3<f64>,
    /// Skid points below the ground surface.
    pub points_touching: u32,
    /// Largest downward speed of a touching point (m/s).
    pub max_sink_mps: f64,
}

/// Where each skid end is tied to the ground (NED north, east), `None` when in the air.
pub type Anchors = [Option<Vector2<f64>>; 4];

/// Tangential stiffness of the stiction spring per skid end (N/m).
const TANGENTIAL_STIFFNESS_N_PER_M: f64 = 4000.0;
/// Tangential damping per skid end (N s/m).
const TANGENTIAL_DAMPING_NS_PER_M: f64 = 100.0;

struct PointContact {
    r_body: Vector3<f64>,
    p_ned: Vector3<f64>,
    v_ned: Vector3<f64>,
    normal_n: f64,
}

/// The skid end at `point` (body axes) if it is below the ground: its position, velocity
/// and the normal force of the ground's spring and damper. `rot` is body to NED.
fn touching_point(
    a: &Airframe,
    point: &[f64; 3],
    pos_ned_m: &Vector3<f64>,
    rot: &Matrix3<f64>,
    vel_body_mps: &Vector3<f64>,
    rate_body_rps: &Vector3<f64>,
) -> Option<PointContact> {
    let r_body = Vector3::new(point[0], point[1], point[2]);
    // Height first: in the air, one row of the rotation decides.
    let depth = pos_ned_m.z + rot.row(2).transpose().dot(&r_body);
    if depth <= 0.0 {
        return None;
    }
    let p_ned = pos_ned_m + rot * r_body;
    let v_ned = rot * (vel_body_mps + rate_body_rps.cross(&r_body));
    let normal_n =
        (a.ground_stiffness_n_per_m * depth + a.ground_damping_ns_per_m * v_ned.z).max(0.0);
    Some(PointContact {
        r_body,
        p_ned,
        v_ned,
        normal_n,
    })
}

/// Tangential force on a skid end tied to `anchor`, limited to the friction cone.
fn friction(a: &Airframe, c: &PointContact, anchor: Vector2<f64>) -> Vector2<f64> {
    let stretch = c.p_ned.xy() - anchor;
    let f = -TANGENTIAL_STIFFNESS_N_PER_M * stretch - TANGENTIAL_DAMPING_NS_PER_M * c.v_ned.xy();
    let limit = a.ground_friction * c.normal_n;
    let norm = f.norm();
    if norm > limit && norm > 0.0 {
        f * (limit / norm)
    } else {
        f
    }
}

/// Ground reaction on the four skid points; `rot` is the attitude as a body-to-NED matrix.
pub fn skid_contact(
    a: &Airframe,
    anchors: &Anchors,
    pos_ned_m: &Vector3<f64>,
    rot: &Matrix3<f64>,
    vel_body_mps: &Vector3<f64>,
    rate_body_rps: &Vector3<f64>,
) -> Contact {
    let mut contact = Contact::default();
    for (point, anchor) in a.skid_points_m.iter().zip(anchors) {
        let Some(c) = touching_point(a, point, pos_ned_m, rot, vel_body_mps, rate_body_rps) else {
            continue;
        };
        let t = friction(a, &c, anchor.unwrap_or_else(|| c.p_ned.xy()));
        let f_body = rot.tr_mul(&Vector3::new(t.x, t.y, -c.normal_n));
        contact.force_body_n += f_body;
        contact.moment_body_nm += c.r_body.cross(&f_body);
        contact.points_touching += 1;
        contact.max_sink_mps = contact.max_sink_mps.max(c.v_ned.z);
    }
    contact
}

/// Moves the anchors after a step: new contacts are tied where they touched, skids that
/// slid drag their anchor to the edge of the friction cone, lifted skids are untied.
pub fn update_anchors(
    a: &Airframe,
    anchors: &mut Anchors,
    pos_ned_m: &Vector3<f64>,
    att: &UnitQuaternion<f64>,
    vel_body_mps: &Vector3<f64>,
    rate_body_rps: &Vector3<f64>,
) {
    let rot = att.to_rotation_matrix().into_inner();
    for (point, anchor) in a.skid_points_m.iter().zip(anchors.iter_mut()) {
        let Some(c) = touching_point(a, point, pos_ned_m, &rot, vel_body_mps, rate_body_rps) else {
            *anchor = None;
            continue;
        };
        let p = c.p_ned.xy();
        let tied = anchor.unwrap_or(p);
        let stretch = p - tied;
        let max_stretch = a.ground_friction * c.normal_n / TANGENTIAL_STIFFNESS_N_PER_M;
        let n = stretch.norm();
        *anchor = Some(if n > max_stretch && n > 0.0 {
            p - stretch * (max_stretch / n)
        } else {
            tied
        });
    }
}
