//! Atmospheric turbulence: the Dryden model's low-altitude form (MIL-F-8785C), seeded, as
//! first-order shaping filters on white noise — the gust velocity added to the steady wind.
//!
//! The Dryden spectra are spatial; a hovering helicopter does not fly through the gust field,
//! the wind carries it past, so the speed that turns length scales into time constants is the
//! larger of airspeed and wind speed (at least 1 m/s). Vertical gusts are given by their
//! intensity σ_w; the horizontal ones and the length scales follow the low-altitude rules.

use nalgebra::Vector3;

use crate::noise::Noise;

/// Metres per foot.
const FT: f64 = 0.3048;

/// The gust field's state.
#[derive(Clone, Debug)]
pub struct Turbulence {
    sigma_w_mps: f64,
    gust_ned_mps: Vector3<f64>,
    noise: Noise,
}

impl Turbulence {
    /// Turbulence with vertical intensity `sigma_w_mps` (0 for none).
    pub fn new(sigma_w_mps: f64, noise: Noise) -> Self {
        Self {
            sigma_w_mps: sigma_w_mps.max(0.0),
            gust_ned_mps: Vector3::zeros(),
            noise,
        }
    }

    /// Intensities (σ_u, σ_v, σ_w, m/s) and length scales (L_u, L_v, L_w, m) at `height_m`.
    pub fn scales(&self, height_m: f64) -> ([f64; 3], [f64; 3]) {
        let h_ft = (height_m / FT).clamp(10.0, 1000.0);
        let ratio = 1.0 / (0.177 + 0.000823 * h_ft).powf(0.4);
        let sigma = [
            self.sigma_w_mps * ratio,
            self.sigma_w_mps * ratio,
            self.sigma_w_mps,
        ];
        let l_uv = h_ft / (0.177 + 0.000823 * h_ft).powf(1.2) * FT;
        (sigma, [l_uv, l_uv, h_ft * FT])
    }

    /// Advances the gusts by `dt_s` at `height_m` above ground and `speed_mps` of air past the
    /// helicopter; returns the gust velocity (NED, m/s).
    pub fn step(&mut self, dt_s: f64, height_m: f64, speed_mps: f64) -> Vector3<f64> {
        if self.sigma_w_mps == 0.0 {
            return Vector3::zeros();
        }
        let (sigma, length) = self.scales(height_m);
        let v = speed_mps.max(1.0);
        for i in 0..3 {
            let a = (-dt_s * v / length[i]).exp();
            let k = sigma[i] * (1.0 - a * a).sqrt();
            self.gust_ned_mps[i] = a * self.gust_ned_mps[i] + k * self.noise.gaussian(1.0);
        }
        self.gust_ned_mps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gusts_have_the_dryden_intensities() {
        let mut t = Turbulence::new(1.0, Noise::new(3, 9));
        let (sigma, length) = t.scales(10.0);
        assert!(sigma[0] > 1.5 && sigma[0] < 2.5, "{sigma:?}");
        assert!((length[2] - 10.0).abs() < 1e-9);
        let n = 400_000;
        let mut sum_sq = Vector3::zeros();
        for _ in 0..n {
            let g = t.step(0.01, 10.0, 5.0);
            sum_sq += g.component_mul(&g);
        }
        let rms = (sum_sq / n as f64).map(f64::sqrt);
        for i in 0..3 {
            assert!(
                (rms[i] / sigma[i] - 1.0).abs() < 0.1,
                "axis {i}: {} vs {}",
                rms[i],
                sigma[i]
            );
        }
    }

    #[test]
    fn no_intensity_no_gusts() {
        let mut t = Turbulence::new(0.0, Noise::new(1, 1));
        assert_eq!(t.step(0.01, 10.0, 5.0), Vector3::zeros());
    }
}
