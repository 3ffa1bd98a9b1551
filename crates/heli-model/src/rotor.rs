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

/// The smallest ground-effect factor: Cheeseman and Bennett's at a hub height of half a
/// radius, below which their image-source formula is not meant to be used.
pub const GROUND_FACTOR_MIN: f64 = 0.75;

/// Ground effect on the induced velocity at a hub height of `height_m` above flat ground
/// (Cheeseman and Bennett 1955, the form Leishman and Padfield give): `1 − (R / 4z)²`, the
/// ratio of the induced velocity in ground effect to that out of it at the same thrust (at
/// constant power, thrust grows by its inverse). 1 far from the ground; 0.94 at one radius;
/// [`GROUND_FACTOR_MIN`] from half a radius down.
pub fn ground_effect_factor(radius_m: f64, height_m: f64) -> f64 {
    if !(height_m.is_finite() && radius_m > 0.0) {
        return 1.0;
    }
    let z = height_m.max(0.5 * radius_m);
    let ratio = radius_m / (4.0 * z);
    (1.0 - ratio * ratio).clamp(GROUND_FACTOR_MIN, 1.0)
}

const MAX_ITERATIONS: u32 = 60;
const TOLERANCE: f64 = 1e-10;
/// Closer than this (a Newton step smaller than it), the iteration takes full Newton steps:
/// the relaxation guards the first steps from a far guess (Padfield), but near the root it
/// only slows the quadratic convergence to a linear one (each step keeps 40 % of the error
/// at 0.6), which cost most of the simulator's time. The root is the same.
const FULL_STEPS_BELOW: f64 = 1e-4;

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
        self.solve_in_ground_effect(
            density_kgpm3,
            omega_rps,
            mu,
            mu_z,
            pitch_rad,
            lambda_guess,
            1.0,
        )
    }

    /// [`Disk::solve`] with the induced inflow scaled by `ground_factor` (1 out of ground
    /// effect; [`ground_effect_factor`] near the ground): the ground blocks the wake, so the
    /// same thrust needs less induced velocity, and the same collective gives more thrust.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_in_ground_effect(
        &self,
        density_kgpm3: f64,
        omega_rps: f64,
        mu: f64,
        mu_z: f64,
        pitch_rad: f64,
        lambda_guess: f64,
        ground_factor: f64,
    ) -> DiskLoad {
        // Eq. 15.4 with the induced velocity scaled: λ0 = k C_T / (2 η √Λ), i.e. a wake
        // contraction η / k.
        let eta = self.wake_contraction / ground_factor.clamp(GROUND_FACTOR_MIN, 1.0);
        let a_sigma = self.lift_slope * self.solidity;
        let mut lambda0 = if lambda_guess.is_finite() {
            lambda_guess
        } else {
            0.05
        };
        let mut iterations = 0;
        // Newton on g(λ0) = 2 η λ0 √Λ − C_T(λ0), Λ = μ² + (λ0 − μ_z)² (eq. 15.4), with its
        // exact derivative. Padfield's form replaces the derivative's λ0-term by its value
        // at the root, which is right near the root but cycles between ±λ0 far from it (at
        // zero collective it settled on a false λ0 = 0.0156 with 40 N of downward thrust).
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            let ct = self.ct_ideal(pitch_rad, mu, mu_z, lambda0);
            let offset = lambda0 - mu_z;
            let raw = mu * mu + offset * offset;
            let floored = raw < LAMBDA_FLOOR;
            let root = raw.max(LAMBDA_FLOOR).sqrt();
            let g = 2.0 * eta * lambda0 * root - ct;
            let dg_root = if floored {
                0.0
            } else {
                2.0 * eta * lambda0 * offset / root
            };
            let dg = 2.0 * eta * root + dg_root + 0.25 * a_sigma;
            if dg.abs() < 1e-12 {
                break;
            }
            let step = -g / dg;
            let relaxation = if step.abs() < FULL_STEPS_BELOW {
                1.0
            } else {
                self.relaxation
            };
            lambda0 += relaxation * step;
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
    fn zero_collective_gives_no_thrust_from_any_guess() {
        // Padfield's near-root form of the Newton step cycled here between ±0.0156 and left
        // 40 N of downward thrust after 60 iterations.
        for guess in [0.03, 0.0156, -0.0156, -0.05, 0.0] {
            let load = main_rotor().solve(1.225, 167.0, 0.0, 0.0, 0.0, guess);
            assert!(load.inflow_ratio.abs() < 1e-8, "{guess}: {load:?}");
            assert!(load.thrust_n.abs() < 1e-3, "{guess}: {load:?}");
            assert!(load.iterations < 20, "{guess}: {load:?}");
        }
    }

    #[test]
    fn a_warm_start_converges_in_a_few_full_newton_steps() {
        let disk = main_rotor();
        let hover = disk.solve(1.225, 167.0, 0.0, 0.0, 0.0985, 0.05);
        // The next derivative evaluation: a slightly different collective, started from the
        // last solution.
        let next = disk.solve(1.225, 167.0, 0.0, 0.0, 0.0986, hover.inflow_ratio);
        assert!(next.iterations <= 4, "{next:?}");
        let cold = disk.solve(1.225, 167.0, 0.0, 0.0, 0.0986, 0.05);
        assert!((next.inflow_ratio - cold.inflow_ratio).abs() < 1e-9);
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
    fn near_the_ground_the_same_collective_gives_more_thrust_for_less_torque() {
        // Cheeseman and Bennett at one radius: T_IGE / T_OGE = 1 / (1 − 1/16) ≈ 1.067 at
        // constant power. At the hover collective the thrust grows and the induced inflow
        // falls.
        let disk = main_rotor();
        let k = ground_effect_factor(0.775, 0.775);
        assert!((k - (1.0 - 1.0 / 16.0)).abs() < 1e-12);
        let free = disk.solve(1.225, 167.0, 0.0, 0.0, 0.0985, 0.05);
        let near = disk.solve_in_ground_effect(1.225, 167.0, 0.0, 0.0, 0.0985, 0.05, k);
        assert!(near.thrust_n > free.thrust_n * 1.02, "{near:?} vs {free:?}");
        assert!(near.inflow_ratio < free.inflow_ratio);
        let power_ratio = near.torque_nm / near.thrust_n / (free.torque_nm / free.thrust_n);
        assert!(power_ratio < 1.0, "{power_ratio}");
        // Far away, none; at the skids, the floor.
        assert!((ground_effect_factor(0.775, 100.0) - 1.0).abs() < 1e-5);
        assert_eq!(ground_effect_factor(0.775, 0.1), GROUND_FACTOR_MIN);
        assert_eq!(ground_effect_factor(0.775, f64::NAN), 1.0);
    }

    #[test]
    fn a_descending_rotor_with_low_collective_is_driven_by_the_air() {
        // The windmill-brake state: in a steady 11 m/s descent at 3 m/s forward, a collective
        // of −0.056 rad holds the weight with the shaft torque reversed (the air turns the
        // rotor), the autorotation the engine-failure response flies.
        let disk = main_rotor();
        let tip = 167.0 * 0.775;
        let load = disk.solve(1.225, 167.0, 3.0 / tip, 11.0 / tip, -0.056, 0.0);
        assert!((load.thrust_n - 8.2 * 9.81).abs() < 4.0, "{load:?}");
        assert!(load.torque_nm < 0.0, "{load:?}");
        // Slower, the same collective brakes the rotor.
        let slow = disk.solve(1.225, 167.0, 3.0 / tip, 6.0 / tip, -0.056, 0.0);
        assert!(slow.torque_nm > 0.0, "{slow:?}");
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
