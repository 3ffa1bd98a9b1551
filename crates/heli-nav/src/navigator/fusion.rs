//! The measurements the filter fuses and the Kalman update they share: GPS position and
//! velocity (with the fix's latency compensated by replaying the stored steps since it was
//! valid), barometric altitude and compass heading. Each is gated on its innovation; a
//! refused measurement changes nothing and is counted.

use super::*;

impl Navigator {
    /// A Kalman update with `M` measurements: innovation `y`, measurement matrix `h`, noise
    /// variances `r`. Returns false (nothing changed) if a component fails the gate.
    pub(super) fn update<const M: usize>(
        &mut self,
        y: &SVector<f64, M>,
        h: &SMatrix<f64, M, N_ERR>,
        r: &SVector<f64, M>,
    ) -> bool {
        let p = self.cov;
        let s = h * p * h.transpose() + SMatrix::<f64, M, M>::from_diagonal(r);
        let gate = self.config.gate_sigmas * self.config.gate_sigmas;
        let mut worst = 0.0_f64;
        for i in 0..M {
            let (yi, si) = (
                y.get(i).copied().unwrap_or(f64::NAN),
                s.get((i, i)).copied().unwrap_or(f64::NAN),
            );
            let ratio = yi * yi / (gate * si);
            worst = if ratio.is_nan() {
                f64::INFINITY
            } else {
                worst.max(ratio)
            };
        }
        self.last_test_ratio = worst;
        if worst.is_nan() || worst > 1.0 {
            return false;
        }
        let Some(s_inv) = s.try_inverse() else {
            return false;
        };
        let gain = p * h.transpose() * s_inv;
        let dx = gain * y;
        self.inject(&dx);
        // Joseph form keeps the covariance positive definite.
        self.cov = covariance::joseph(&p, &gain, h, r);
        self.tidy_covariance();
        true
    }

    /// Fuses a GPS fix whose last byte arrived at `t_arrival_us`.
    pub fn fuse_gps(&mut self, t_arrival_us: u64, fix: &GpsNav) {
        let usable = matches!(fix.fix, FixType::Fix3D)
            && fix.satellites >= self.config.gps_min_satellites
            && fix.lat_deg.is_finite()
            && fix.lon_deg.is_finite()
            && fix.alt_m.is_finite()
            && fix.vel_ned_mps.iter().all(|x| x.is_finite());
        if !usable {
            self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
            return;
        }
        let origin = *self.origin.get_or_insert(GeoOrigin {
            lat_deg: fix.lat_deg,
            lon_deg: fix.lon_deg,
            alt_m: fix.alt_m,
        });
        let gps_pos = Vector3::from(origin.to_ned(fix.lat_deg, fix.lon_deg, fix.alt_m));
        let gps_vel = Vector3::from(fix.vel_ned_mps);
        self.last_gps_ned = Some(gps_pos);
        let t_valid = t_arrival_us.saturating_sub(seconds_to_us(self.config.gps_latency_s));
        self.last_gps_valid_us = Some(t_valid);
        if self.state.is_none() {
            return; // before initialisation a fix only sets the origin and the start position
        }
        // Roll back to the last propagation at or before the time of validity: restore the
        // state and covariance from just before the first propagation after it. A fix valid
        // now (no propagation since) is fused on the present state.
        let split = self
            .history
            .iter()
            .position(|op| matches!(op, Op::Propagate { t_us, .. } if *t_us > t_valid))
            .unwrap_or(self.history.len());
        let (live_state, live_cov) = (self.state, self.cov);
        if let Some(Op::Propagate {
            before, cov_before, ..
        }) = self.history.get(split).copied()
        {
            let has_earlier = self
                .history
                .iter()
                .take(split)
                .any(|op| matches!(op, Op::Propagate { .. }));
            if !has_earlier && before.t_us.abs_diff(t_valid) > 30_000 {
                // Older than anything kept.
                self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
                return;
            }
            self.state = Some(before);
            self.cov = cov_before;
        }
        let Some(before) = self.state else { return };
        let dt_fix = (t_valid as f64 - before.t_us as f64) * 1e-6;
        let pos_d = before.pos_ned_m + before.vel_ned_mps * dt_fix;
        let vel_d = before.vel_ned_mps;
        let y = SVector::<f64, 5>::new(
            gps_pos.x - pos_d.x,
            gps_pos.y - pos_d.y,
            gps_vel.x - vel_d.x,
            gps_vel.y - vel_d.y,
            gps_vel.z - vel_d.z,
        );
        let mut h = SMatrix::<f64, 5, N_ERR>::zeros();
        for (row, col) in [
            (0, ix::POS),
            (1, ix::POS + 1),
            (2, ix::VEL),
            (3, ix::VEL + 1),
            (4, ix::VEL + 2),
        ] {
            if let Some(x) = h.get_mut((row, col)) {
                *x = 1.0;
            }
        }
        let (sp, sv) = (
            self.config.gps_pos_sigma_m.powi(2),
            self.config.gps_vel_sigma_mps.powi(2),
        );
        let r = SVector::<f64, 5>::new(sp, sp, sv, sv, 4.0 * sv);
        let fused = self.update(&y, &h, &r);
        self.ratios.gps = self.last_test_ratio;
        if !fused {
            self.stats.gps_rejected = self.stats.gps_rejected.saturating_add(1);
            self.stats.gps_rejected_in_row = self.stats.gps_rejected_in_row.saturating_add(1);
            if !self.gps_reset_due(t_arrival_us) {
                self.state = live_state;
                self.cov = live_cov;
                return;
            }
            // The reset is made where the fix was valid, a latency ago, and the IMU carries
            // it to the present in the replay: a helicopter pulling up or rolling out
            // changes its velocity by metres a second in that latency.
            self.reset_to_gps(dt_fix, &gps_pos, &gps_vel, t_arrival_us);
            self.replay_since(split, true);
            return;
        }
        self.stats.gps_rejected_in_row = 0;
        self.replay_since(split, false);
        self.stats.gps_fused = self.stats.gps_fused.saturating_add(1);
        self.stats.last_gps_fused_us = t_arrival_us;
    }

    /// Replays the history from `split` (the first step after a delayed fix was valid) to the
    /// present, from the state corrected there; with `drop_past`, what is kept from before
    /// `split` (the drifted solution a reset left) is dropped.
    fn replay_since(&mut self, split: usize, drop_past: bool) {
        // The scratch buffer is taken out while the replay calls back into `self`, and put
        // back with its capacity: no allocation in the control step.
        let mut replay = std::mem::take(&mut self.replay);
        replay.extend(self.history.drain(split..));
        if drop_past {
            self.history.clear();
        }
        for op in replay.drain(..) {
            match op {
                Op::Propagate { t_us, a, b, .. } => self.propagate(t_us, &a, &b),
                Op::Baro(p) => {
                    self.apply_baro(p);
                    self.record(op);
                }
                Op::Mag(field) => {
                    self.apply_mag(&field);
                    self.record(op);
                }
                Op::Still => {
                    self.apply_still();
                    self.record(op);
                }
            }
        }
        self.replay = replay;
    }

    /// Fuses a barometric pressure reading (before initialisation: accumulates the reference).
    pub fn fuse_baro(&mut self, pressure_mbar: f64) {
        if !(pressure_mbar.is_finite() && pressure_mbar > 0.0) {
            self.stats.baro_rejected = self.stats.baro_rejected.saturating_add(1);
            return;
        }
        if self.state.is_none() {
            self.baro_sum_mbar += pressure_mbar;
            self.baro_count = self.baro_count.saturating_add(1);
            return;
        }
        let fused = self.apply_baro(pressure_mbar);
        self.ratios.baro = self.last_test_ratio;
        if fused {
            self.stats.baro_fused = self.stats.baro_fused.saturating_add(1);
            self.stats.last_baro_fused_us = self.state.map_or(0, |s| s.t_us);
        } else {
            self.stats.baro_rejected = self.stats.baro_rejected.saturating_add(1);
        }
        self.record(Op::Baro(pressure_mbar));
    }

    pub(super) fn apply_baro(&mut self, pressure_mbar: f64) -> bool {
        let Some(state) = self.state.as_ref() else {
            return false;
        };
        // An altimeter that started after the calibration is referenced where it first speaks.
        let z_now = state.pos_ned_m.z;
        let reference = *self.baro_reference_mbar.get_or_insert_with(|| {
            self.baro_reference_z_m = z_now;
            pressure_mbar
        });
        let z_baro = self.baro_reference_z_m - pressure_altitude_m(pressure_mbar, reference);
        let y = SVector::<f64, 1>::new(z_baro - z_now);
        let mut h = SMatrix::<f64, 1, N_ERR>::zeros();
        if let Some(x) = h.get_mut((0, ix::POS + 2)) {
            *x = 1.0;
        }
        let r = SVector::<f64, 1>::new(self.config.baro_sigma_m.powi(2));
        self.update(&y, &h, &r)
    }

    /// Fuses a calibrated compass field (before initialisation: remembers it for the heading).
    pub fn fuse_compass(&mut self, field: &MagField) {
        if !field.field_gauss.iter().all(|x| x.is_finite()) {
            self.stats.compass_rejected = self.stats.compass_rejected.saturating_add(1);
            return;
        }
        self.last_field = Some(*field);
        if self.state.is_none() {
            return;
        }
        if self.earth_field_ned.is_none() {
            // No compass before initialisation: the heading was a guess; take this reading.
            self.align_heading(field);
            self.stats.compass_fused = self.stats.compass_fused.saturating_add(1);
            return;
        }
        let fused = self.apply_mag(field);
        self.ratios.compass = self.last_test_ratio;
        if fused {
            self.stats.compass_fused = self.stats.compass_fused.saturating_add(1);
            self.stats.last_compass_fused_us = self.state.map_or(0, |s| s.t_us);
        } else {
            self.stats.compass_rejected = self.stats.compass_rejected.saturating_add(1);
        }
        self.record(Op::Mag(*field));
    }

    pub(super) fn apply_mag(&mut self, field: &MagField) -> bool {
        let (Some(state), Some(earth)) = (self.state.as_ref(), self.earth_field_ned) else {
            return false;
        };
        let rot_t = state.att.inverse().to_rotation_matrix().into_inner();
        let predicted = rot_t * earth;
        let y = Vector3::from(field.field_gauss) - predicted;
        let mut h = SMatrix::<f64, 3, N_ERR>::zeros();
        h.fixed_view_mut::<3, 3>(0, ix::ATT)
            .copy_from(&(rot_t * skew(&earth)));
        let r = Vector3::repeat(self.config.mag_sigma_gauss.powi(2));
        self.update(&y, &h, &r)
    }
}
