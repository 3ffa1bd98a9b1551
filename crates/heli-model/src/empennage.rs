//! Tail surfaces: vertical fin and horizontal stabilizer (H15 eqs. 15.35–15.42), and the
//! main-rotor wake factor K_λ that says how much of the rotor's downwash reaches the tail
//! (eqs. 15.48–15.49).

use crate::params::Airframe;

/// Largest wake factor (the fully developed, contracted wake).
pub const WAKE_FACTOR_MAX: f64 = 1.5;

/// K_λ: 0 while the wake passes ahead of the tail (hover, slow flight, climb faster than the
/// induced velocity), 1.5 once the wake is swept fully onto it, linear in between with the
/// wake skew u_a / (V_i − w_a) between the geometric limits g_i and g_f.
pub fn wake_factor(a: &Airframe, ua_mps: f64, wa_mps: f64, induced_mps: f64) -> f64 {
    let g_i = (a.tr_arm_m - a.mr_radius_m - a.tr_radius_m) / a.tr_height_m;
    let g_f = (a.tr_arm_m - a.mr_radius_m + a.tr_radius_m) / a.tr_height_m;
    let sink = induced_mps - wa_mps;
    if sink <= 0.0 {
        return 0.0;
    }
    let skew = ua_mps / sink;
    if skew <= g_i {
        0.0
    } else if skew >= g_f {
        WAKE_FACTOR_MAX
    } else {
        WAKE_FACTOR_MAX * (skew - g_i) / (g_f - g_i)
    }
}

/// Side force of the vertical fin Y_vf (N) from the air-relative side velocity at the fin
/// `v_vf_mps` (already corrected for yaw rate and the tail rotor's induced flow) and the
/// speed in the fin's plane `v_plane_mps`; limited by stall (McConley 1998).
pub fn vertical_fin_force(a: &Airframe, density: f64, v_plane_mps: f64, v_vf_mps: f64) -> f64 {
    let q = 0.5 * density * a.vf_area_m2;
    let force = -q * (a.vf_lift_slope * v_plane_mps + v_vf_mps.abs()) * v_vf_mps;
    let stall = q * (v_plane_mps * v_plane_mps + v_vf_mps * v_vf_mps);
    limit(force, stall)
}

/// Vertical force of the horizontal stabilizer Z_ht (N, body z) from forward airspeed and
/// the vertical air-relative velocity at the stabilizer `w_ht_mps`.
///
/// Typo in H15 eq. 15.40: printed with a positive sign, a nose-up pitch rate (tail moving
/// down, w_ht > 0) would push the tail further down — a destabilising moment, contrary to the
/// text. The stabilizer's lift opposes the flow it meets: Z_ht has the sign of −w_ht.
pub fn stabilizer_force(a: &Airframe, density: f64, ua_mps: f64, w_ht_mps: f64) -> f64 {
    let q = 0.5 * density * a.ht_area_m2;
    let force = -q * (a.ht_lift_slope * ua_mps.abs() * w_ht_mps + w_ht_mps.abs() * w_ht_mps);
    let stall = q * (ua_mps * ua_mps + w_ht_mps * w_ht_mps);
    limit(force, stall)
}

/// `force` limited to ±`stall`, for any values: `f64::clamp` panics on a bound that is NaN,
/// and a state the model was driven out of its range with must not take the simulator
/// down (the lockstep reports the non-finite state instead).
fn limit(force: f64, stall: f64) -> f64 {
    force.max(-stall).min(stall)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wake_misses_the_tail_in_hover_and_covers_it_in_fast_flight() {
        let a = Airframe::default();
        assert_eq!(wake_factor(&a, 0.0, 0.0, 4.4), 0.0);
        assert_eq!(wake_factor(&a, 20.0, 0.0, 4.4), WAKE_FACTOR_MAX);
        let mid = wake_factor(&a, 5.0, 0.0, 4.4);
        assert!(mid > 0.0 && mid < WAKE_FACTOR_MAX, "{mid}");
        assert_eq!(
            wake_factor(&a, 5.0, 6.0, 4.4),
            0.0,
            "climbing out of the wake"
        );
    }

    #[test]
    fn stabilizer_damps_pitch_in_forward_flight() {
        // q > 0 at 10 m/s: the stabilizer 0.71 m behind the c.g. moves down (w_ht > 0);
        // the force must push it up (Z < 0) and the moment Z · l_ht pitch the nose down.
        let a = Airframe::default();
        let q = 1.0;
        let z = stabilizer_force(&a, 1.225, 10.0, a.ht_arm_m * q);
        assert!(z < 0.0);
        assert!(z * a.ht_arm_m < 0.0);
    }

    #[test]
    fn fin_opposes_sideslip_and_stalls() {
        let a = Airframe::default();
        assert!(vertical_fin_force(&a, 1.225, 10.0, 2.0) < 0.0);
        assert!(vertical_fin_force(&a, 1.225, 10.0, -2.0) > 0.0);
        let stalled = vertical_fin_force(&a, 1.225, 10.0, 30.0).abs();
        let limit = 0.5 * 1.225 * a.vf_area_m2 * (100.0 + 900.0);
        assert!((stalled - limit).abs() < 1e-9);
    }
}
