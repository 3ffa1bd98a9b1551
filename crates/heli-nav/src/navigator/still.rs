//! Zero-velocity updates: a helicopter standing on its skids is not moving, and the filter
//! is told so. Without them the inertial solution on the ground, with no GPS, wanders as the
//! accelerometer's errors integrate twice (tens of metres in a few minutes), and the display
//! and the log show a helicopter "moving" on its skids; with GPS, the fixes' noise moves it.
//!
//! The caller decides when the helicopter stands (the flight core: on the ground, before the
//! first lift-off, with no lift commanded); the update is gated like any other, so a
//! helicopter that is moving after all (carried, sliding) is refused and counted.

use super::*;

impl Navigator {
    /// Fuses "standing still": the velocity is zero, σ [`NavConfig::still_sigma_mps`] per
    /// axis. Nothing before initialisation.
    pub fn fuse_still(&mut self) {
        if self.state.is_none() {
            return;
        }
        if self.apply_still() {
            self.stats.still_fused = self.stats.still_fused.saturating_add(1);
        } else {
            self.stats.still_rejected = self.stats.still_rejected.saturating_add(1);
        }
        self.record(Op::Still);
    }

    pub(super) fn apply_still(&mut self) -> bool {
        let Some(state) = self.state.as_ref() else {
            return false;
        };
        let y = -state.vel_ned_mps;
        let mut h = SMatrix::<f64, 3, N_ERR>::zeros();
        for (row, col) in [(0, ix::VEL), (1, ix::VEL + 1), (2, ix::VEL + 2)] {
            if let Some(x) = h.get_mut((row, col)) {
                *x = 1.0;
            }
        }
        let r = SVector::<f64, 3>::repeat(self.config.still_sigma_mps.powi(2));
        self.update(&y, &h, &r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::ImuBiases;

    /// A navigator initialised level and still, whose accelerometer reads a bias it does not
    /// know (0.05 m/s² north).
    fn standing() -> (Navigator, ImuRepr) {
        let mut nav = Navigator::new(NavConfig::default());
        nav.fuse_compass(&MagField {
            field_gauss: [0.2, 0.0, 0.45],
        });
        nav.fuse_baro(1013.25);
        let biases = ImuBiases {
            gyro_rps: Vector3::zeros(),
            mean_accel_mps2: Vector3::new(0.0, 0.0, -9.80665),
            samples: 8000,
        };
        nav.initialise(0, &biases);
        let sample = ImuRepr {
            rate_rps: [0.0; 3],
            accel_mps2: [0.05, 0.0, -9.80665],
            temp_c: 20.0,
        };
        (nav, sample)
    }

    /// Five minutes on the skids, told it stands (`still`) or not: where it thinks it is.
    fn five_minutes(still: bool) -> (Navigator, f64) {
        let (mut nav, sample) = standing();
        for k in 1..=15_000u64 {
            nav.propagate(k * 20_000, &sample, &sample);
            if still && k % 5 == 0 {
                nav.fuse_still();
            }
        }
        let off = nav.state().map_or(f64::NAN, |s| s.pos_ned_m.norm());
        (nav, off)
    }

    #[test]
    fn standing_on_the_skids_the_estimate_stays_where_it_is() {
        let (_, drifted) = five_minutes(false);
        assert!(drifted > 100.0, "without: {drifted} m");
        let (nav, off) = five_minutes(true);
        assert!(off < 1.0, "with zero-velocity updates: {off} m");
        let s = nav
            .state()
            .copied()
            .unwrap_or_else(|| panic!("initialised"));
        assert!(s.vel_ned_mps.norm() < 0.05, "{:?}", s.vel_ned_mps);
        assert_eq!(nav.stats().still_fused, 3000);
        assert_eq!(nav.stats().still_rejected, 0);
    }

    #[test]
    fn every_axis_of_the_velocity_is_told_it_is_zero() {
        let (mut nav, sample) = standing();
        if let Some(s) = nav.state.as_mut() {
            s.vel_ned_mps = Vector3::new(0.2, -0.3, 0.25);
        }
        for k in 1..=250u64 {
            nav.propagate(k * 20_000, &sample, &sample);
            if k % 5 == 0 {
                nav.fuse_still();
            }
        }
        let v = nav
            .state()
            .map_or(Vector3::repeat(f64::NAN), |s| s.vel_ned_mps);
        assert!(v.iter().all(|x| x.abs() < 0.03), "{v:?}");
    }

    #[test]
    fn a_helicopter_moving_after_all_is_refused_and_counted() {
        let (mut nav, _) = standing();
        if let Some(s) = nav.state.as_mut() {
            s.vel_ned_mps = Vector3::new(3.0, 0.0, 0.0);
        }
        // A velocity the covariance is sure of: 3 m/s is far beyond the gate.
        nav.cov = Covariance::identity() * 1e-4;
        nav.fuse_still();
        assert_eq!(nav.stats().still_rejected, 1);
        assert_eq!(nav.state().map(|s| s.vel_ned_mps.x), Some(3.0));
        // Nothing before initialisation.
        let mut fresh = Navigator::new(NavConfig::default());
        fresh.fuse_still();
        assert_eq!(fresh.stats(), NavSensorStats::default());
    }
}
