//! Airframe parameters of the X-Cell 60 model.
//!
//! Values are Table 15.1 of Gavrilets, "Dynamic Model for a Miniature Aerobatic Helicopter"
//! (Handbook of UAVs, 2015), the MIT instrumented X-Cell 60 SE, plus the constants that
//! the chapter states in its text (H15 §4). One typed struct,
//! loadable from TOML, so another airframe can be described without touching the code.

use serde::{Deserialize, Serialize};

use crate::rotor::Disk;

/// Every physical parameter of the helicopter model, SI units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Airframe {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Roll moment of inertia (kg m²).
    pub ixx_kgm2: f64,
    /// Pitch moment of inertia (kg m²).
    pub iyy_kgm2: f64,
    /// Yaw moment of inertia (kg m²).
    pub izz_kgm2: f64,
    /// Hub torsional stiffness K_β (N m / rad).
    pub hub_stiffness_nm_per_rad: f64,
    /// Stabilizer-bar Lock number γ_fb.
    pub flybar_lock_number: f64,
    /// Lateral cyclic to flapping gain at nominal rotor speed, B_δlat (rad/rad).
    pub b_dlat: f64,
    /// Longitudinal cyclic to flapping gain at nominal rotor speed, A_δlon (rad/rad).
    pub a_dlon: f64,
    /// Scaling of the flapping response to speed, K_μ.
    pub k_mu: f64,
    /// Nominal main-rotor speed (rad/s).
    pub omega_nom_rps: f64,
    /// Main-rotor radius (m).
    pub mr_radius_m: f64,
    /// Main-rotor chord (m).
    pub mr_chord_m: f64,
    /// Main-rotor blade lift-curve slope (1/rad).
    pub mr_lift_slope: f64,
    /// Main-rotor blade profile drag coefficient.
    pub mr_cd0: f64,
    /// Main-rotor maximum thrust coefficient.
    pub mr_ct_max: f64,
    /// Main-rotor blade flapping inertia (kg m²).
    pub mr_blade_inertia_kgm2: f64,
    /// Number of main-rotor blades.
    pub mr_blades: f64,
    /// Tail-rotor radius (m).
    pub tr_radius_m: f64,
    /// Tail-rotor chord (m).
    pub tr_chord_m: f64,
    /// Tail-rotor lift-curve slope (1/rad).
    pub tr_lift_slope: f64,
    /// Tail-rotor profile drag coefficient.
    pub tr_cd0: f64,
    /// Tail-rotor maximum thrust coefficient.
    pub tr_ct_max: f64,
    /// Tail-rotor to main-rotor gear ratio.
    pub tr_gear_ratio: f64,
    /// Engine to main-rotor gear ratio.
    pub engine_gear_ratio: f64,
    /// Tail-rotor pitch trim offset δ_r^trim (rad).
    pub tr_pitch_trim_rad: f64,
    /// Effective vertical-fin area (m²).
    pub vf_area_m2: f64,
    /// Vertical-fin lift-curve slope (1/rad).
    pub vf_lift_slope: f64,
    /// Fraction of the vertical fin in the tail-rotor induced flow.
    pub vf_tr_wash_fraction: f64,
    /// Horizontal-stabilizer area (m²).
    pub ht_area_m2: f64,
    /// Horizontal-stabilizer lift-curve slope (1/rad).
    pub ht_lift_slope: f64,
    /// Engine idle power (W).
    pub engine_idle_power_w: f64,
    /// Engine maximum power (W).
    pub engine_max_power_w: f64,
    /// Governor proportional gain (s/rad).
    pub governor_kp: f64,
    /// Governor integral gain (1/rad).
    pub governor_ki: f64,
    /// Fuselage frontal drag area (m²).
    pub fus_area_x_m2: f64,
    /// Fuselage side drag area (m²).
    pub fus_area_y_m2: f64,
    /// Fuselage vertical drag area (m²).
    pub fus_area_z_m2: f64,
    /// Main-rotor hub height above the centre of gravity (m).
    pub mr_hub_height_m: f64,
    /// Tail-rotor hub distance behind the centre of gravity (m).
    pub tr_arm_m: f64,
    /// Tail-rotor hub height above the centre of gravity (m).
    pub tr_height_m: f64,
    /// Horizontal-stabilizer distance behind the centre of gravity (m).
    pub ht_arm_m: f64,
    /// Non-ideal wake contraction coefficient η_w (text of H15).
    pub wake_contraction: f64,
    /// Padfield's convergence-rate factor of the inflow Newton iteration.
    pub inflow_relaxation: f64,
    /// Rotational inertia of rotor, engine and tail rotor reflected to the main shaft (kg m²):
    /// H15 estimates 2.5 times the main-rotor blade flapping inertia.
    pub rotor_system_inertia_kgm2: f64,
    /// Largest lateral and longitudinal cyclic blade pitch (rad), symmetric about centre.
    pub cyclic_max_rad: f64,
    /// Largest collective blade pitch (rad), symmetric about centre.
    pub collective_max_rad: f64,
    /// Largest tail-rotor pitch command (rad), symmetric about centre.
    pub tail_max_rad: f64,
    /// Governor set point at full throttle channel (rpm); the throttle channel scales it.
    pub governor_full_scale_rpm: f64,
    /// Skid contact points, body FRD coordinates (m) of the four skid ends.
    pub skid_points_m: [[f64; 3]; 4],
    /// Ground stiffness per skid point (N/m).
    pub ground_stiffness_n_per_m: f64,
    /// Ground damping per skid point (N s/m).
    pub ground_damping_ns_per_m: f64,
    /// Skid-to-ground friction coefficient.
    pub ground_friction: f64,
}

impl Default for Airframe {
    fn default() -> Self {
        let mr_blade_inertia_kgm2 = 0.038;
        Self {
            mass_kg: 8.2,
            ixx_kgm2: 0.18,
            iyy_kgm2: 0.34,
            izz_kgm2: 0.28,
            hub_stiffness_nm_per_rad: 54.0,
            flybar_lock_number: 0.8,
            b_dlat: 4.2,
            a_dlon: 4.2,
            k_mu: 0.2,
            omega_nom_rps: 167.0,
            mr_radius_m: 0.775,
            mr_chord_m: 0.058,
            mr_lift_slope: 5.5,
            mr_cd0: 0.024,
            mr_ct_max: 0.0055,
            mr_blade_inertia_kgm2,
            mr_blades: 2.0,
            tr_radius_m: 0.13,
            tr_chord_m: 0.029,
            tr_lift_slope: 5.0,
            tr_cd0: 0.024,
            tr_ct_max: 0.05,
            tr_gear_ratio: 4.66,
            engine_gear_ratio: 9.0,
            tr_pitch_trim_rad: 0.1,
            vf_area_m2: 0.012,
            vf_lift_slope: 2.0,
            vf_tr_wash_fraction: 0.2,
            ht_area_m2: 0.01,
            ht_lift_slope: 3.0,
            engine_idle_power_w: 0.0,
            engine_max_power_w: 2000.0,
            // Departure from Table 15.1 (K_p = 0.01, K_i = 0.02), see docs/model.md: these
            // reproduce H15's identified rotor-speed response (ζ = 0.63, ω_n = 1.3 rad/s) with
            // this model's full shaft torque, tail rotor included.
            governor_kp: 0.0022,
            governor_ki: 0.0136,
            fus_area_x_m2: 0.1,
            fus_area_y_m2: 0.22,
            fus_area_z_m2: 0.15,
            mr_hub_height_m: 0.235,
            tr_arm_m: 0.91,
            tr_height_m: 0.08,
            ht_arm_m: 0.71,
            wake_contraction: 0.9,
            inflow_relaxation: 0.6,
            rotor_system_inertia_kgm2: 2.5 * mr_blade_inertia_kgm2,
            cyclic_max_rad: 0.096,
            collective_max_rad: 0.183,
            tail_max_rad: 0.38,
            governor_full_scale_rpm: 2000.0,
            skid_points_m: [
                [0.25, -0.22, 0.35],
                [0.25, 0.22, 0.35],
                [-0.20, -0.22, 0.35],
                [-0.20, 0.22, 0.35],
            ],
            ground_stiffness_n_per_m: 4000.0,
            ground_damping_ns_per_m: 150.0,
            ground_friction: 0.6,
        }
    }
}

impl Airframe {
    /// Main-rotor solidity σ = N c / (π R).
    pub fn mr_solidity(&self) -> f64 {
        self.mr_blades * self.mr_chord_m / (std::f64::consts::PI * self.mr_radius_m)
    }

    /// Tail-rotor solidity (two blades).
    pub fn tr_solidity(&self) -> f64 {
        2.0 * self.tr_chord_m / (std::f64::consts::PI * self.tr_radius_m)
    }

    /// Effective flapping time constant τ_e = 16 / (γ_fb Ω) (s).
    pub fn flap_time_constant_s(&self, omega_rps: f64) -> f64 {
        16.0 / (self.flybar_lock_number * omega_rps.max(1.0))
    }

    /// The main rotor as a momentum-theory disk.
    pub fn main_disk(&self) -> Disk {
        Disk {
            radius_m: self.mr_radius_m,
            solidity: self.mr_solidity(),
            lift_slope: self.mr_lift_slope,
            cd0: self.mr_cd0,
            ct_max: self.mr_ct_max,
            wake_contraction: self.wake_contraction,
            relaxation: self.inflow_relaxation,
        }
    }

    /// The tail rotor as a momentum-theory disk.
    pub fn tail_disk(&self) -> Disk {
        Disk {
            radius_m: self.tr_radius_m,
            solidity: self.tr_solidity(),
            lift_slope: self.tr_lift_slope,
            cd0: self.tr_cd0,
            ct_max: self.tr_ct_max,
            wake_contraction: self.wake_contraction,
            relaxation: self.inflow_relaxation,
        }
    }

    /// Fin blockage factor of the tail rotor, f_t = 1 − ¾ S_vf / (π R_tr²).
    pub fn tr_fin_blockage(&self) -> f64 {
        1.0 - 0.75 * self.vf_area_m2 / (std::f64::consts::PI * self.tr_radius_m.powi(2))
    }
}

/// The atmosphere the helicopter flies in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Atmosphere {
    /// Air density (kg/m³).
    pub density_kgpm3: f64,
    /// Gravity (m/s²).
    pub gravity_mps2: f64,
    /// Static pressure at the take-off point (mbar).
    pub ground_pressure_mbar: f64,
    /// Air temperature (°C).
    pub temperature_c: f64,
    /// The density falls with height above the take-off point as in the standard
    /// atmosphere (`density_kgpm3` is the density at the take-off point).
    pub density_falls_with_height: bool,
}

impl Atmosphere {
    /// Air density (kg/m³) `height_m` above the take-off point: the standard atmosphere's
    /// troposphere, 6.5 K/km lapse, from the take-off point's temperature.
    pub fn density_at(&self, height_m: f64) -> f64 {
        if !self.density_falls_with_height {
            return self.density_kgpm3;
        }
        const LAPSE_K_PER_M: f64 = 0.0065;
        // g / (R L) - 1, with R = 287.05 J/(kg K).
        const EXPONENT: f64 = 9.80665 / (287.05 * LAPSE_K_PER_M) - 1.0;
        let t0_k = self.temperature_c + 273.15;
        let ratio = (1.0 - LAPSE_K_PER_M * height_m / t0_k).max(0.1);
        self.density_kgpm3 * ratio.powf(EXPONENT)
    }
}

impl Default for Atmosphere {
    fn default() -> Self {
        Self {
            density_kgpm3: 1.225,
            gravity_mps2: 9.81,
            ground_pressure_mbar: 1013.25,
            temperature_c: 15.0,
            density_falls_with_height: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_falls_with_height_as_in_the_standard_atmosphere() {
        let isa = Atmosphere::default();
        // The standard atmosphere: 1.1117 kg/m³ at 1000 m.
        assert!((isa.density_at(1000.0) - 1.1117).abs() < 0.001);
        assert!((isa.density_at(30.0) / isa.density_kgpm3 - 0.99717).abs() < 1e-4);
        let constant = Atmosphere {
            density_falls_with_height: false,
            ..isa
        };
        assert_eq!(constant.density_at(1000.0), 1.225);
    }

    #[test]
    fn the_drawn_x_cell_has_the_model_s_dimensions() {
        use heli_types::shape;
        let a = Airframe::default();
        assert_eq!(shape::MAIN_ROTOR_RADIUS_M, a.mr_radius_m);
        assert_eq!(shape::MAIN_ROTOR_HUB_HEIGHT_M, a.mr_hub_height_m);
        assert_eq!(shape::TAIL_ROTOR_RADIUS_M, a.tr_radius_m);
        assert_eq!(shape::TAIL_ROTOR_ARM_M, a.tr_arm_m);
        assert_eq!(shape::TAIL_ROTOR_HEIGHT_M, a.tr_height_m);
        for [x, y, z] in a.skid_points_m {
            assert_eq!(z, shape::SKID_DEPTH_M);
            assert_eq!(y.abs(), shape::SKID_HALF_TRACK_M);
            assert!(x.abs() < 0.5 * shape::SKID_LENGTH_M);
        }
    }
}
