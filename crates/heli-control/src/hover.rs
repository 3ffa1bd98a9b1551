//! Autonomous take-off and position hold: a cascade of position → velocity → attitude →
//! angular rate on the cyclic, vertical position → climb rate on the collective, heading →
//! yaw rate on the tail rotor. Gains and their tuning are in `docs/control.md`.

use heli_nav::NavState;
use heli_proto::scb::Controls;
use nalgebra::Vector3;

use crate::heading_lock::HeadingLock;
use crate::sanitize_dt;
use crate::{GOVERNED_THROTTLE, limit};

/// How much of the tail's travel the yaw integrator may hold (normalised): in a strong
/// crosswind the fin and the tail rotor need most of it to keep the heading.
pub const YAW_TRIM_AUTHORITY: f64 = 1.0;

/// Gains and limits of the hover controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoverGains {
    /// Velocity command per metre of horizontal position error (1/s).
    pub pos_to_vel: f64,
    /// Largest horizontal velocity command (m/s).
    pub max_horizontal_speed_mps: f64,
    /// Acceleration command per m/s of velocity error (1/s).
    pub vel_to_accel: f64,
    /// Integral gain on velocity error (1/s²), active only in the air.
    pub vel_integral: f64,
    /// Largest horizontal acceleration the velocity error may command (m/s²): how hard a
    /// correction is flown. The wind's trim comes on top ([`HoverGains::max_trim_accel_mps2`]).
    pub max_accel_mps2: f64,
    /// Largest trim the velocity integrator may hold (m/s²): against the wind and the drag
    /// of forward flight; kept apart from the correction so that a strong wind does not use
    /// up the room to correct.
    pub max_trim_accel_mps2: f64,
    /// Largest commanded roll or pitch (rad).
    pub max_tilt_rad: f64,
    /// Rate command per rad of attitude error (1/s).
    pub att_to_rate: f64,
    /// Largest roll or pitch rate command (rad/s).
    pub max_rate_rps: f64,
    /// Cyclic per rad/s of commanded rate (feedforward: inverse of the rate response's DC gain).
    pub rate_feedforward: f64,
    /// Cyclic per rad/s of rate error.
    pub rate_feedback: f64,
    /// Climb-rate command per metre of altitude error (1/s).
    pub alt_to_climb: f64,
    /// Largest climb rate (m/s).
    pub max_climb_mps: f64,
    /// Largest descent rate (m/s).
    pub max_descent_mps: f64,
    /// Collective per m/s of vertical-speed error.
    pub climb_feedback: f64,
    /// Collective per m of integrated vertical-speed error.
    pub climb_integral: f64,
    /// Collective that holds the weight in hover (feedforward).
    pub hover_collective: f64,
    /// Yaw-rate command per rad of heading error (1/s).
    pub heading_to_rate: f64,
    /// Yaw rate (1/s) per rad of heading error in the augmented modes' heading lock
    /// ([`crate::heading_lock`]).
    pub heading_lock_to_rate: f64,
    /// Largest yaw-rate command (rad/s).
    pub max_yaw_rate_rps: f64,
    /// Tail command per rad/s of yaw-rate error.
    pub yaw_rate_feedback: f64,
    /// Tail command per rad of integrated yaw-rate error.
    pub yaw_integral: f64,
    /// Tail command that balances the main-rotor torque at the hover collective; the
    /// feedforward scales with collective, as the rotor torque does.
    pub tail_trim: f64,
    /// Time constant of the tail feedforward (s): the fuselage feels the engine's torque,
    /// which follows a collective change only as fast as the governor does.
    pub tail_feedforward_lag_s: f64,
}

impl Default for HoverGains {
    fn default() -> Self {
        Self {
            pos_to_vel: 0.5,
            max_horizontal_speed_mps: 2.0,
            vel_to_accel: 1.4,
            vel_integral: 0.15,
            max_accel_mps2: 3.0,
            max_trim_accel_mps2: 4.5,
            // 30 deg, ArduPilot's ANGLE_MAX default (PX4 allows 45 deg in the air).
            max_tilt_rad: 0.52,
            att_to_rate: 4.0,
            max_rate_rps: 1.5,
            rate_feedforward: 0.3,
            rate_feedback: 0.05,
            alt_to_climb: 0.8,
            max_climb_mps: 1.5,
            max_descent_mps: 1.0,
            climb_feedback: 0.12,
            climb_integral: 0.04,
            hover_collective: 0.54,
            heading_to_rate: 2.0,
            heading_lock_to_rate: 8.0,
            max_yaw_rate_rps: 1.0,
            yaw_rate_feedback: 0.3,
            yaw_integral: 0.15,
            tail_trim: 0.4,
            tail_feedforward_lag_s: 0.5,
        }
    }
}

/// Where the controller holds the helicopter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// Position, NED (m).
    pub pos_ned_m: Vector3<f64>,
    /// Velocity of the target, NED (m/s): zero to hold, the path speed to track a path.
    pub vel_ned_mps: Vector3<f64>,
    /// Heading (rad).
    pub yaw_rad: f64,
}

impl Target {
    /// A fixed point to hold at a heading.
    pub fn hold(pos_ned_m: Vector3<f64>, yaw_rad: f64) -> Self {
        Self {
            pos_ned_m,
            vel_ned_mps: Vector3::zeros(),
            yaw_rad,
        }
    }
}

/// The roll and pitch (rad) that tilt the rotor's thrust to give a horizontal acceleration
/// `accel_ned` (m/s², NED) at heading `yaw_rad`: into the heading frame, nose down to go
/// forward, right roll to go right.
pub fn accel_to_attitude(yaw_rad: f64, accel_ned: &Vector3<f64>) -> (f64, f64) {
    let (s, c) = yaw_rad.sin_cos();
    let fwd = c * accel_ned.x + s * accel_ned.y;
    let right = -s * accel_ned.x + c * accel_ned.y;
    let gravity = heli_nav::GRAVITY_MPS2;
    ((right / gravity).atan(), -(fwd / gravity).atan())
}

/// A hold begun after flight ([`HoverController::enter_hold`]) unlearns the flight's drag
/// once the helicopter is slower than this (m/s) ...
pub const SETTLE_FROM_MPS: f64 = 1.5;
/// ... for this long (s) ...
pub const SETTLE_S: f64 = 8.0;
/// ... with its velocity integrator this many times faster.
pub const SETTLE_INTEGRAL_BOOST: f64 = 3.0;

/// The hover controller with its integrator states.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HoverController {
    /// Gains.
    pub gains: HoverGains,
    vel_integral: Vector3<f64>,
    climb_integral: f64,
    yaw_integral: f64,
    tail_feedforward: Option<f64>,
    /// A hold that began after flight and is settling: for how much longer (s).
    settling_s: Option<f64>,
    /// The augmented modes' heading lock.
    pub(crate) heading_lock: HeadingLock,
}

impl HoverController {
    /// A controller with zeroed integrators.
    pub fn new(gains: HoverGains) -> Self {
        Self {
            gains,
            ..Default::default()
        }
    }

    /// The horizontal acceleration the velocity integrator holds (m/s², NED): the trim
    /// against the wind (and the drag of flight). It points into the wind.
    pub fn trim_accel_ned_mps2(&self) -> Vector3<f64> {
        self.vel_integral * self.gains.vel_integral
    }

    /// A hold begins after flight along a trajectory (a path, the roll manoeuvre). In
    /// flight the velocity integrator also held the drag of the airspeed (the flight's speed
    /// through the wind: 1.3 m/s² more at 8 m/s into 7 m/s of wind), which the stopped
    /// helicopter no longer has. Left to bleed off at the integrator's time constant
    /// (`vel_to_accel / vel_integral`, some 9 s) it pushed the helicopter on at up to 1 m/s
    /// for ten seconds after the stop, and the stop's target rode along with it. So once
    /// slower than [`SETTLE_FROM_MPS`], the integrator learns [`SETTLE_INTEGRAL_BOOST`]
    /// times faster for [`SETTLE_S`].
    pub fn enter_hold(&mut self) {
        self.settling_s = Some(SETTLE_S);
    }

    /// Whether a hold begun after flight is still to unlearn, or unlearning, that flight's
    /// drag ([`HoverController::enter_hold`]).
    pub fn settling(&self) -> bool {
        self.settling_s.is_some()
    }

    /// Clears the integrators (on the ground, or when another mode had control).
    pub fn reset(&mut self) {
        self.settling_s = None;
        self.vel_integral = Vector3::zeros();
        self.climb_integral = 0.0;
        self.yaw_integral = 0.0;
        self.tail_feedforward = None;
        self.heading_lock = HeadingLock::default();
    }

    /// One control step of `dt_s` toward `target`. `airborne` enables the horizontal and yaw
    /// integrators (skids on the ground would wind them up).
    pub fn update(
        &mut self,
        est: &NavState,
        target: &Target,
        dt_s: f64,
        airborne: bool,
    ) -> Controls {
        let g = self.gains;
        let dt = sanitize_dt(dt_s);
        let (_, _, yaw) = est.euler_rad();
        let pos = est.pos_ned_m;

        // Horizontal: position -> velocity (target's velocity as feedforward).
        let pos_err = Vector3::new(target.pos_ned_m.x - pos.x, target.pos_ned_m.y - pos.y, 0.0);
        let mut correction = pos_err * g.pos_to_vel;
        let speed = correction.norm();
        if speed > g.max_horizontal_speed_mps {
            correction *= g.max_horizontal_speed_mps / speed;
        }
        let vel_cmd = Vector3::new(target.vel_ned_mps.x, target.vel_ned_mps.y, 0.0) + correction;
        let (roll_cmd, pitch_cmd) = self.velocity_to_attitude(est, &vel_cmd, dt, airborne);
        let (aileron, elevator) = self.attitude_to_cyclic(est, roll_cmd, pitch_cmd);

        // Vertical: altitude -> climb rate (NED: down is positive).
        let w_cmd = target.vel_ned_mps.z
            + (g.alt_to_climb * (target.pos_ned_m.z - pos.z))
                .clamp(-g.max_climb_mps, g.max_descent_mps);
        let collective = self.climb_to_collective(est, w_cmd, dt);

        // Heading -> yaw rate.
        let yaw_err = heli_nav::navigator::wrap_pi(target.yaw_rad - yaw);
        let r_cmd = limit(g.heading_to_rate * yaw_err, g.max_yaw_rate_rps);
        let rudder = self.yaw_rate_to_tail(est, r_cmd, collective, dt, airborne);

        Controls {
            aileron: limit(aileron, 1.0),
            elevator: limit(elevator, 1.0),
            rudder: limit(rudder, 1.0),
            collective: limit(collective, 1.0),
            throttle: GOVERNED_THROTTLE,
        }
    }

    /// Horizontal velocity command (NED) -> roll and pitch commands: acceleration with an
    /// integrator (in the air only), into the heading frame, nose down to go forward.
    pub fn velocity_to_attitude(
        &mut self,
        est: &NavState,
        vel_cmd: &Vector3<f64>,
        dt: f64,
        airborne: bool,
    ) -> (f64, f64) {
        let g = self.gains;
        let (_, _, yaw) = est.euler_rad();
        let vel = est.vel_ned_mps;
        let vel_err = Vector3::new(vel_cmd.x - vel.x, vel_cmd.y - vel.y, 0.0);
        if airborne {
            // Settling after flight: the drag's trim unlearnt faster, once stopped.
            let boost = match self.settling_s {
                Some(left_s) if left_s < SETTLE_S || vel.xy().norm() < SETTLE_FROM_MPS => {
                    let left_s = left_s - dt;
                    self.settling_s = (left_s > 0.0).then_some(left_s);
                    SETTLE_INTEGRAL_BOOST
                }
                _ => 1.0,
            };
            self.vel_integral += vel_err * (dt * boost);
            // The trim is limited in magnitude, whatever its direction.
            let trim = self.vel_integral.norm() * g.vel_integral;
            if trim > g.max_trim_accel_mps2 {
                self.vel_integral *= g.max_trim_accel_mps2 / trim;
            }
        }
        // The correction and the trim are limited apart: a strong wind's trim does not use
        // up the room to correct (the tilt limit below bounds the sum).
        let mut correction = vel_err * g.vel_to_accel;
        let a = correction.norm();
        if a > g.max_accel_mps2 {
            correction *= g.max_accel_mps2 / a;
        }
        let accel_cmd = correction + self.vel_integral * g.vel_integral;
        let (roll_cmd, pitch_cmd) = accel_to_attitude(yaw, &accel_cmd);
        (
            limit(roll_cmd, g.max_tilt_rad),
            limit(pitch_cmd, g.max_tilt_rad),
        )
    }

    /// Roll and pitch commands -> rate commands -> lateral and longitudinal cyclic.
    pub fn attitude_to_cyclic(&self, est: &NavState, roll_cmd: f64, pitch_cmd: f64) -> (f64, f64) {
        let g = self.gains;
        let (roll, pitch, _) = est.euler_rad();
        let p_cmd = limit(g.att_to_rate * (roll_cmd - roll), g.max_rate_rps);
        let q_cmd = limit(g.att_to_rate * (pitch_cmd - pitch), g.max_rate_rps);
        self.rates_to_cyclic(est, p_cmd, q_cmd)
    }

    /// Roll and pitch rate commands -> cyclic (feedforward of the rotor's inverse DC gain plus
    /// feedback).
    pub fn rates_to_cyclic(&self, est: &NavState, p_cmd: f64, q_cmd: f64) -> (f64, f64) {
        let g = self.gains;
        let rate = est.rate_body_rps;
        let aileron = g.rate_feedforward * p_cmd + g.rate_feedback * (p_cmd - rate.x);
        let elevator = g.rate_feedforward * q_cmd + g.rate_feedback * (q_cmd - rate.y);
        (limit(aileron, 1.0), limit(elevator, 1.0))
    }

    /// Climb-rate command (NED, down positive) -> collective, with the hover feedforward
    /// corrected for tilt and an integrator.
    pub fn climb_to_collective(&mut self, est: &NavState, w_cmd: f64, dt: f64) -> f64 {
        let g = self.gains;
        let (roll, pitch, _) = est.euler_rad();
        let w_err = w_cmd - est.vel_ned_mps.z;
        self.climb_integral = limit(
            self.climb_integral + w_err * dt,
            0.5 / g.climb_integral.max(1e-6),
        );
        let tilt_cos = (roll.cos() * pitch.cos()).max(0.5);
        limit(
            g.hover_collective / tilt_cos
                - g.climb_feedback * w_err
                - g.climb_integral * self.climb_integral,
            1.0,
        )
    }

    /// Yaw-rate command -> tail, with the rotor-torque feedforward lagged like the engine.
    pub fn yaw_rate_to_tail(
        &mut self,
        est: &NavState,
        r_cmd: f64,
        collective: f64,
        dt: f64,
        airborne: bool,
    ) -> f64 {
        let g = self.gains;
        let r_err = r_cmd - est.rate_body_rps.z;
        if airborne {
            self.yaw_integral = limit(
                self.yaw_integral + r_err * dt,
                YAW_TRIM_AUTHORITY / g.yaw_integral.max(1e-6),
            );
        }
        let torque_feedforward =
            g.tail_trim * (collective / g.hover_collective.max(1e-6)).clamp(0.0, 2.0);
        // Starting on the ground the engine still delivers idle torque; in the air, the
        // torque of the current collective.
        let lagged =
            self.tail_feedforward
                .unwrap_or(if airborne { torque_feedforward } else { 0.0 });
        let alpha = (dt / g.tail_feedforward_lag_s.max(dt).max(1e-6)).clamp(0.0, 1.0);
        let lagged = limit(lagged + alpha * (torque_feedforward - lagged), 1.0);
        self.tail_feedforward = Some(lagged);
        limit(
            lagged + g.yaw_rate_feedback * r_err + g.yaw_integral * self.yaw_integral,
            1.0,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn est_at(pos: Vector3<f64>, vel: Vector3<f64>) -> NavState {
        NavState {
            t_us: 0,
            att: UnitQuaternion::identity(),
            vel_ned_mps: vel,
            pos_ned_m: pos,
            rate_body_rps: Vector3::zeros(),
            accel_body_mps2: Vector3::new(0.0, 0.0, -9.81),
            gyro_bias_rps: Vector3::zeros(),
            accel_bias_mps2: Vector3::zeros(),
        }
    }

    #[test]
    fn target_ahead_tilts_nose_down_and_target_right_rolls_right() {
        let mut c = HoverController::new(HoverGains::default());
        let t = Target {
            pos_ned_m: Vector3::new(5.0, 0.0, -10.0),
            vel_ned_mps: Vector3::zeros(),
            yaw_rad: 0.0,
        };
        let u = c.update(
            &est_at(Vector3::new(0.0, 0.0, -10.0), Vector3::zeros()),
            &t,
            0.02,
            true,
        );
        assert!(u.elevator < 0.0, "{u:?}");
        let t = Target {
            pos_ned_m: Vector3::new(0.0, 5.0, -10.0),
            vel_ned_mps: Vector3::zeros(),
            yaw_rad: 0.0,
        };
        let u = c.update(
            &est_at(Vector3::new(0.0, 0.0, -10.0), Vector3::zeros()),
            &t,
            0.02,
            true,
        );
        assert!(u.aileron > 0.0, "{u:?}");
    }

    #[test]
    fn below_target_raises_collective_above_hover() {
        let mut c = HoverController::new(HoverGains::default());
        let t = Target {
            pos_ned_m: Vector3::new(0.0, 0.0, -10.0),
            vel_ned_mps: Vector3::zeros(),
            yaw_rad: 0.0,
        };
        let u = c.update(&est_at(Vector3::zeros(), Vector3::zeros()), &t, 0.02, false);
        assert!(u.collective > HoverGains::default().hover_collective);
        assert_eq!(u.throttle, GOVERNED_THROTTLE);
    }

    #[test]
    fn non_finite_estimate_gives_bounded_commands() {
        let mut c = HoverController::new(HoverGains::default());
        let t = Target {
            pos_ned_m: Vector3::zeros(),
            vel_ned_mps: Vector3::zeros(),
            yaw_rad: 0.0,
        };
        let u = c.update(
            &est_at(Vector3::new(f64::NAN, 0.0, 0.0), Vector3::zeros()),
            &t,
            0.02,
            true,
        );
        for x in [u.aileron, u.elevator, u.rudder, u.collective] {
            assert!(x.is_finite() && x.abs() <= 1.0);
        }
    }

    /// How many times the usual rate the velocity integrator learnt in one step of `dt_s`
    /// with 1 m/s of velocity error north, flying east at `speed_mps`.
    fn learning(c: &mut HoverController, speed_mps: f64, dt_s: f64) -> f64 {
        let before = c.trim_accel_ned_mps2().x;
        let e = est_at(
            Vector3::new(0.0, 0.0, -10.0),
            Vector3::new(0.0, speed_mps, 0.0),
        );
        c.velocity_to_attitude(&e, &Vector3::new(1.0, speed_mps, 0.0), dt_s, true);
        (c.trim_accel_ned_mps2().x - before) / (c.gains.vel_integral * dt_s)
    }

    #[test]
    fn a_hold_after_flight_unlearns_the_flight_s_drag_faster_once_stopped_and_for_a_while() {
        let dt = 0.0625;
        let mut c = HoverController::new(HoverGains::default());
        let near = |a: f64, b: f64| (a - b).abs() < 1e-9;
        // Without a hold after flight, and while it still slows: the usual rate.
        assert!(near(learning(&mut c, 1.0, dt), 1.0));
        assert!(!c.settling());
        c.enter_hold();
        assert!(c.settling());
        assert!(near(learning(&mut c, 5.0, dt), 1.0), "still braking");
        assert!(
            near(learning(&mut c, SETTLE_FROM_MPS, dt), 1.0),
            "not yet slower"
        );
        // Stopped: three times the rate, for SETTLE_S from then, fast or slow.
        let mut boosted = 0;
        for i in 0..1000 {
            let rate = learning(&mut c, if i % 2 == 0 { 1.0 } else { 5.0 }, dt);
            if near(rate, 1.0) {
                break;
            }
            assert!(near(rate, SETTLE_INTEGRAL_BOOST), "{rate} at step {i}");
            boosted += 1;
        }
        assert_eq!(f64::from(boosted) * dt, SETTLE_S);
        assert!(!c.settling());
        assert!(near(learning(&mut c, 1.0, dt), 1.0), "over");
        // Cleared with the integrators.
        c.enter_hold();
        c.reset();
        assert!(near(learning(&mut c, 1.0, dt), 1.0));
    }
}
