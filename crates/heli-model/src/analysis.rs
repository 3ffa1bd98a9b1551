//! Analyses of the model alone, behind `heli model`: trim at a forward speed, the linearised
//! rotor–fuselage modes at hover, and the governor's response to a rotor-speed step. They are
//! the checks against the published numbers (H15 §5–7).

use nalgebra::{Matrix2, SMatrix, SVector, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::model::{ControlInputs, Environment, Helicopter, N_STATE, State, index};
use crate::params::{Airframe, Atmosphere};

/// Nominal rotor speed of every flight in the thesis: 1600 rpm (rad/s).
pub const ROTOR_1600_RPM_RPS: f64 = 1600.0 * std::f64::consts::PI / 30.0;

/// A trimmed, steady, level flight condition.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Trim {
    /// Forward speed (m/s).
    pub speed_mps: f64,
    /// Collective blade pitch (deg).
    pub collective_deg: f64,
    /// Lateral cyclic (rad).
    pub lat_cyclic_rad: f64,
    /// Longitudinal cyclic (rad).
    pub lon_cyclic_rad: f64,
    /// Tail-rotor pitch command δ_r^cmd (rad), without the trim offset.
    pub tail_pitch_cmd_rad: f64,
    /// Roll attitude (deg).
    pub roll_deg: f64,
    /// Pitch attitude (deg).
    pub pitch_deg: f64,
    /// Longitudinal flapping a1 (deg).
    pub flap_lon_deg: f64,
    /// Lateral flapping b1 (deg).
    pub flap_lat_deg: f64,
    /// Main-rotor thrust (N).
    pub thrust_n: f64,
    /// Main-rotor torque (N m).
    pub mr_torque_nm: f64,
    /// Shaft power to both rotors (W).
    pub power_w: f64,
    /// Throttle the governor settles at.
    pub throttle: f64,
    /// Largest residual acceleration left (m/s² or rad/s²).
    pub residual: f64,
    /// Newton iterations used.
    pub iterations: u32,
}

/// The trim unknowns: lat, lon, col, tail, roll, pitch, a1, b1.
type Unknowns = SVector<f64, 8>;

fn still_air() -> Environment {
    Environment {
        wind_ned_mps: Vector3::zeros(),
        atmosphere: Atmosphere::default(),
    }
}

/// The helicopter at 100 m in the condition `x` describes, flying north at `speed_mps`, with
/// the governor integrator set so that the engine exactly holds 1600 rpm.
fn condition(airframe: &Airframe, speed_mps: f64, x: &Unknowns) -> (Helicopter, ControlInputs) {
    let mut heli = Helicopter::on_ground(airframe.clone(), ROTOR_1600_RPM_RPS);
    let att = UnitQuaternion::from_euler_angles(x[4], x[5], 0.0);
    heli.state.pos_ned_m = Vector3::new(0.0, 0.0, -100.0);
    heli.state.att = att;
    heli.state.vel_body_mps = att.inverse() * Vector3::new(speed_mps, 0.0, 0.0);
    heli.state.flap_lon_rad = x[6];
    heli.state.flap_lat_rad = x[7];
    let u = ControlInputs {
        lat_rad: x[0],
        lon_rad: x[1],
        col_rad: x[2],
        tail_rad: x[3],
        governor_setpoint_rps: ROTOR_1600_RPM_RPS,
    };
    let env = still_air();
    let (_, out) = heli.derivative(&heli.state, &u, &env);
    let power = (out.mr_torque_nm + airframe.tr_gear_ratio * out.tr_torque_nm) * ROTOR_1600_RPM_RPS;
    let throttle = (power - airframe.engine_idle_power_w)
        / (airframe.engine_max_power_w - airframe.engine_idle_power_w);
    heli.state.governor_integral_rad = throttle / airframe.governor_ki;
    (heli, u)
}

fn residual(airframe: &Airframe, speed_mps: f64, x: &Unknowns) -> Unknowns {
    let (heli, u) = condition(airframe, speed_mps, x);
    let (d, _) = heli.derivative(&heli.state, &u, &still_air());
    Unknowns::from_column_slice(&[
        d[index::VEL],
        d[index::VEL + 1],
        d[index::VEL + 2],
        d[index::RATE],
        d[index::RATE + 1],
        d[index::RATE + 2],
        d[index::A1],
        d[index::B1],
    ])
}

/// Trims the model in steady level flight north at `speed_mps` (Newton's method with a
/// finite-difference Jacobian). `None` if it does not converge.
pub fn trim(airframe: &Airframe, speed_mps: f64) -> Option<Trim> {
    let mut x = Unknowns::from_column_slice(&[0.0, 0.0, 0.0985, 0.13, 0.05, 0.0, 0.0, 0.0]);
    let mut iterations = 0;
    let mut r = residual(airframe, speed_mps, &x);
    while r.amax() > 1e-9 && iterations < 50 {
        iterations += 1;
        let mut jac = SMatrix::<f64, 8, 8>::zeros();
        for j in 0..8 {
            let h = 1e-6;
            let mut xp = x;
            xp[j] += h;
            jac.set_column(j, &((residual(airframe, speed_mps, &xp) - r) / h));
        }
        let step = jac.lu().solve(&(-r))?;
        // Damp large steps: angles and blade pitches move by at most 0.1 rad per iteration.
        let scale = (0.1 / step.amax()).min(1.0);
        x += step * scale;
        r = residual(airframe, speed_mps, &x);
    }
    if r.amax() > 1e-6 {
        return None;
    }
    let (heli, u) = condition(airframe, speed_mps, &x);
    let (_, out) = heli.derivative(&heli.state, &u, &still_air());
    let power_w =
        (out.mr_torque_nm + airframe.tr_gear_ratio * out.tr_torque_nm) * ROTOR_1600_RPM_RPS;
    Some(Trim {
        speed_mps,
        collective_deg: x[2].to_degrees(),
        lat_cyclic_rad: x[0],
        lon_cyclic_rad: x[1],
        tail_pitch_cmd_rad: x[3],
        roll_deg: x[4].to_degrees(),
        pitch_deg: x[5].to_degrees(),
        flap_lon_deg: x[6].to_degrees(),
        flap_lat_deg: x[7].to_degrees(),
        thrust_n: out.thrust_n,
        mr_torque_nm: out.mr_torque_nm,
        power_w,
        throttle: out.throttle,
        residual: r.amax(),
        iterations,
    })
}

/// A helicopter trimmed at `speed_mps` with its controls, ready to be flown or linearised.
pub fn trimmed_helicopter(
    airframe: &Airframe,
    speed_mps: f64,
) -> Option<(Helicopter, ControlInputs)> {
    let t = trim(airframe, speed_mps)?;
    let x = Unknowns::from_column_slice(&[
        t.lat_cyclic_rad,
        t.lon_cyclic_rad,
        t.collective_deg.to_radians(),
        t.tail_pitch_cmd_rad,
        t.roll_deg.to_radians(),
        t.pitch_deg.to_radians(),
        t.flap_lon_deg.to_radians(),
        t.flap_lat_deg.to_radians(),
    ]);
    Some(condition(airframe, speed_mps, &x))
}

/// A second-order mode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Mode {
    /// Natural frequency (rad/s).
    pub natural_frequency_rps: f64,
    /// Damping ratio.
    pub damping: f64,
}

impl Mode {
    fn from_2x2(a: &Matrix2<f64>) -> Self {
        let det = a.determinant();
        let wn = det.max(0.0).sqrt();
        Self {
            natural_frequency_rps: wn,
            damping: if wn > 0.0 {
                -a.trace() / (2.0 * wn)
            } else {
                0.0
            },
        }
    }
}

/// The rotor–fuselage modes at hover.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HoverModes {
    /// Roll rate coupled with lateral flapping (p, b1).
    pub roll: Mode,
    /// Pitch rate coupled with longitudinal flapping (q, a1).
    pub pitch: Mode,
    /// Every eigenvalue of the full linearisation (16 error states), as [re, im].
    pub full_eigenvalues: Vec<[f64; 2]>,
}

/// Error-state layout of the linearisation: position 3, velocity 3, attitude 3 (small
/// rotation), rates 3, a1, b1, rotor speed, governor integrator.
const N_ERR: usize = 16;

fn perturbed(state: &State, k: usize, h: f64) -> State {
    let mut s = *state;
    match k {
        0..=2 => s.pos_ned_m[k] += h,
        3..=5 => s.vel_body_mps[k - 3] += h,
        6..=8 => {
            let mut axis = Vector3::zeros();
            axis[k - 6] = h;
            s.att *= UnitQuaternion::from_scaled_axis(axis);
        }
        9..=11 => s.rate_body_rps[k - 9] += h,
        12 => s.flap_lon_rad += h,
        13 => s.flap_lat_rad += h,
        14 => s.rotor_rps += h,
        _ => s.governor_integral_rad += h,
    }
    s
}

fn error_derivative(d: &[f64; N_STATE], state: &State) -> SVector<f64, N_ERR> {
    let mut e = SVector::<f64, N_ERR>::zeros();
    for i in 0..3 {
        e[i] = d[index::POS + i];
        e[3 + i] = d[index::VEL + i];
        // Small body-axis rotation: its rate is the body rate.
        e[6 + i] = state.rate_body_rps[i];
        e[9 + i] = d[index::RATE + i];
    }
    e[12] = d[index::A1];
    e[13] = d[index::B1];
    e[14] = d[index::ROTOR];
    e[15] = d[index::GOVERNOR];
    e
}

/// Linearises the model at hover trim and extracts the roll and pitch rotor–fuselage modes.
pub fn hover_modes(airframe: &Airframe) -> Option<HoverModes> {
    let (heli, u) = trimmed_helicopter(airframe, 0.0)?;
    let env = still_air();
    let base = heli.state;
    let f = |s: &State| error_derivative(&heli.derivative(s, &u, &env).0, s);
    let f0 = f(&base);
    let mut a = SMatrix::<f64, N_ERR, N_ERR>::zeros();
    for k in 0..N_ERR {
        let h = 1e-6;
        a.set_column(k, &((f(&perturbed(&base, k, h)) - f0) / h));
    }
    let roll = Matrix2::new(a[(9, 9)], a[(9, 13)], a[(13, 9)], a[(13, 13)]);
    let pitch = Matrix2::new(a[(10, 10)], a[(10, 12)], a[(12, 10)], a[(12, 12)]);
    let mut full_eigenvalues: Vec<[f64; 2]> = a
        .complex_eigenvalues()
        .iter()
        .map(|c| [c.re, c.im])
        .collect();
    full_eigenvalues.sort_by(|x, y| x[0].total_cmp(&y[0]).then(x[1].total_cmp(&y[1])));
    Some(HoverModes {
        roll: Mode::from_2x2(&roll),
        pitch: Mode::from_2x2(&pitch),
        full_eigenvalues,
    })
}

/// The rotor-speed response to a governor set-point step.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GovernorStep {
    /// Step size (rpm).
    pub step_rpm: f64,
    /// Overshoot, fraction of the step.
    pub overshoot: f64,
    /// Time of the first peak (s).
    pub peak_time_s: f64,
    /// Damping ratio of the closed rotor-speed loop's poles.
    pub damping: f64,
    /// Natural frequency of the closed rotor-speed loop's poles (rad/s).
    pub natural_frequency_rps: f64,
    /// Rotor speed every 0.1 s (rpm), for plotting.
    pub rpm: Vec<f64>,
}

/// Steps the governor set point by `step_rpm` at hover trim, with the airframe held (the
/// rigid-body states frozen, as on a test stand, so that only the rotor-speed loop moves).
///
/// The loop is second order (rotor speed and governor integrator), but the PI governor adds a
/// zero at −K_i/K_p, so overshoot and peak time overstate the speed of the poles; the damping
/// and natural frequency reported are those of the poles, from the loop linearised about the
/// trim (the characteristic polynomial of H15 eqs. 15.32–15.34), and the measured overshoot
/// and peak time are reported beside them.
pub fn governor_step(airframe: &Airframe, step_rpm: f64) -> Option<GovernorStep> {
    let (heli, mut u) = trimmed_helicopter(airframe, 0.0)?;
    let env = still_air();
    let start_rps = heli.state.rotor_rps;
    u.governor_setpoint_rps = start_rps + step_rpm * std::f64::consts::PI / 30.0;
    let dt = 0.002;
    let mut state = heli.state;
    let mut rpm = Vec::new();
    let mut peak = (0.0_f64, 0.0_f64);
    for k in 0..(20.0 / dt) as usize {
        let t = k as f64 * dt;
        if k % 50 == 0 {
            rpm.push(state.rotor_rps * 30.0 / std::f64::consts::PI);
        }
        let speed_change = (state.rotor_rps - start_rps) * 30.0 / std::f64::consts::PI;
        if speed_change > peak.1 {
            peak = (t, speed_change);
        }
        // RK4 on the rotor speed and governor integrator only.
        let deriv = |s: &State| {
            let d = heli.derivative(s, &u, &env).0;
            // The frozen fuselage has no yaw acceleration to share with the rotor.
            let rotor_dot = d[index::ROTOR] + d[index::RATE + 2];
            (rotor_dot, d[index::GOVERNOR])
        };
        let with = |dr: f64, dg: f64, h: f64| {
            let mut s = state;
            s.rotor_rps += h * dr;
            s.governor_integral_rad += h * dg;
            s
        };
        let k1 = deriv(&state);
        let k2 = deriv(&with(k1.0, k1.1, 0.5 * dt));
        let k3 = deriv(&with(k2.0, k2.1, 0.5 * dt));
        let k4 = deriv(&with(k3.0, k3.1, dt));
        state.rotor_rps += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        state.governor_integral_rad += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    let overshoot = (peak.1 - step_rpm) / step_rpm;
    // Linearise the two-state loop at the trim.
    let f = |s: &State| {
        let d = heli.derivative(s, &u, &env).0;
        nalgebra::Vector2::new(d[index::ROTOR] + d[index::RATE + 2], d[index::GOVERNOR])
    };
    let f0 = f(&heli.state);
    let h = 1e-6;
    let mut s_rotor = heli.state;
    s_rotor.rotor_rps += h;
    let mut s_gov = heli.state;
    s_gov.governor_integral_rad += h;
    let a = Matrix2::from_columns(&[(f(&s_rotor) - f0) / h, (f(&s_gov) - f0) / h]);
    let poles = Mode::from_2x2(&a);
    let (damping, natural_frequency_rps) = (poles.damping, poles.natural_frequency_rps);
    Some(GovernorStep {
        step_rpm,
        overshoot,
        peak_time_s: peak.0,
        damping,
        natural_frequency_rps,
        rpm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hover_trim_matches_the_reference_numbers() {
        let t = trim(&Airframe::default(), 0.0).unwrap_or_else(|| panic!("no hover trim"));
        assert!((t.collective_deg - 5.65).abs() <= 0.3, "{t:?}");
        assert!(t.mr_torque_nm >= 6.2 && t.mr_torque_nm <= 6.5, "{t:?}");
        assert!((t.tail_pitch_cmd_rad - 0.13).abs() <= 0.03, "{t:?}");
    }

    #[test]
    fn forward_flight_at_14_5_mps_trims_nose_down_about_ten_degrees() {
        let t = trim(&Airframe::default(), 14.5).unwrap_or_else(|| panic!("no trim"));
        assert!(t.pitch_deg <= -8.5 && t.pitch_deg >= -10.5, "{t:?}");
    }

    #[test]
    fn roll_and_pitch_modes_match_the_published_frequencies() {
        let m = hover_modes(&Airframe::default()).unwrap_or_else(|| panic!("no modes"));
        assert!(
            (m.roll.natural_frequency_rps / 20.1 - 1.0).abs() <= 0.1,
            "{m:?}"
        );
        assert!(
            (m.pitch.natural_frequency_rps / 14.6 - 1.0).abs() <= 0.1,
            "{m:?}"
        );
    }

    #[test]
    fn governor_step_has_the_identified_damping_and_frequency() {
        let g =
            governor_step(&Airframe::default(), 100.0).unwrap_or_else(|| panic!("no overshoot"));
        assert!(
            g.damping >= 0.6 && g.damping <= 0.8,
            "{:?}",
            (g.damping, g.natural_frequency_rps)
        );
        assert!(
            g.natural_frequency_rps >= 1.3 && g.natural_frequency_rps <= 1.6,
            "{:?}",
            (g.damping, g.natural_frequency_rps)
        );
    }
}
