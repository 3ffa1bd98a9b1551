//! Rotor thrust and torque from momentum theory with the inflow Newton iteration
//! (Gavrilets ch. 15, eqs. 15.3–15.7 and 15.11–15.12, after Padfield 1996).
//!
//! The same disk model serves the main rotor and, turned on its side, the tail rotor.

use std::f64::consts::PI;

/// What the thrust model needs to know about one rotor disk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    /// Radius (m).
    pub radius_m: f64,
    /// Solidity σ.
    pub solidity: f64,
    /// Blade lift-curve slope (1/rad).
    pub lift_slope: f64,
    /// Blade profile drag coefficient.
    pub cd0: f64,
    /// Largest thrust coefficient magnitude.
    pub ct_max: f64,
    /// Wake contraction coefficient η_w.
    pub wake_contraction: f64,
    /// Relaxation factor of the Newton iteration (Padfield's f_j).
    pub relaxation: f64,
}

/// Result of one thrust solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskLoad {
    /// Thrust along the shaft, positive in the thrust direction (N).
    pub thrust_n: f64,
    /// Thrust coefficient (after the C_T,max limit).
    pub ct: f64,
    /// Induced inflow ratio λ0.
    pub inflow_ratio: f64,
    /// Shaft torque absorbed by the rotor (N m).
    pub torque_nm: f64,
    /// Newton iterations used.
    pub iterations: u32,
}

/// Floor on Λ = μ² + (λ0 − μ_z)²: keeps the denominator of eq. 15.4 away from zero in the
/// vortex-ring state, where momentum theory is not valid anyway (H15 "numerically separates
/// the denominator from zero"; the value is ours: √Λ ≥ 0.005, about a seventh of hover inflow).
pub const LAMBDA_FLOOR: f64 = 2.5e-5;

const MAX_ITERATIONS: u32 = 60;
const TOLERANCE: f64 = 1e-10;

impl Disk {
    /// Ideal thrust coefficient of eq. 15.5 for a given inflow.
    fn ct_ideal(&self, pitch_rad: f64, mu: f64, mu_z: f64, lambda0: f64) -> f64 {
        0.5 * self.lift_slope
            * self.solidity
            * (pitch_rad * (1.0 / 3.0 + 0.5 * mu * mu) + 0.5 * (mu_z - lambda0))
    }

    /// Solves thrust and inflow at advance ratio `mu`, axial ratio `mu_z` (positive when the
    /// air comes against the thrust direction, i.e. descending for the main rotor) and
    /// collective blade pitch `pitch_rad`, starting the iteration from `lambda_guess`.
    pub fn solve(
        &self,
        density_kgpm3: f64,
        omega_rps: f64,
        mu: f64,
        mu_z: f64,
        pitch_rad: f64,
        lambda_guess: f64,
    ) -> DiskLoad {
        let eta = self.wake_contraction;
        let a_sigma = self.lift_slope * self.solidity;
        let mut lambda0 = if lambda_guess.is_finite() {
            lambda_guess
        } else {
            0.05
        };
        let mut iterations = 0;
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            let ct = self.ct_ideal(pitch_rad, mu, mu_z, lambda0);
            let big_lambda = (mu * mu + (lambda0 - mu_z).powi(2)).max(LAMBDA_FLOOR);
            let root = big_lambda.sqrt();
            let numerator = (2.0 * eta * lambda0 * root - ct) * big_lambda;
            let denominator =
                2.0 * eta * big_lambda * root + 0.25 * a_sigma * big_lambda - ct * (mu_z - lambda0);
            if denominator.abs() < 1e-12 {
                break;
            }
            let step = -numerator / denominator;
            lambda0 += self.relaxation * step;
            if step.abs() < TOLERANCE {
                break;
            }
        }
        let ct = self
            .ct_ideal(pitch_rad, mu, mu_z, lambda0)
            .clamp(-self.ct_max, self.ct_max);
        let area = PI * self.radius_m * self.radius_m;
        let tip_speed = omega_rps * self.radius_m;
        let dynamic = density_kgpm3 * tip_speed * tip_speed * area;
        let cq =
            ct * (lambda0 - mu_z) + self.cd0 * self.solidity / 8.0 * (1.0 + 7.0 / 3.0 * mu * mu);
        DiskLoad {
            thrust_n: ct * dynamic,
            ct,
            inflow_ratio: lambda0,
            torque_nm: cq * dynamic * self.radius_m,
            iterations,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Airframe;

    fn main_rotor() -> Disk {
        Airframe::default().main_disk()
    }

    #[test]
    fn hover_collective_reproduces_reference_inflow_and_torque() {
        // heli-model.md §7: hover C_T = 0.002078, λ0 = 0.03397, θ0 = 0.0985 rad, Q = 6.41 N m.
        let load = main_rotor().solve(1.225, 167.0, 0.0, 0.0, 0.0985, 0.05);
        assert!((load.inflow_ratio - 0.03397).abs() < 2e-4, "{load:?}");
        assert!((load.ct - 0.002078).abs() < 3e-5, "{load:?}");
        assert!((load.thrust_n - 8.2 * 9.81).abs() < 1.5, "{load:?}");
        assert!((load.torque_nm - 6.41).abs() < 0.1, "{load:?}");
    }

    #[test]
    fn climbing_reduces_thrust_and_descending_raises_it() {
        let disk = main_rotor();
        let hover = disk.solve(1.225, 167.0, 0.0, 0.0, 0.0985, 0.05);
        let climb = disk.solve(1.225, 167.0, 0.0, -1.0 / 129.4, 0.0985, 0.05);
        let descend = disk.solve(1.225, 167.0, 0.0, 1.0 / 129.4, 0.0985, 0.05);
        assert!(climb.thrust_n < hover.thrust_n);
        assert!(descend.thrust_n > hover.thrust_n);
    }

    #[test]
    fn thrust_is_limited_by_ct_max() {
        let load = main_rotor().solve(1.225, 167.0, 0.0, 0.0, 0.5, 0.05);
        assert!((load.ct - 0.0055).abs() < 1e-12);
    }

    #[test]
    fn negative_pitch_gives_negative_thrust() {
        let load = main_rotor().solve(1.225, 167.0, 0.0, 0.0, -0.1, 0.05);
        assert!(load.thrust_n < 0.0, "{load:?}");
        assert!(load.inflow_ratio < 0.0);
    }
}
