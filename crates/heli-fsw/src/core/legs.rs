//! How each leg of a flight plan begins: the phase that flies it, from where the last one
//! left the target (or where the helicopter is), home and the heading.

use heli_control::Target;
use heli_types::Leg;
use nalgebra::Vector3;

use crate::phase::{Phase, RollStage};

/// How a leg begins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Begin {
    /// In this phase.
    Fly(Phase),
    /// A hold of this target, braking first if begun in motion.
    Hold(Target),
    /// No leg is left: the plan is complete, and this target held.
    Done(Target),
}

/// How `leg` begins from `from` (the last target, or where the helicopter is), with `home`
/// the take-off point and `yaw_rad` the heading, at `now_us`.
pub fn begin(
    leg: Option<Leg>,
    from: Vector3<f64>,
    home: Vector3<f64>,
    yaw_rad: f64,
    now_us: u64,
) -> Begin {
    let yaw = yaw_rad;
    match leg {
        Some(Leg::Takeoff { alt_m }) => Begin::Fly(Phase::TakingOff {
            target: Target::hold(home + Vector3::new(0.0, 0.0, -alt_m), yaw),
        }),
        Some(Leg::Hold { .. }) => Begin::Hold(Target::hold(from, yaw)),
        Some(Leg::Fly {
            north_m,
            east_m,
            alt_m,
            speed_mps,
        }) => {
            let to_ned_m = home + Vector3::new(north_m, east_m, -alt_m);
            let path = to_ned_m - from;
            let horizontal = Vector3::new(path.x, path.y, 0.0);
            let heading = if horizontal.norm() > 5.0 {
                path.y.atan2(path.x)
            } else {
                yaw
            };
            let vel = if path.norm() > 1e-6 {
                path.normalize() * speed_mps
            } else {
                Vector3::zeros()
            };
            Begin::Fly(Phase::Flying {
                target: Target {
                    pos_ned_m: from,
                    vel_ned_mps: vel,
                    yaw_rad: heading,
                },
                to_ned_m,
            })
        }
        Some(Leg::Rolls { .. }) => {
            // The run-up's trajectory starts at rest where the last leg left it and speeds
            // up along the heading ([`crate::core::roll`]).
            Begin::Fly(Phase::Maneuver {
                target: Target {
                    pos_ned_m: from,
                    vel_ned_mps: Vector3::zeros(),
                    yaw_rad: yaw,
                },
                stage: RollStage::Accelerate { since_us: now_us },
                rolls_done: 0,
            })
        }
        Some(Leg::Land) => Begin::Fly(Phase::Landing {
            settled_since_us: None,
            target: Target {
                pos_ned_m: from,
                vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
                yaw_rad: yaw,
            },
        }),
        None => Begin::Done(Target::hold(from, yaw)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_leg_begins_in_its_phase_from_where_the_last_left_off() {
        let from = Vector3::new(2.0, 3.0, -10.0);
        let home = Vector3::new(0.0, 0.0, 0.5);
        let takeoff = begin(Some(Leg::Takeoff { alt_m: 12.0 }), from, home, 0.4, 7);
        assert_eq!(
            takeoff,
            Begin::Fly(Phase::TakingOff {
                target: Target::hold(Vector3::new(0.0, 0.0, -11.5), 0.4)
            })
        );
        assert_eq!(
            begin(Some(Leg::Hold { seconds: 3.0 }), from, home, 0.4, 7),
            Begin::Hold(Target::hold(from, 0.4))
        );
        let Begin::Fly(Phase::Flying { target, to_ned_m }) = begin(
            Some(Leg::Fly {
                north_m: 42.0,
                east_m: 3.0,
                alt_m: 10.5,
                speed_mps: 4.0,
            }),
            from,
            home,
            0.4,
            7,
        ) else {
            panic!("a path")
        };
        assert_eq!(to_ned_m, Vector3::new(42.0, 3.0, -10.0));
        assert!((target.vel_ned_mps.norm() - 4.0).abs() < 1e-12);
        assert!(target.yaw_rad.abs() < 1e-12, "faces along a long path");
        let Begin::Fly(Phase::Flying { target: short, .. }) = begin(
            Some(Leg::Fly {
                north_m: 4.0,
                east_m: 3.0,
                alt_m: 10.5,
                speed_mps: 4.0,
            }),
            from,
            home,
            0.4,
            7,
        ) else {
            panic!("a path")
        };
        assert_eq!(short.yaw_rad, 0.4, "a short path keeps the heading");
        let Begin::Fly(Phase::Maneuver {
            target,
            stage,
            rolls_done,
        }) = begin(
            Some(Leg::Rolls {
                count: 3,
                speed_mps: 8.0,
            }),
            from,
            home,
            0.0,
            7,
        )
        else {
            panic!("rolls")
        };
        assert_eq!(target.vel_ned_mps, Vector3::zeros());
        assert_eq!(target.yaw_rad, 0.0);
        assert_eq!(
            (stage, rolls_done),
            (RollStage::Accelerate { since_us: 7 }, 0)
        );
        let Begin::Fly(Phase::Landing { target, .. }) = begin(Some(Leg::Land), from, home, 0.4, 7)
        else {
            panic!("a landing")
        };
        assert_eq!(target.vel_ned_mps.z, 0.5);
        assert_eq!(
            begin(None, from, home, 0.4, 7),
            Begin::Done(Target::hold(from, 0.4))
        );
    }
}
