//! The X-Cell 60 nonlinear model: rigid body with quaternion attitude, main-rotor thrust with
//! the inflow iteration, first-order lumped rotor/stabilizer-bar flapping, tail rotor, engine
//! with the rotor-speed governor, fuselage drag and skid contact with the ground.
//!
//! Equations follow Gavrilets ch. 15 §3; the
//! places where the printed equations were corrected on physical grounds are marked
//! "typo" and listed in `docs/model.md`. Servo dynamics live in [`crate::actuators`]: the
//! inputs here are blade pitches the servos have already reached.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::params::{Airframe, Atmosphere};
use crate::rotor::DiskLoad;
use crate::{empennage, ground, rotor};

/// Blade-pitch inputs the physics sees (after the servos), plus the governor set point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ControlInputs {
    /// Lateral cyclic δ_lat (rad), positive rolls right.
    pub lat_rad: f64,
    /// Longitudinal cyclic δ_lon (rad), positive pitches nose up.
    pub lon_rad: f64,
    /// Main-rotor collective θ0 (rad).
    pub col_rad: f64,
    /// Tail-rotor pitch command δ_r^cmd (rad); the trim offset is added by the model.
    pub tail_rad: f64,
    /// Governor rotor-speed set point (rad/s).
    pub governor_setpoint_rps: f64,
}

/// The model's state (17 numbers with the quaternion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Position of the centre of gravity, NED (m).
    pub pos_ned_m: Vector3<f64>,
    /// Velocity, body FRD axes (m/s).
    pub vel_body_mps: Vector3<f64>,
    /// Attitude, body to NED.
    pub att: UnitQuaternion<f64>,
    /// Angular rate, body axes (rad/s).
    pub rate_body_rps: Vector3<f64>,
    /// Longitudinal tip-path-plane flapping a1 (rad), positive tilted aft.
    pub flap_lon_rad: f64,
    /// Lateral tip-path-plane flapping b1 (rad), positive tilted right.
    pub flap_lat_rad: f64,
    /// Main-rotor speed relative to the fuselage (rad/s).
    pub rotor_rps: f64,
    /// Integral of the governor's rotor-speed error (rad).
    pub governor_integral_rad: f64,
}

/// Number of numbers in the state vector (with the quaternion's four).
pub const N_STATE: usize = 17;

/// Index of each state in [`State::to_array`].
pub mod index {
    /// North, east, down position.
    pub const POS: usize = 0;
    /// Body u, v, w.
    pub const VEL: usize = 3;
    /// Quaternion w, i, j, k.
    pub const QUAT: usize = 6;
    /// Body p, q, r.
    pub const RATE: usize = 10;
    /// Longitudinal flapping a1.
    pub const A1: usize = 13;
    /// Lateral flapping b1.
    pub const B1: usize = 14;
    /// Rotor speed.
    pub const ROTOR: usize = 15;
    /// Governor integrator.
    pub const GOVERNOR: usize = 16;
}

impl State {
    /// The state as a flat vector (layout in [`index`]).
    pub fn to_array(self) -> [f64; N_STATE] {
        let q = self.att.quaternion();
        [
            self.pos_ned_m.x,
            self.pos_ned_m.y,
            self.pos_ned_m.z,
            self.vel_body_mps.x,
            self.vel_body_mps.y,
            self.vel_body_mps.z,
            q.w,
            q.i,
            q.j,
            q.k,
            self.rate_body_rps.x,
            self.rate_body_rps.y,
            self.rate_body_rps.z,
            self.flap_lon_rad,
            self.flap_lat_rad,
            self.rotor_rps,
            self.governor_integral_rad,
        ]
    }

    /// The state from a flat vector (the quaternion is normalised).
    pub fn from_array(a: &[f64; N_STATE]) -> Self {
        Self {
            pos_ned_m: Vector3::new(a[0], a[1], a[2]),
            vel_body_mps: Vector3::new(a[3], a[4], a[5]),
            att: UnitQuaternion::from_quaternion(Quaternion::new(a[6], a[7], a[8], a[9])),
            rate_body_rps: Vector3::new(a[10], a[11], a[12]),
            flap_lon_rad: a[13],
            flap_lat_rad: a[14],
            rotor_rps: a[15],
            governor_integral_rad: a[16],
        }
    }

    /// Velocity in NED axes (m/s).
    pub fn vel_ned_mps(&self) -> Vector3<f64> {
        self.att * self.vel_body_mps
    }
}

/// Quantities computed along with the derivative, for sensors and the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outputs {
    /// Specific force at the centre of gravity, body axes (m/s²): what an accelerometer reads.
    pub specific_force_body_mps2: Vector3<f64>,
    /// Main-rotor thrust (N).
    pub thrust_n: f64,
    /// Main-rotor torque (N m).
    pub mr_torque_nm: f64,
    /// Main-rotor induced inflow ratio.
    pub inflow_ratio: f64,
    /// Tail-rotor induced inflow ratio.
    pub tr_inflow_ratio: f64,
    /// Tail-rotor side force Y_tr (N).
    pub tr_force_n: f64,
    /// Tail-rotor shaft torque (N m).
    pub tr_torque_nm: f64,
    /// Engine torque at the main shaft (N m).
    pub engine_torque_nm: f64,
    /// Throttle produced by the governor, 0..1.
    pub throttle: f64,
    /// Number of skid points touching the ground.
    pub contact_points: u32,
    /// Largest downward speed of a touching skid point (m/s).
    pub contact_sink_mps: f64,
}

/// The helicopter: airframe parameters, state and the inflow guesses that warm-start the
/// thrust iterations.
#[derive(Clone, Debug)]
pub struct Helicopter {
    /// Airframe parameters.
    pub airframe: Airframe,
    /// Current state.
    pub state: State,
    /// Outputs at the start of the last step.
    pub outputs: Outputs,
    /// The fraction of its power the engine can give (1; less after an engine fault, 0 when
    /// it has quit): the governor's throttle scales what is left.
    pub engine_power_available: f64,
    mr_inflow_guess: f64,
    tr_inflow_guess: f64,
    anchors: ground::Anchors,
}

/// Wind and air the helicopter flies in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    /// Wind velocity, NED (m/s).
    pub wind_ned_mps: Vector3<f64>,
    /// Atmosphere.
    pub atmosphere: Atmosphere,
}

impl Helicopter {
    /// A helicopter resting level on its skids at the origin, heading north, rotor at `rotor_rps`.
    pub fn on_ground(airframe: Airframe, rotor_rps: f64) -> Self {
        let skid_depth = airframe.skid_points_m[0][2];
        let static_deflection = airframe.mass_kg * 9.81 / (4.0 * airframe.ground_stiffness_n_per_m);
        let state = State {
            pos_ned_m: Vector3::new(0.0, 0.0, -skid_depth + static_deflection),
            vel_body_mps: Vector3::zeros(),
            att: UnitQuaternion::identity(),
            rate_body_rps: Vector3::zeros(),
            flap_lon_rad: 0.0,
            flap_lat_rad: 0.0,
            rotor_rps,
            governor_integral_rad: 0.0,
        };
        Self {
            airframe,
            state,
            outputs: Outputs::default(),
            engine_power_available: 1.0,
            mr_inflow_guess: 0.03,
            tr_inflow_guess: 0.05,
            anchors: [None; 4],
        }
    }

    /// Sets the governor integrator so that the engine holds the current rotor speed
    /// against the torque of collective `col_rad` in still air (a governed start).
    pub fn trim_governor(&mut self, col_rad: f64, env: &Environment) {
        let (_, out) = self.derivative(
            &self.state,
            &ControlInputs {
                col_rad,
                ..Default::default()
            },
            env,
        );
        let a = &self.airframe;
        let needed_torque = out.mr_torque_nm + a.tr_gear_ratio * out.tr_torque_nm;
        let power = needed_torque * self.state.rotor_rps;
        let throttle = ((power - a.engine_idle_power_w)
            / (a.engine_max_power_w - a.engine_idle_power_w))
            .clamp(0.0, 1.0);
        self.state.governor_integral_rad = throttle / a.governor_ki;
    }

    /// State derivative and outputs at state `s` with inputs `u`.
    pub fn derivative(
        &self,
        s: &State,
        u: &ControlInputs,
        env: &Environment,
    ) -> ([f64; N_STATE], Outputs) {
        let a = &self.airframe;
        let rho = env.atmosphere.density_kgpm3;
        let g = env.atmosphere.gravity_mps2;
        let m = a.mass_kg;
        let att = s.att;
        let w = s.rate_body_rps;
        let (p, q, r) = (w.x, w.y, w.z);

        // Body to NED as a matrix: one conversion, then nine multiply-adds per rotation.
        let rot = att.to_rotation_matrix().into_inner();
        let wind_body = rot.tr_mul(&env.wind_ned_mps);
        let va = s.vel_body_mps - wind_body;
        let (ua, v_a, wa) = (va.x, va.y, va.z);

        // Main rotor (15.3–15.12).
        let omega = s.rotor_rps.max(1.0);
        let tip = omega * a.mr_radius_m;
        let mu = (ua * ua + v_a * v_a).sqrt() / tip;
        let mu_z = wa / tip;
        // Ground effect from the hub's height above the ground (NED z = 0).
        let hub_height_m = -(s.pos_ned_m.z - rot.m33 * a.mr_hub_height_m);
        let mr: DiskLoad = self.airframe.main_disk().solve_in_ground_effect(
            rho,
            omega,
            mu,
            mu_z,
            u.col_rad,
            self.mr_inflow_guess,
            rotor::ground_effect_factor(a.mr_radius_m, hub_height_m),
        );
        let thrust = mr.thrust_n;
        let induced_mps = mr.inflow_ratio * tip;

        // Flapping (15.17–15.27), gains scheduled with rotor speed.
        let tau = a.flap_time_constant_s(omega);
        let speed_ratio = (omega / a.omega_nom_rps).powi(2);
        let b_lat = a.b_dlat * speed_ratio;
        let a_lon = a.a_dlon * speed_ratio;
        let a_sigma = a.mr_lift_slope * a.mr_solidity();
        let da1_dmu = 2.0 * a.k_mu * (4.0 * u.col_rad / 3.0 - mr.inflow_ratio);
        let mu_x = ua / tip;
        let da1_dmuz = a.k_mu * 16.0 * mu_x * mu_x * mu_x.signum()
            / ((1.0 - 0.5 * mu_x * mu_x) * (8.0 * mu_x.abs() + a_sigma));
        let a1 = s.flap_lon_rad;
        let b1 = s.flap_lat_rad;
        let a1_dot =
            -q - a1 / tau + (da1_dmu * mu_x + da1_dmuz * mu_z) / tau + a_lon / tau * u.lon_rad;
        // Typo (15.17 with 15.26): the printed signs make the disc tilt toward a side wind.
        // The rotor flaps away from the incoming air, as H15's text says: steady +v gives b1 < 0.
        let b1_dot = -p - b1 / tau - da1_dmu * (v_a / tip) / tau + b_lat / tau * u.lat_rad;

        let flap_stiffness = a.hub_stiffness_nm_per_rad + thrust * a.mr_hub_height_m;
        let l_mr = flap_stiffness * b1;
        let m_mr = flap_stiffness * a1;
        let f_mr = Vector3::new(-thrust * a1, thrust * b1, -thrust);

        // Fuselage drag (H15 §15.4.3). Typo: the printed (w_a + V_imr) would lift the
        // fuselage in its own downwash; the downwash pushes it down, so (w_a − V_i).
        let w_fus = wa - induced_mps;
        let v_inf = (ua * ua + v_a * v_a + w_fus * w_fus).sqrt();
        let f_fus = -0.5
            * rho
            * v_inf
            * Vector3::new(
                a.fus_area_x_m2 * ua,
                a.fus_area_y_m2 * v_a,
                a.fus_area_z_m2 * w_fus,
            );

        // Main-rotor wake on the tail surfaces (15.48–15.49).
        let wake = empennage::wake_factor(a, ua, wa, induced_mps) * induced_mps;

        // Tail rotor: the main-rotor disk model turned on its side, thrust toward −y.
        let omega_tr = a.tr_gear_ratio * omega;
        let tip_tr = omega_tr * a.tr_radius_m;
        let w_tr = wa + a.tr_arm_m * q - wake;
        let mu_tr = (ua * ua + w_tr * w_tr).sqrt() / tip_tr;
        let v_tr = v_a - a.tr_arm_m * r + a.tr_height_m * p;
        let mu_z_tr = v_tr / tip_tr;
        let tail_pitch = u.tail_rad + a.tr_pitch_trim_rad;
        let tr = self.airframe.tail_disk().solve(
            rho,
            omega_tr,
            mu_tr,
            mu_z_tr,
            tail_pitch,
            self.tr_inflow_guess,
        );
        let y_tr = -a.tr_fin_blockage() * tr.thrust_n;

        // Vertical fin (15.35–15.38): in the tail rotor's induced flow and the wake.
        let tr_induced_mps = tr.inflow_ratio * tip_tr;
        let v_vf = v_a - a.vf_tr_wash_fraction * tr_induced_mps - a.tr_arm_m * r;
        let v_plane_tr = (ua * ua + w_tr * w_tr).sqrt();
        let y_vf = empennage::vertical_fin_force(a, rho, v_plane_tr, v_vf);

        // Horizontal stabilizer (15.39–15.42).
        let w_ht = wa + a.ht_arm_m * q - wake;
        let z_ht = empennage::stabilizer_force(a, rho, ua, w_ht);

        // Tail forces and moments: fin and tail rotor act at the tail-rotor hub.
        let f_tail = Vector3::new(0.0, y_tr + y_vf, z_ht);
        let l_tail = (y_tr + y_vf) * a.tr_height_m;
        let m_tail = z_ht * a.ht_arm_m;
        let n_tail = -(y_tr + y_vf) * a.tr_arm_m;

        // Engine and governor (15.28–15.31): PI on rotor speed, anti-windup by conditional integration.
        let speed_error = u.governor_setpoint_rps - s.rotor_rps;
        let throttle_raw = a.governor_kp * speed_error + a.governor_ki * s.governor_integral_rad;
        let throttle = throttle_raw.clamp(0.0, 1.0);
        let saturated =
            (throttle_raw > 1.0 && speed_error > 0.0) || (throttle_raw < 0.0 && speed_error < 0.0);
        let integral_dot = if saturated { 0.0 } else { speed_error };
        let power = self.engine_power_available.clamp(0.0, 1.0)
            * (a.engine_idle_power_w + (a.engine_max_power_w - a.engine_idle_power_w) * throttle);
        let engine_torque = power / omega;

        // Ground contact.
        let contact =
            ground::skid_contact(a, &self.anchors, &s.pos_ned_m, &rot, &s.vel_body_mps, &w);

        // Sums of forces and moments (body axes).
        let f_aero = f_mr + f_fus + f_tail;
        let f_total_nongrav = f_aero + contact.force_body_n;
        let gravity_body = rot.tr_mul(&Vector3::new(0.0, 0.0, g));
        let moments = Vector3::new(l_mr + l_tail, m_mr + m_tail, -engine_torque + n_tail)
            + contact.moment_body_nm;

        let specific_force = f_total_nongrav / m;
        let vel_dot = specific_force + gravity_body - w.cross(&s.vel_body_mps);
        let inertia = Vector3::new(a.ixx_kgm2, a.iyy_kgm2, a.izz_kgm2);
        let i_w = inertia.component_mul(&w);
        let rate_dot = (moments - w.cross(&i_w)).component_div(&inertia);

        // Rotor speed relative to the fuselage: the shaft torques accelerate the rotor in
        // inertial space; the fuselage's own yaw acceleration (same sense as the rotor,
        // which turns clockwise seen from above) subtracts.
        let rotor_dot = (engine_torque - mr.torque_nm - a.tr_gear_ratio * tr.torque_nm)
            / a.rotor_system_inertia_kgm2
            - rate_dot.z;

        let pos_dot = rot * s.vel_body_mps;
        let qv = att.quaternion();
        let q_dot = qv * Quaternion::new(0.0, p, q, r) * 0.5;

        let d = [
            pos_dot.x,
            pos_dot.y,
            pos_dot.z,
            vel_dot.x,
            vel_dot.y,
            vel_dot.z,
            q_dot.w,
            q_dot.i,
            q_dot.j,
            q_dot.k,
            rate_dot.x,
            rate_dot.y,
            rate_dot.z,
            a1_dot,
            b1_dot,
            rotor_dot,
            integral_dot,
        ];
        let out = Outputs {
            specific_force_body_mps2: specific_force,
            thrust_n: thrust,
            mr_torque_nm: mr.torque_nm,
            inflow_ratio: mr.inflow_ratio,
            tr_inflow_ratio: tr.inflow_ratio,
            tr_force_n: y_tr,
            tr_torque_nm: tr.torque_nm,
            engine_torque_nm: engine_torque,
            throttle,
            contact_points: contact.points_touching,
            contact_sink_mps: contact.max_sink_mps,
        };
        (d, out)
    }

    /// Advances the state by `dt_s` with fourth-order Runge–Kutta (H15 integrated at 0.01 s;
    /// we use smaller steps for the stiff skid contact).
    pub fn step(&mut self, dt_s: f64, u: &ControlInputs, env: &Environment) {
        let x0 = self.state.to_array();
        let (k1, out) = self.derivative(&self.state, u, env);
        self.outputs = out;
        self.mr_inflow_guess = out.inflow_ratio;
        self.tr_inflow_guess = out.tr_inflow_ratio;
        let add = |x: &[f64; N_STATE], k: &[f64; N_STATE], h: f64| {
            let mut y = *x;
            for (yi, ki) in y.iter_mut().zip(k) {
                *yi += h * ki;
            }
            State::from_array(&y)
        };
        let (k2, _) = self.derivative(&add(&x0, &k1, 0.5 * dt_s), u, env);
        let (k3, _) = self.derivative(&add(&x0, &k2, 0.5 * dt_s), u, env);
        let (k4, _) = self.derivative(&add(&x0, &k3, dt_s), u, env);
        let mut x = x0;
        for i in 0..N_STATE {
            x[i] += dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        self.state = State::from_array(&x);
        let s = &self.state;
        ground::update_anchors(
            &self.airframe,
            &mut self.anchors,
            &s.pos_ned_m,
            &s.att,
            &s.vel_body_mps,
            &s.rate_body_rps,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn still_air() -> Environment {
        Environment {
            wind_ned_mps: Vector3::zeros(),
            atmosphere: Atmosphere::default(),
        }
    }

    fn airborne_hover() -> Helicopter {
        let mut h = Helicopter::on_ground(
            Airframe::default(),
            1600.0 / 60.0 * 2.0 * std::f64::consts::PI,
        );
        h.state.pos_ned_m = Vector3::new(0.0, 0.0, -50.0);
        h
    }

    /// A state driven out of the model's range (here a velocity that is not a number) goes
    /// through a step without a panic: the lockstep sees it non-finite and ends the flight.
    #[test]
    fn a_non_finite_state_never_panics_a_step() {
        let env = still_air();
        for bad in [f64::NAN, f64::INFINITY, 1e300] {
            let mut h = airborne_hover();
            h.state.vel_body_mps = Vector3::new(bad, -bad, bad);
            h.step(0.005, &ControlInputs::default(), &env);
            h.step(0.005, &ControlInputs::default(), &env);
        }
    }

    #[test]
    fn resting_on_the_ground_stays_put() {
        let env = still_air();
        let mut h = Helicopter::on_ground(Airframe::default(), 167.55);
        let u = ControlInputs {
            governor_setpoint_rps: 167.55,
            ..Default::default()
        };
        h.trim_governor(0.0, &env);
        let start = h.state.pos_ned_m;
        for _ in 0..5000 {
            h.step(0.002, &u, &env);
        }
        let moved = (h.state.pos_ned_m - start).norm();
        assert!(moved < 0.05, "moved {moved} m: {:?}", h.state);
        assert_eq!(h.outputs.contact_points, 4);
        assert!(
            (h.state.rotor_rps - 167.55).abs() < 2.0,
            "rotor {}",
            h.state.rotor_rps
        );
    }

    #[test]
    fn hover_collective_balances_weight() {
        let env = still_air();
        let h = airborne_hover();
        let u = ControlInputs {
            col_rad: 0.0985,
            governor_setpoint_rps: 167.55,
            ..Default::default()
        };
        let (d, out) = h.derivative(&h.state, &u, &env);
        assert!(d[5].abs() < 0.3, "vertical acceleration {}", d[5]);
        assert!((out.thrust_n - 8.2 * 9.81).abs() < 3.0);
    }

    #[test]
    fn lateral_cyclic_rolls_right() {
        let env = still_air();
        let mut h = airborne_hover();
        let u = ControlInputs {
            col_rad: 0.0985,
            lat_rad: 0.05,
            governor_setpoint_rps: 167.55,
            ..Default::default()
        };
        h.trim_governor(0.0985, &env);
        // The disc tilts right first, then the fuselage follows it into a roll.
        for _ in 0..10 {
            h.step(0.002, &u, &env);
        }
        assert!(h.state.flap_lat_rad > 0.0, "b1 {}", h.state.flap_lat_rad);
        for _ in 0..90 {
            h.step(0.002, &u, &env);
        }
        assert!(h.state.rate_body_rps.x > 0.5, "{:?}", h.state.rate_body_rps);
    }

    #[test]
    fn side_velocity_flaps_the_rotor_away_from_the_wind() {
        let env = still_air();
        let mut h = airborne_hover();
        h.state.vel_body_mps = Vector3::new(0.0, 5.0, 0.0);
        let u = ControlInputs {
            col_rad: 0.0985,
            governor_setpoint_rps: 167.55,
            ..Default::default()
        };
        let (d, _) = h.derivative(&h.state, &u, &env);
        assert!(d[14] < 0.0, "b1 rate {}", d[14]);
    }

    #[test]
    fn tail_rotor_pushes_the_nose_right_against_engine_torque() {
        let env = still_air();
        let mut h = airborne_hover();
        h.trim_governor(0.0985, &env);
        let u = |tail| ControlInputs {
            col_rad: 0.0985,
            tail_rad: tail,
            governor_setpoint_rps: 167.55,
            ..Default::default()
        };
        let (d_low, _) = h.derivative(&h.state, &u(-0.3), &env);
        let (d_high, _) = h.derivative(&h.state, &u(0.3), &env);
        assert!(d_high[12] > d_low[12]);
    }
}
