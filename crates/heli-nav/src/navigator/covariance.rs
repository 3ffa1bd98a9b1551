//! The covariance arithmetic of the filter, written for the structure of its matrices.
//!
//! The error-state transition is the identity plus four 3×3 blocks, and a measurement row
//! touches a few states; the dense products `Φ P Φᵀ` and the Joseph form
//! `(I − K H) P (I − K H)ᵀ + K R Kᵀ` spent most of the filter's time multiplying zeros
//! (about 7 000 multiply-adds per 15×15 product). These functions compute the same
//! quantities from the blocks that are not zero; the tests hold them to the dense
//! formulas.

use nalgebra::{Matrix3, SMatrix, SVector};

use super::{Covariance, N_ERR, ix};

/// The non-identity blocks of the error-state transition `Φ` over one propagation of
/// `dt_s`: attitude from gyro bias, velocity from attitude and from accelerometer bias,
/// position from velocity.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Transition {
    /// ∂δθ/∂δb_g: `−R dt`.
    pub att_from_gyro_bias: Matrix3<f64>,
    /// ∂δv/∂δθ: `−[f]ₓ dt`.
    pub vel_from_att: Matrix3<f64>,
    /// ∂δv/∂δb_a: `−R dt`.
    pub vel_from_accel_bias: Matrix3<f64>,
    /// ∂δp/∂δv: `I dt`.
    pub dt_s: f64,
}

impl Transition {
    /// `Φ` as a dense matrix (for the tests, and for anyone checking the blocks).
    #[cfg(test)]
    pub fn dense(&self) -> Covariance {
        let mut phi = Covariance::identity();
        phi.fixed_view_mut::<3, 3>(ix::ATT, ix::GYRO_BIAS)
            .copy_from(&self.att_from_gyro_bias);
        phi.fixed_view_mut::<3, 3>(ix::VEL, ix::ATT)
            .copy_from(&self.vel_from_att);
        phi.fixed_view_mut::<3, 3>(ix::VEL, ix::ACCEL_BIAS)
            .copy_from(&self.vel_from_accel_bias);
        phi.fixed_view_mut::<3, 3>(ix::POS, ix::VEL)
            .copy_from(&(Matrix3::identity() * self.dt_s));
        phi
    }

    /// `Φ P Φᵀ + diag(q)` for a symmetric `P`, as `Φ (Φ P)ᵀ`: two passes of [`Self::times`].
    pub fn propagate(&self, p: &Covariance, q: &SVector<f64, N_ERR>) -> Covariance {
        let mut out = self.times(&self.times(p).transpose());
        let diagonal = out.diagonal() + q;
        out.set_diagonal(&diagonal);
        out
    }

    /// `Φ M`, column by column: each column gains the four blocks times the rows they pick
    /// (30 multiply-adds instead of 225).
    fn times(&self, m: &Covariance) -> Covariance {
        let mut out = *m;
        for (mut o, c) in out.column_iter_mut().zip(m.column_iter()) {
            let att = c.fixed_rows::<3>(ix::ATT).into_owned();
            let vel = c.fixed_rows::<3>(ix::VEL).into_owned();
            let gyro_bias = c.fixed_rows::<3>(ix::GYRO_BIAS).into_owned();
            let accel_bias = c.fixed_rows::<3>(ix::ACCEL_BIAS).into_owned();
            let mut r = o.fixed_rows_mut::<3>(ix::ATT);
            r += self.att_from_gyro_bias * gyro_bias;
            let mut r = o.fixed_rows_mut::<3>(ix::VEL);
            r += self.vel_from_att * att + self.vel_from_accel_bias * accel_bias;
            let mut r = o.fixed_rows_mut::<3>(ix::POS);
            r += vel * self.dt_s;
        }
        out
    }
}

/// The Joseph-form update `(I − K H) P (I − K H)ᵀ + K R Kᵀ` with `R = diag(r)`, as
/// `A − (A Hᵀ) Kᵀ + K R Kᵀ` where `A = P − K (H P)`: products with `M` rows or columns
/// instead of 15.
pub(crate) fn joseph<const M: usize>(
    p: &Covariance,
    gain: &SMatrix<f64, N_ERR, M>,
    h: &SMatrix<f64, M, N_ERR>,
    r: &SVector<f64, M>,
) -> Covariance {
    let a = p - gain * (h * p);
    let k_r = SMatrix::<f64, N_ERR, M>::from_fn(|i, j| {
        gain.get((i, j)).copied().unwrap_or(0.0) * r.get(j).copied().unwrap_or(0.0)
    });
    a - (a * h.transpose()) * gain.transpose() + k_r * gain.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    /// A symmetric positive definite covariance with every entry non-zero.
    fn full_covariance() -> Covariance {
        let l = Covariance::from_fn(|i, j| {
            if j <= i {
                0.1 + ((i * 7 + j * 3) % 11) as f64 * 0.05
            } else {
                0.0
            }
        });
        l * l.transpose()
    }

    fn transition() -> Transition {
        let dt = 0.02;
        let rot = Rotation3::from_euler_angles(0.3, -0.2, 1.1).into_inner();
        let f = Vector3::new(0.4, -0.7, -9.6);
        Transition {
            att_from_gyro_bias: -rot * dt,
            vel_from_att: -f.cross_matrix() * dt,
            vel_from_accel_bias: -rot * dt,
            dt_s: dt,
        }
    }

    fn assert_close(a: &Covariance, b: &Covariance) {
        let scale = b.amax();
        let worst = (a - b).amax();
        assert!(
            worst <= 1e-13 * scale,
            "differs by {worst:e} (scale {scale:e})"
        );
    }

    #[test]
    fn propagation_equals_the_dense_product() {
        let p = full_covariance();
        let t = transition();
        let q = SVector::<f64, N_ERR>::from_fn(|i, _| 1e-6 * (i + 1) as f64);
        let phi = t.dense();
        let dense = phi * p * phi.transpose() + Covariance::from_diagonal(&q);
        assert_close(&t.propagate(&p, &q), &dense);
    }

    #[test]
    fn joseph_update_equals_the_dense_formula() {
        let p = full_covariance();
        let h =
            SMatrix::<f64, 3, N_ERR>::from_fn(|i, j| if j % 5 == i { 0.5 + i as f64 } else { 0.0 });
        let r = Vector3::new(0.01, 0.02, 0.03);
        let s = h * p * h.transpose() + Matrix3::from_diagonal(&r);
        let gain = p * h.transpose() * s.try_inverse().expect("invertible");
        let i_kh = Covariance::identity() - gain * h;
        let dense =
            i_kh * p * i_kh.transpose() + gain * Matrix3::from_diagonal(&r) * gain.transpose();
        assert_close(&joseph(&p, &gain, &h, &r), &dense);
    }
}
