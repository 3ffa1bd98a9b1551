//! Autorotation: the answer to an engine failure.
//!
//! With the engine gone, the rotor keeps its speed only from the air flowing up through it
//! as the helicopter descends; its inertia is the only reserve for the landing. The
//! controller does what a pilot is taught, in four stages chosen from the height above the
//! take-off point and the sink rate:
//!
//! 1. **Glide**: the collective holds the rotor at its target speed (lower it when the
//!    rotor slows, raise it when the rotor overspeeds), starting from the collective of a
//!    steady autorotation; the cyclic flies a forward glide at [`AutorotationGains::glide_speed_mps`],
//!    along the way it was already going (or the nose's way from a hover), the heading held.
//! 2. **Flare**: below [`AutorotationGains::flare_height_m`] the glide speed is taken off
//!    toward zero, the tilt limited, turning forward speed into rotor speed and less sink.
//! 3. **Cushion**: the sink rate is held under a profile that falls to
//!    [`AutorotationGains::touchdown_sink_mps`] at the ground (a constant deceleration of
//!    [`AutorotationGains::cushion_decel_mps2`]): when the helicopter sinks faster than the
//!    profile, the collective rises on the error, spending the rotor's energy.
//! 4. **Level**: below [`AutorotationGains::level_height_m`] the attitude is held level
//!    whatever the speed left, so the skids meet the ground flat.
//!
//! Sans-I/O: the estimate, the height, the rotor speed and the step time come in, the
//! servo commands go out. The flight core decides when it begins (the engine-failure
//! detection) and when it ends (on the ground).

use heli_nav::navigator::NavState;
use heli_proto::scb::Controls;
use nalgebra::Vector3;

use crate::hover::{HoverController, sanitize_dt};
use crate::{GOVERNED_THROTTLE, limit};

/// Gains and limits of the autorotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutorotationGains {
    /// Rotor speed the collective holds in the glide (rpm).
    pub rotor_target_rpm: f64,
    /// Collective of a steady autorotation at the target speed (normalised; the X-Cell model
    /// needs about −0.056 rad of blade pitch at 3–12 m/s forward).
    pub glide_collective: f64,
    /// Collective per rpm of rotor-speed error (normalised/rpm).
    pub rotor_to_collective: f64,
    /// Integral of the rotor-speed error (normalised/(rpm s)).
    pub rotor_integral: f64,
    /// Lowest collective of the glide (normalised).
    pub min_collective: f64,
    /// Forward ground speed of the glide (m/s).
    pub glide_speed_mps: f64,
    /// Height above the take-off point where the flare begins (m).
    pub flare_height_m: f64,
    /// Height below which the attitude is held level (m).
    pub level_height_m: f64,
    /// Largest tilt in the flare and the cushion (rad).
    pub flare_max_tilt_rad: f64,
    /// Deceleration of the cushion's sink-rate profile (m/s²).
    pub cushion_decel_mps2: f64,
    /// Sink rate the profile reaches at the ground (m/s).
    pub touchdown_sink_mps: f64,
    /// Collective per m/s of sink above the profile (normalised s/m).
    pub sink_to_collective: f64,
    /// Collective around which the cushion's correction acts (normalised): the hover's.
    pub cushion_collective: f64,
}

impl Default for AutorotationGains {
    fn default() -> Self {
        Self {
            rotor_target_rpm: 1500.0,
            glide_collective: -0.3,
            rotor_to_collective: 0.004,
            rotor_integral: 0.002,
            min_collective: -0.4,
            glide_speed_mps: 6.0,
            flare_height_m: 6.0,
            level_height_m: 1.0,
            flare_max_tilt_rad: 0.35,
            cushion_decel_mps2: 4.0,
            touchdown_sink_mps: 0.5,
            sink_to_collective: 0.25,
            cushion_collective: 0.54,
        }
    }
}

/// Where in the autorotation the helicopter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AutorotationStage {
    /// Rotor speed on the collective, forward glide on the cyclic.
    Glide,
    /// Speed taken off near the ground.
    Flare,
    /// Collective raised against the sink, from the rotor's energy.
    Cushion,
    /// Level for the skids.
    Level,
}

impl AutorotationStage {
    /// Lower-case name for messages and logs.
    pub fn name(self) -> &'static str {
        match self {
            AutorotationStage::Glide => "glide",
            AutorotationStage::Flare => "flare",
            AutorotationStage::Cushion => "cushion",
            AutorotationStage::Level => "level",
        }
    }
}

/// The autorotation's state: the glide's direction and heading, the rotor-speed integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Autorotation {
    /// Gains.
    pub gains: AutorotationGains,
    /// Unit horizontal direction of the glide (NED).
    glide_dir: Vector3<f64>,
    /// Ground speed of the glide (m/s): the glide's, or less if the helicopter was slower
    /// (from a hover there is no height to gain speed with).
    glide_speed_mps: f64,
    /// Heading held (rad).
    heading_rad: f64,
    rotor_integral: f64,
    stage: AutorotationStage,
    cushioning: bool,
}

impl Autorotation {
    /// Begins at the estimate `est`: the glide goes the way the helicopter was going (above
    /// 2 m/s), otherwise the way its nose points.
    pub fn begin(gains: AutorotationGains, est: &NavState) -> Self {
        let (_, _, yaw) = est.euler_rad();
        let vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        let glide_dir = if vel.norm() > 2.0 {
            vel / vel.norm()
        } else {
            Vector3::new(yaw.cos(), yaw.sin(), 0.0)
        };
        Self {
            gains,
            glide_dir,
            glide_speed_mps: vel.norm().min(gains.glide_speed_mps),
            heading_rad: yaw,
            rotor_integral: 0.0,
            stage: AutorotationStage::Glide,
            cushioning: false,
        }
    }

    /// The stage of the last update.
    pub fn stage(&self) -> AutorotationStage {
        self.stage
    }

    /// The sink rate (m/s, down positive) the cushion allows at `height_m` above the ground.
    pub fn sink_profile_mps(&self, height_m: f64) -> f64 {
        let g = self.gains;
        let td = g.touchdown_sink_mps;
        (td * td + 2.0 * g.cushion_decel_mps2 * height_m.max(0.0)).sqrt()
    }

    /// One control step: servo commands from the estimate, the height above the take-off
    /// point, the rotor speed and the step time. `hover` lends its attitude, cyclic and tail
    /// loops (its integrators keep working for the glide's trim).
    pub fn update(
        &mut self,
        hover: &mut HoverController,
        est: &NavState,
        height_m: f64,
        rotor_rpm: f64,
        dt_s: f64,
    ) -> Controls {
        let g = self.gains;
        let dt = sanitize_dt(dt_s);
        let sink = est.vel_ned_mps.z;
        let profile = self.sink_profile_mps(height_m);
        // Once begun, the cushion goes on to the ground.
        self.cushioning |= sink > profile;
        self.stage = if height_m < g.level_height_m {
            AutorotationStage::Level
        } else if self.cushioning {
            AutorotationStage::Cushion
        } else if height_m < g.flare_height_m {
            AutorotationStage::Flare
        } else {
            AutorotationStage::Glide
        };

        // Collective: the rotor's speed, and above it the cushion's sink limit.
        let rotor_err = if rotor_rpm.is_finite() {
            rotor_rpm - g.rotor_target_rpm
        } else {
            0.0
        };
        if !self.cushioning {
            self.rotor_integral = limit(
                self.rotor_integral + rotor_err * dt,
                0.5 / g.rotor_integral.max(1e-9),
            );
        }
        let for_rotor = (g.glide_collective
            + g.rotor_to_collective * rotor_err
            + g.rotor_integral * self.rotor_integral)
            .clamp(g.min_collective, 1.0);
        let for_sink = if self.cushioning {
            g.cushion_collective + g.sink_to_collective * (sink - profile)
        } else {
            f64::NEG_INFINITY
        };
        let collective = limit(for_rotor.max(for_sink), 1.0);

        // Cyclic: the glide's speed, taken off in the flare, level at the end.
        let (roll_cmd, pitch_cmd) = match self.stage {
            AutorotationStage::Glide => {
                let vel_cmd = self.glide_dir * self.glide_speed_mps;
                hover.velocity_to_attitude(est, &vel_cmd, dt, true)
            }
            AutorotationStage::Flare | AutorotationStage::Cushion => {
                let span = (g.flare_height_m - g.level_height_m).max(1e-3);
                let fraction = ((height_m - g.level_height_m) / span).clamp(0.0, 1.0);
                let vel_cmd = self.glide_dir * (self.glide_speed_mps * fraction);
                let (roll, pitch) = hover.velocity_to_attitude(est, &vel_cmd, dt, false);
                (
                    limit(roll, g.flare_max_tilt_rad),
                    limit(pitch, g.flare_max_tilt_rad),
                )
            }
            AutorotationStage::Level => (0.0, 0.0),
        };
        let (aileron, elevator) = hover.attitude_to_cyclic(est, roll_cmd, pitch_cmd);
        let (_, _, yaw) = est.euler_rad();
        let yaw_err = heli_nav::navigator::wrap_pi(self.heading_rad - yaw);
        let r_cmd = limit(
            hover.gains.heading_to_rate * yaw_err,
            hover.gains.max_yaw_rate_rps,
        );
        // No engine torque to balance: the tail's feedforward sees no collective.
        let rudder = hover.yaw_rate_to_tail(est, r_cmd, 0.0, dt, true);
        Controls {
            aileron: limit(aileron, 1.0),
            elevator: limit(elevator, 1.0),
            rudder: limit(rudder, 1.0),
            collective,
            throttle: GOVERNED_THROTTLE,
        }
    }
}
