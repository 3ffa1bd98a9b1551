//! Autorotation: the answer to an engine failure.
//!
//! With the engine gone, the rotor keeps its speed only from the air flowing up through it
//! as the helicopter descends; its inertia is the only reserve for the landing. The
//! controller does what a pilot is taught, in stages chosen from the attitude, the height
//! above the take-off point and the sink rate:
//!
//! 0. **Upset**: tilted beyond [`AutorotationGains::upset_tilt_rad`] (the engine failed in
//!    a roll), the helicopter is turned upright by the shortest way, by body rates from the
//!    attitude quaternion (Euler angles mislead upside down), at a collective that pulls no
//!    thrust and so spends the least of the rotor's speed.
//! 1. **Glide**: the collective holds the rotor at its target speed (lower it when the
//!    rotor slows, raise it when the rotor overspeeds), starting from the collective of a
//!    steady autorotation; the cyclic flies a forward glide at [`AutorotationGains::glide_speed_mps`],
//!    along the way it was already going (or the nose's way from a hover), the heading held.
//! 2. **Flare**: below [`AutorotationGains::flare_height_m`] the glide speed is taken off
//!    toward zero, the tilt limited, turning forward speed into rotor speed and less sink.
//! 3. **Cushion**: the sink rate is held under a profile that falls to
//!    [`AutorotationGains::touchdown_sink_mps`] at [`AutorotationGains::touchdown_height_m`]
//!    and holds it to the ground (a constant deceleration of
//!    [`AutorotationGains::cushion_decel_mps2`] above): when the helicopter sinks faster than the
//!    profile, the collective rises on the error, spending the rotor's energy.
//! 4. **Level**: below [`AutorotationGains::level_height_m`] the attitude is held level
//!    whatever the speed left, so the skids meet the ground flat.
//!
//! **Close to the ground** (the engine quits below [`AutorotationGains::hover_auto_height_m`]
//! at walking speed, in a low hover, a take-off or a landing) there is no height for a
//! glide: the autorotation is a pilot's *hovering autorotation*. The stages are the same,
//! but the cushion's profile decelerates at [`AutorotationGains::hover_cushion_decel_mps2`],
//! gentler than the glide's arrival: the collective comes up as soon as the helicopter
//! starts to sink, and the rotor's energy is spent on a slow descent instead of on stopping
//! a fast one it could not stop.
//!
//! Sans-I/O: the estimate, the height, the rotor speed and the step time come in, the
//! servo commands go out. The flight core decides when it begins (the engine-failure
//! detection) and when it ends (on the ground).

use heli_nav::navigator::NavState;
use heli_proto::scb::Controls;
use nalgebra::Vector3;

use crate::hover::{HoverController, accel_to_attitude};
use crate::sanitize_dt;
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
    /// Largest tilt in the glide (rad): enough to hold the glide's speed, not the dive a
    /// powered flight's speed loop would ask for (nose down, the air no longer drives the
    /// rotor).
    pub glide_max_tilt_rad: f64,
    /// How far below its target the rotor may be (rpm) before the glide's nose-down tilt is
    /// cut back, to none at this far below.
    pub glide_rotor_band_rpm: f64,
    /// Nose-up pitch (rad) held while the rotor is a whole band below its target and the
    /// helicopter has forward speed to spend.
    pub entry_pitch_rad: f64,
    /// Height above the take-off point where the flare begins (m).
    pub flare_height_m: f64,
    /// Height below which the attitude is held level (m).
    pub level_height_m: f64,
    /// Largest tilt in the flare and the cushion (rad).
    pub flare_max_tilt_rad: f64,
    /// The flare's deceleration per m/s of ground speed left (1/s): the nose comes up in
    /// proportion to the speed, and down as it is taken off.
    pub flare_decel_per_mps: f64,
    /// Deceleration of the cushion's sink-rate profile (m/s²).
    pub cushion_decel_mps2: f64,
    /// Height above the take-off point below which an engine failure at walking speed
    /// (at most [`HOVERING_MAX_SPEED_MPS`]) begins a hovering autorotation (m).
    pub hover_auto_height_m: f64,
    /// Deceleration of the cushion's sink-rate profile in a hovering autorotation (m/s²).
    pub hover_cushion_decel_mps2: f64,
    /// Sink rate the profile reaches at [`AutorotationGains::touchdown_height_m`] and holds
    /// to the ground (m/s).
    pub touchdown_sink_mps: f64,
    /// Height above the ground where the profile's deceleration ends (m): the last of the
    /// descent is flown at the touchdown sink, so the rotor's energy is not all spent in the
    /// last instant before contact.
    pub touchdown_height_m: f64,
    /// Collective per m/s of sink above the profile (normalised s/m).
    pub sink_to_collective: f64,
    /// Collective around which the cushion's correction acts (normalised): the hover's.
    pub cushion_collective: f64,
    /// Collective while upset (normalised): about no blade pitch, no thrust, the least
    /// torque on the rotor. Finishing a roll on the roll's own collective (±0.75, inverted)
    /// took the rotor from 1700 to 940 rpm before the helicopter was upright.
    pub upset_collective: f64,
    /// Tilt beyond which the helicopter is upset (rad): righted first, level, at
    /// [`AutorotationGains::upset_collective`].
    pub upset_tilt_rad: f64,
    /// Largest righting rate when upset (rad/s): the full cyclic, for the rotor is slow
    /// and the tail and stabiliser turn a falling helicopter nose-down into the air.
    pub upset_rate_rps: f64,
}

impl Default for AutorotationGains {
    fn default() -> Self {
        Self {
            rotor_target_rpm: 1400.0,
            glide_collective: -0.3,
            rotor_to_collective: 0.004,
            rotor_integral: 0.002,
            min_collective: -0.4,
            glide_speed_mps: 22.0,
            glide_max_tilt_rad: 0.35,
            glide_rotor_band_rpm: 600.0,
            entry_pitch_rad: 0.45,
            flare_height_m: 10.0,
            level_height_m: 1.5,
            flare_max_tilt_rad: 0.35,
            flare_decel_per_mps: 0.3,
            cushion_decel_mps2: 9.0,
            hover_auto_height_m: 5.0,
            hover_cushion_decel_mps2: 2.0,
            touchdown_sink_mps: 0.6,
            touchdown_height_m: 0.3,
            sink_to_collective: 0.8,
            cushion_collective: 0.8,
            upset_collective: 0.0,
            upset_tilt_rad: 1.2,
            upset_rate_rps: 5.0,
        }
    }
}

/// Ground speed (m/s) at or below which the helicopter is hovering when the engine quits:
/// the glide goes the nose's way, and close to the ground the autorotation is a hovering
/// one.
pub const HOVERING_MAX_SPEED_MPS: f64 = 2.0;

/// Where in the autorotation the helicopter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AutorotationStage {
    /// Tilted beyond [`AutorotationGains::upset_tilt_rad`] (the engine failed in a roll):
    /// righted by the shortest way, no thrust pulled.
    Upset,
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
            AutorotationStage::Upset => "upset",
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
    /// Begun close to the ground at walking speed: a hovering autorotation.
    hovering: bool,
}

impl Autorotation {
    /// Begins at the estimate `est`, `height_m` above the take-off point: the glide goes the
    /// way the helicopter was going (above [`HOVERING_MAX_SPEED_MPS`]), otherwise the way
    /// its nose points; below [`AutorotationGains::hover_auto_height_m`] at walking speed
    /// it is a hovering autorotation.
    pub fn begin(gains: AutorotationGains, est: &NavState, height_m: f64) -> Self {
        let (_, _, yaw) = est.euler_rad();
        let vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        let moving = vel.norm() > HOVERING_MAX_SPEED_MPS;
        let glide_dir = if moving {
            vel / vel.norm()
        } else {
            Vector3::new(yaw.cos(), yaw.sin(), 0.0)
        };
        Self {
            gains,
            glide_dir,
            glide_speed_mps: gains.glide_speed_mps,
            heading_rad: yaw,
            rotor_integral: 0.0,
            stage: AutorotationStage::Glide,
            cushioning: false,
            hovering: !moving && height_m < gains.hover_auto_height_m,
        }
    }

    /// Whether this is a hovering autorotation (begun close to the ground at walking speed).
    pub fn hovering(&self) -> bool {
        self.hovering
    }

    /// The stage of the last update.
    pub fn stage(&self) -> AutorotationStage {
        self.stage
    }

    /// The sink rate (m/s, down positive) the cushion allows at `height_m` above the ground.
    pub fn sink_profile_mps(&self, height_m: f64) -> f64 {
        let g = self.gains;
        let td = g.touchdown_sink_mps;
        let above = (height_m - g.touchdown_height_m).max(0.0);
        let decel = if self.hovering {
            g.hover_cushion_decel_mps2
        } else {
            g.cushion_decel_mps2
        };
        (td * td + 2.0 * decel * above).sqrt()
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
        let upset = tilt_rad(est) > g.upset_tilt_rad;
        self.stage = if upset {
            AutorotationStage::Upset
        } else if height_m < g.level_height_m {
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
        let collective = if upset {
            g.upset_collective
        } else {
            limit(for_rotor.max(for_sink), 1.0)
        };

        // Cyclic: the glide's speed, taken off in the flare, level at the end.
        let (roll_cmd, pitch_cmd) = match self.stage {
            AutorotationStage::Glide => {
                let vel_cmd = self.glide_dir * self.glide_speed_mps;
                let (roll, pitch) = hover.velocity_to_attitude(est, &vel_cmd, dt, true);
                // The nose goes down for speed only as the rotor has its speed back: a
                // dive unloads the disk, and the rotor would go on slowing.
                let band = g.glide_rotor_band_rpm.max(1.0);
                let ready = ((rotor_err + band) / band).clamp(0.0, 1.0);
                // With speed to spend and the rotor slow, the nose comes up: the air then
                // comes up through the disk and drives the rotor (a pilot's entry flare).
                let along = est.vel_ned_mps.dot(&self.glide_dir);
                let speed_share = (along / 5.0).clamp(0.0, 1.0);
                let floor =
                    -g.glide_max_tilt_rad * ready + g.entry_pitch_rad * speed_share * (1.0 - ready);
                (
                    limit(roll, g.glide_max_tilt_rad),
                    pitch.max(floor).min(g.glide_max_tilt_rad.max(floor)),
                )
            }
            AutorotationStage::Flare | AutorotationStage::Cushion => {
                // Decelerate along the glide in proportion to the speed left; take any
                // sideways speed off with the hover's gain.
                let vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
                let along = vel.dot(&self.glide_dir);
                let cross = vel - self.glide_dir * along;
                let accel = -self.glide_dir * (g.flare_decel_per_mps * along)
                    - cross * hover.gains.vel_to_accel;
                let (_, _, yaw) = est.euler_rad();
                let (roll, pitch) = accel_to_attitude(yaw, &accel);
                (
                    limit(roll, g.flare_max_tilt_rad),
                    limit(pitch, g.flare_max_tilt_rad),
                )
            }
            AutorotationStage::Level | AutorotationStage::Upset => (0.0, 0.0),
        };
        let (aileron, elevator) = if upset {
            let (p, q) = righting_rates(est, hover.gains.att_to_rate, g.upset_rate_rps);
            hover.rates_to_cyclic(est, p, q)
        } else {
            hover.attitude_to_cyclic(est, roll_cmd, pitch_cmd)
        };
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

/// The shaft's angle from the vertical (rad): 0 level, π upside down.
fn tilt_rad(est: &NavState) -> f64 {
    let world_up = est.att.inverse() * Vector3::new(0.0, 0.0, -1.0);
    (-world_up.z).clamp(-1.0, 1.0).acos()
}

/// Body roll and pitch rates (rad/s) that turn the shaft toward the vertical by the
/// shortest way, at `gain` per radian of tilt, at most `max_rps`: the way up from any
/// attitude (upside down, on its nose), where Euler angles are no guide (inverted, a pitch
/// rate moves the Euler pitch the other way). Exactly inverted, it rolls.
fn righting_rates(est: &NavState, gain: f64, max_rps: f64) -> (f64, f64) {
    let shaft_up = Vector3::new(0.0, 0.0, -1.0);
    let world_up = est.att.inverse() * shaft_up;
    let axis = shaft_up.cross(&world_up);
    let tilt = tilt_rad(est);
    let dir = if axis.norm() > 1e-3 {
        axis / axis.norm()
    } else {
        Vector3::x()
    };
    let rate = dir * (gain * tilt).min(max_rps);
    (rate.x, rate.y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hover::HoverGains;
    use nalgebra::UnitQuaternion;

    /// Level, heading north, moving at `vel` (NED).
    fn est(vel: Vector3<f64>) -> NavState {
        NavState {
            t_us: 0,
            att: UnitQuaternion::identity(),
            vel_ned_mps: vel,
            pos_ned_m: Vector3::zeros(),
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: Vector3::zeros(),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        }
    }

    fn step(ar: &mut Autorotation, e: &NavState, height_m: f64, rpm: f64) -> Controls {
        let mut hover = HoverController::new(HoverGains::default());
        ar.update(&mut hover, e, height_m, rpm, 0.02)
    }

    #[test]
    fn with_the_rotor_slow_and_speed_to_spend_the_nose_comes_up() {
        let e = est(Vector3::new(10.0, 0.0, 2.0));
        let mut ar = Autorotation::begin(AutorotationGains::default(), &e, 50.0);
        // Level now: a nose-up command is aft cyclic (positive elevator pitches up).
        let slow = step(&mut ar, &e, 50.0, 1100.0);
        let mut ar = Autorotation::begin(AutorotationGains::default(), &e, 50.0);
        let at_speed = step(&mut ar, &e, 50.0, 1500.0);
        assert_eq!(ar.stage(), AutorotationStage::Glide);
        assert!(slow.elevator > 0.0, "{slow:?}");
        assert!(at_speed.elevator < slow.elevator, "{at_speed:?} {slow:?}");
    }

    #[test]
    fn the_collective_holds_the_rotor_speed_in_the_glide() {
        let e = est(Vector3::new(10.0, 0.0, 8.0));
        let g = AutorotationGains::default();
        let mut ar = Autorotation::begin(g, &e, 50.0);
        let slow = step(&mut ar, &e, 50.0, 1250.0).collective;
        let mut ar = Autorotation::begin(g, &e, 50.0);
        let fast = step(&mut ar, &e, 50.0, 1650.0).collective;
        assert!(slow < g.glide_collective && fast > g.glide_collective);
        assert!(slow >= g.min_collective);
    }

    #[test]
    fn near_the_ground_the_flare_takes_the_speed_off_and_the_cushion_the_sink() {
        let g = AutorotationGains::default();
        // In the flare, sinking slower than the profile: nose up, collective still on the
        // rotor.
        let e = est(Vector3::new(12.0, 0.0, 3.0));
        let mut ar = Autorotation::begin(g, &e, 50.0);
        let flare = step(&mut ar, &e, g.flare_height_m - 1.0, g.rotor_target_rpm);
        assert_eq!(ar.stage(), AutorotationStage::Flare);
        assert!(flare.elevator > 0.0, "{flare:?}");
        assert!(flare.collective < 0.0, "{flare:?}");
        // Sinking faster than the profile allows: the collective comes up, and stays up.
        let h = 5.0;
        let fast = est(Vector3::new(6.0, 0.0, ar.sink_profile_mps(h) + 2.0));
        let cushion = step(&mut ar, &fast, h, 1500.0);
        assert_eq!(ar.stage(), AutorotationStage::Cushion);
        assert!(cushion.collective > g.cushion_collective, "{cushion:?}");
        let slow = est(Vector3::new(6.0, 0.0, 0.5));
        step(&mut ar, &slow, h - 0.5, 1500.0);
        assert_eq!(ar.stage(), AutorotationStage::Cushion);
        // The last metre: level.
        let level = step(&mut ar, &slow, g.level_height_m - 0.1, 1400.0);
        assert_eq!(ar.stage(), AutorotationStage::Level);
        assert!(level.elevator.abs() < 0.2, "{level:?}");
    }

    #[test]
    fn upset_it_is_righted_by_the_shortest_way_without_thrust() {
        let g = AutorotationGains::default();
        let mut e = est(Vector3::new(5.0, 0.0, 2.0));
        let mut ar = Autorotation::begin(g, &e, 50.0);
        // Rolled 150 degrees right: back left is the short way (the Euler roll error says
        // the same here; upside down, a pitch error does not).
        e.att = UnitQuaternion::from_euler_angles(150f64.to_radians(), 0.0, 0.0);
        let rolled = step(&mut ar, &e, 60.0, 1300.0);
        assert_eq!(ar.stage(), AutorotationStage::Upset);
        assert_eq!(rolled.collective, g.upset_collective);
        assert!(rolled.aileron < -0.5, "{rolled:?}");
        // Upside down and nose down 40 degrees in the body's own sense: the way up is
        // nose further round, which an Euler pitch loop gets backwards.
        e.att = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0)
            * UnitQuaternion::from_euler_angles(0.0, -40f64.to_radians(), 0.0);
        let inverted = step(&mut ar, &e, 60.0, 1300.0);
        let (p, q) = righting_rates(&e, 4.0, 5.0);
        let shaft = e.att * Vector3::new(0.0, 0.0, -1.0);
        // Turning at (p, q) must bring the shaft's up toward the world's up.
        let turned = e.att * UnitQuaternion::from_scaled_axis(Vector3::new(p, q, 0.0) * 0.01);
        let after = turned * Vector3::new(0.0, 0.0, -1.0);
        assert!(-after.z > -shaft.z, "{shaft:?} -> {after:?}");
        assert!(inverted.collective == g.upset_collective);
        // Exactly upside down there is no shortest way: it rolls.
        e.att = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
        let (p, q) = righting_rates(&e, 4.0, 5.0);
        assert!(p.abs() > 4.0 && q.abs() < 1e-9, "{p} {q}");
        // Level again: the autorotation's own stages.
        e.att = UnitQuaternion::identity();
        step(&mut ar, &e, 60.0, 1300.0);
        assert_eq!(ar.stage(), AutorotationStage::Glide);
    }

    #[test]
    fn the_sink_profile_reaches_the_touchdown_sink_above_the_ground_and_holds_it() {
        let g = AutorotationGains::default();
        let ar = Autorotation::begin(g, &est(Vector3::zeros()), 50.0);
        let td = g.touchdown_sink_mps;
        assert!((ar.sink_profile_mps(g.touchdown_height_m) - td).abs() < 1e-12);
        assert!((ar.sink_profile_mps(0.0) - td).abs() < 1e-12);
        let h = g.touchdown_height_m + 5.0;
        let expect = (td * td + 2.0 * g.cushion_decel_mps2 * 5.0).sqrt();
        assert!((ar.sink_profile_mps(h) - expect).abs() < 1e-12);
    }
}
