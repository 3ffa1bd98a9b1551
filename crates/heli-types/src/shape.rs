//! The X-Cell 60's outward shape, for the pictures of it: the simulator's and the ground
//! station's 3D views draw it, and the flight log carries it for Foxglove's 3D panel. One
//! definition, so that the helicopter looks the same wherever it is seen.
//!
//! Each part is a simple solid — a box, a cylinder (or cone), an ellipsoid — in the body
//! frame (forward, right, down; origin at the centre of gravity; metres), at the airframe's
//! true dimensions: main rotor 1.55 m across with its hub 0.235 m above the centre of
//! gravity, tail rotor 0.26 m across 0.91 m behind, skids 0.35 m below and 0.44 m apart (the
//! simulator's model, `heli_model::params`, checks that they agree). The rotors are marked
//! so that a view can spin and tilt them.

/// The shape of a part.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(tag = "kind", rename_all = "snake_case"))]
pub enum Solid {
    /// A box, its edges along the body axes (m: forward, right, down).
    Box {
        /// Edge lengths (m).
        size_m: [f64; 3],
    },
    /// An ellipsoid, its axes along the body axes (m: diameters forward, right, down).
    Ellipsoid {
        /// Diameters (m).
        size_m: [f64; 3],
    },
    /// A cylinder (a cone where the radii differ) along a body axis.
    Cylinder {
        /// The body axis it lies along.
        axis: Axis,
        /// Length along the axis (m).
        length_m: f64,
        /// Radius at the end toward the axis's negative side (m).
        start_radius_m: f64,
        /// Radius at the end toward the axis's positive side (m).
        end_radius_m: f64,
    },
}

/// A body axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Axis {
    /// Forward.
    Forward,
    /// Right.
    Right,
    /// Down.
    Down,
}

/// What a part belongs to, for a view that moves some parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Group {
    /// The airframe.
    Airframe,
    /// The main rotor's disk and blades: tilted by the flapping, the blades spinning about
    /// the mast.
    MainRotor,
    /// The tail rotor's disk: spinning about the right axis.
    TailRotor,
}

/// One part of the helicopter.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Part {
    /// What it is.
    pub name: &'static str,
    /// Its solid.
    pub solid: Solid,
    /// Its centre in the body frame (m: forward, right, down).
    pub center_frd_m: [f64; 3],
    /// Its colour: red, green, blue, opacity (0 to 1).
    pub rgba: [f64; 4],
    /// What it moves with.
    pub group: Group,
}

/// Main rotor radius (m).
pub const MAIN_ROTOR_RADIUS_M: f64 = 0.775;
/// Main rotor hub above the centre of gravity (m).
pub const MAIN_ROTOR_HUB_HEIGHT_M: f64 = 0.235;
/// Tail rotor radius (m).
pub const TAIL_ROTOR_RADIUS_M: f64 = 0.13;
/// Tail rotor hub behind the centre of gravity (m).
pub const TAIL_ROTOR_ARM_M: f64 = 0.91;
/// Tail rotor hub above the centre of gravity (m).
pub const TAIL_ROTOR_HEIGHT_M: f64 = 0.08;
/// Skid tubes below the centre of gravity (m).
pub const SKID_DEPTH_M: f64 = 0.35;
/// Skid tubes either side of the centre line (m).
pub const SKID_HALF_TRACK_M: f64 = 0.22;
/// Skid tube length (m).
pub const SKID_LENGTH_M: f64 = 0.62;

const BODY: [f64; 4] = [0.86, 0.16, 0.12, 1.0];
const CANOPY: [f64; 4] = [0.10, 0.16, 0.24, 1.0];
const METAL: [f64; 4] = [0.72, 0.74, 0.78, 1.0];
const DARK: [f64; 4] = [0.12, 0.12, 0.14, 1.0];
const BLADE: [f64; 4] = [0.95, 0.95, 0.92, 1.0];
const DISK: [f64; 4] = [0.85, 0.88, 0.92, 0.18];

const fn rod(axis: Axis, length_m: f64, radius_m: f64) -> Solid {
    Solid::Cylinder {
        axis,
        length_m,
        start_radius_m: radius_m,
        end_radius_m: radius_m,
    }
}

/// The X-Cell 60's parts.
pub const XCELL_60: &[Part] = &[
    Part {
        name: "fuselage",
        solid: Solid::Ellipsoid {
            size_m: [0.74, 0.22, 0.30],
        },
        center_frd_m: [0.06, 0.0, 0.04],
        rgba: BODY,
        group: Group::Airframe,
    },
    Part {
        name: "canopy",
        solid: Solid::Ellipsoid {
            size_m: [0.34, 0.19, 0.17],
        },
        center_frd_m: [0.22, 0.0, -0.05],
        rgba: CANOPY,
        group: Group::Airframe,
    },
    Part {
        name: "tail boom",
        solid: Solid::Cylinder {
            axis: Axis::Forward,
            length_m: 0.66,
            start_radius_m: 0.012,
            end_radius_m: 0.024,
        },
        center_frd_m: [-0.58, 0.0, -0.03],
        rgba: METAL,
        group: Group::Airframe,
    },
    Part {
        name: "vertical fin",
        solid: Solid::Box {
            size_m: [0.14, 0.008, 0.22],
        },
        center_frd_m: [-0.90, 0.0, 0.04],
        rgba: BODY,
        group: Group::Airframe,
    },
    Part {
        name: "horizontal stabilizer",
        solid: Solid::Box {
            size_m: [0.08, 0.30, 0.008],
        },
        center_frd_m: [-0.71, 0.0, -0.03],
        rgba: BODY,
        group: Group::Airframe,
    },
    Part {
        name: "mast",
        solid: rod(Axis::Down, 0.16, 0.012),
        center_frd_m: [0.0, 0.0, -0.155],
        rgba: METAL,
        group: Group::Airframe,
    },
    Part {
        name: "left skid",
        solid: rod(Axis::Forward, SKID_LENGTH_M, 0.008),
        center_frd_m: [0.0, -SKID_HALF_TRACK_M, SKID_DEPTH_M],
        rgba: DARK,
        group: Group::Airframe,
    },
    Part {
        name: "right skid",
        solid: rod(Axis::Forward, SKID_LENGTH_M, 0.008),
        center_frd_m: [0.0, SKID_HALF_TRACK_M, SKID_DEPTH_M],
        rgba: DARK,
        group: Group::Airframe,
    },
    Part {
        name: "front strut",
        solid: rod(Axis::Right, 2.0 * SKID_HALF_TRACK_M, 0.008),
        center_frd_m: [0.16, 0.0, 0.26],
        rgba: DARK,
        group: Group::Airframe,
    },
    Part {
        name: "rear strut",
        solid: rod(Axis::Right, 2.0 * SKID_HALF_TRACK_M, 0.008),
        center_frd_m: [-0.16, 0.0, 0.26],
        rgba: DARK,
        group: Group::Airframe,
    },
    Part {
        name: "main rotor disk",
        solid: rod(Axis::Down, 0.01, MAIN_ROTOR_RADIUS_M),
        center_frd_m: [0.0, 0.0, -MAIN_ROTOR_HUB_HEIGHT_M],
        rgba: DISK,
        group: Group::MainRotor,
    },
    Part {
        name: "main rotor blades",
        solid: Solid::Box {
            size_m: [0.06, 2.0 * MAIN_ROTOR_RADIUS_M, 0.012],
        },
        center_frd_m: [0.0, 0.0, -MAIN_ROTOR_HUB_HEIGHT_M],
        rgba: BLADE,
        group: Group::MainRotor,
    },
    Part {
        name: "flybar",
        solid: rod(Axis::Forward, 0.70, 0.004),
        center_frd_m: [0.0, 0.0, -MAIN_ROTOR_HUB_HEIGHT_M - 0.03],
        rgba: DARK,
        group: Group::MainRotor,
    },
    Part {
        name: "tail rotor disk",
        solid: rod(Axis::Right, 0.008, TAIL_ROTOR_RADIUS_M),
        center_frd_m: [-TAIL_ROTOR_ARM_M, 0.05, -TAIL_ROTOR_HEIGHT_M],
        rgba: DISK,
        group: Group::TailRotor,
    },
    Part {
        name: "tail rotor blades",
        solid: Solid::Box {
            size_m: [0.025, 0.006, 2.0 * TAIL_ROTOR_RADIUS_M],
        },
        center_frd_m: [-TAIL_ROTOR_ARM_M, 0.05, -TAIL_ROTOR_HEIGHT_M],
        rgba: BLADE,
        group: Group::TailRotor,
    },
];

/// The box that holds every part (m: least and most forward, right, down).
pub fn bounds_frd_m(parts: &[Part]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for part in parts {
        let half = match part.solid {
            Solid::Box { size_m } | Solid::Ellipsoid { size_m } => size_m.map(|s| 0.5 * s),
            Solid::Cylinder {
                axis,
                length_m,
                start_radius_m,
                end_radius_m,
            } => {
                let r = start_radius_m.max(end_radius_m);
                let along = 0.5 * length_m;
                match axis {
                    Axis::Forward => [along, r, r],
                    Axis::Right => [r, along, r],
                    Axis::Down => [r, r, along],
                }
            }
        };
        for ((l, h), (c, e)) in lo
            .iter_mut()
            .zip(hi.iter_mut())
            .zip(part.center_frd_m.iter().zip(half))
        {
            *l = l.min(c - e);
            *h = h.max(c + e);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_x_cell_spans_its_rotor_and_stands_on_its_skids() {
        let (lo, hi) = bounds_frd_m(XCELL_60);
        // The main rotor's 1.55 m across, forward and sideways.
        assert!((hi[1] - lo[1] - 2.0 * MAIN_ROTOR_RADIUS_M).abs() < 1e-9);
        assert!((hi[0] - MAIN_ROTOR_RADIUS_M).abs() < 1e-9);
        // From the nose of the rotor disk back to the tail rotor's far edge.
        assert!(lo[0] <= -TAIL_ROTOR_ARM_M - TAIL_ROTOR_RADIUS_M + 1e-9);
        // The skids are the lowest part; the rotor disk and its flybar the highest.
        assert!((hi[2] - SKID_DEPTH_M - 0.008).abs() < 1e-9);
        assert!(lo[2] < -MAIN_ROTOR_HUB_HEIGHT_M);
        // Every colour is a colour, every part has a size.
        for part in XCELL_60 {
            assert!(
                part.rgba.iter().all(|c| (0.0..=1.0).contains(c)),
                "{}",
                part.name
            );
        }
    }

    #[test]
    fn each_rotor_group_has_its_disk_and_blades() {
        for group in [Group::MainRotor, Group::TailRotor] {
            let names: Vec<_> = XCELL_60
                .iter()
                .filter(|p| p.group == group)
                .map(|p| p.name)
                .collect();
            assert!(names.iter().any(|n| n.ends_with("disk")), "{names:?}");
            assert!(names.iter().any(|n| n.ends_with("blades")), "{names:?}");
        }
    }
}
