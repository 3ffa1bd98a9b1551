//! The filter's way back from a long coast: when GPS fixes keep failing the innovation gate
//! long after the last one was fused — the inertial solution drifted during a gap, and the
//! gate, sized by a covariance that underestimates that drift, would refuse every later fix
//! — the position and velocity are reset to the GPS (where the fix was valid, a latency ago,
//! and carried to the present by the IMU) and their uncertainty to the GPS's, as
//! PX4 resets on a timeout and ArduPilot beyond its glitch radius. The reset is counted;
//! the flight core raises it.

use super::*;

impl Navigator {
    /// True when a fix refused by the gate is to reset the estimate: the gate has refused
    /// [`NavConfig::gps_reset_rejections`] fixes in a row and none was fused for
    /// [`NavConfig::gps_reset_after_s`].
    pub(super) fn gps_reset_due(&self, t_arrival_us: u64) -> bool {
        let since = self.stats.last_gps_fused_us.max(self.initialised_us);
        seconds_between(since, t_arrival_us) >= self.config.gps_reset_after_s
            && self.stats.gps_rejected_in_row >= self.config.gps_reset_rejections
    }

    /// Resets the position and velocity of the state (the one the fix was valid at, rolled
    /// back to, `dt_fix_s` before the fix's time of validity) to the fix's, and their
    /// uncertainty to the GPS's; counted.
    pub(super) fn reset_to_gps(
        &mut self,
        dt_fix_s: f64,
        gps_pos: &Vector3<f64>,
        gps_vel: &Vector3<f64>,
        t_arrival_us: u64,
    ) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        // The fix placed where the state is in time, on its own velocity.
        let pos = gps_pos - gps_vel * dt_fix_s;
        state.pos_ned_m.x = pos.x;
        state.pos_ned_m.y = pos.y;
        state.vel_ned_mps = *gps_vel;
        // Position and velocity know nothing but the GPS now: no correlations, the GPS's own
        // variances.
        let (sp, sv) = (
            self.config.gps_pos_sigma_m.powi(2),
            self.config.gps_vel_sigma_mps.powi(2),
        );
        for i in ix::VEL..ix::POS.saturating_add(2) {
            for j in 0..N_ERR {
                if let Some(x) = self.cov.get_mut((i, j)) {
                    *x = 0.0;
                }
                if let Some(x) = self.cov.get_mut((j, i)) {
                    *x = 0.0;
                }
            }
            let variance = if i >= ix::POS { sp } else { sv };
            if let Some(x) = self.cov.get_mut((i, i)) {
                *x = variance;
            }
        }
        self.stats.gps_resets = self.stats.gps_resets.saturating_add(1);
        self.stats.gps_rejected_in_row = 0;
        self.stats.last_gps_fused_us = t_arrival_us;
    }
}

impl Navigator {
    /// Starts the estimate in the air (a flight process started again in flight): as
    /// [`Navigator::initialise`], but moving at the GPS's velocity `vel_ned_mps` if a fix
    /// gave one, with no accelerometer bias taken from the mean specific force (in the air it
    /// holds the helicopter's acceleration, not only gravity), placed where the last fix
    /// leads after its latency, keeping the earth's field and the altimeter reference learned
    /// on the ground, and with the attitude, velocity and position as uncertain as
    /// [`IN_AIR_ATTITUDE_SIGMA_RAD`], [`IN_AIR_VEL_SIGMA_MPS`] and [`IN_AIR_POS_SIGMA_M`] so
    /// that the GPS corrects a levelling taken while manoeuvring.
    pub fn initialise_in_air(
        &mut self,
        t_us: u64,
        biases: &ImuBiases,
        vel_ned_mps: Option<Vector3<f64>>,
    ) {
        // The earth's field learned on the skids, where the levelling was true, is kept: one
        // learned again from a levelling in the air would bake its tilt error into every
        // later compass reading, where the kept one lets the compass correct it.
        // So is the altimeter's reference, set on the ground: a mean of the pressures read
        // in flight, placed at a fix's height, is no reference at all.
        let earth_field = self.earth_field_ned;
        let baro_reference = self
            .baro_reference_mbar
            .map(|p| (p, self.baro_reference_z_m));
        self.initialise(t_us, biases);
        if let Some(field) = earth_field {
            self.earth_field_ned = Some(field);
        }
        if let Some((p_mbar, z_m)) = baro_reference {
            self.baro_reference_mbar = Some(p_mbar);
            self.baro_reference_z_m = z_m;
        }
        let fix_valid_us = self.last_gps_valid_us;
        if let Some(state) = self.state.as_mut() {
            if let Some(v) = vel_ned_mps {
                state.vel_ned_mps = v;
                // The fix placed the helicopter where it was a latency ago; moving, it is
                // that far along its velocity now.
                if let Some(valid_us) = fix_valid_us {
                    state.pos_ned_m += v * seconds_between(valid_us, t_us);
                }
            }
            state.accel_bias_mps2 = Vector3::zeros();
        }
        // In the air nothing is at rest or exactly placed: the attitude as uncertain as a
        // levelling under acceleration, the velocity and position as a fix a latency old.
        let blocks = [
            (ix::ATT, IN_AIR_ATTITUDE_SIGMA_RAD),
            (ix::VEL, IN_AIR_VEL_SIGMA_MPS),
            (ix::POS, IN_AIR_POS_SIGMA_M),
        ];
        for (offset, sigma) in blocks {
            for i in offset..offset.saturating_add(3) {
                if let Some(x) = self.cov.get_mut((i, i)) {
                    *x = x.max(sigma * sigma);
                }
            }
        }
    }
}

impl Navigator {
    /// Sets the attitude of an estimate just started in the air to `att` (body to NED): one
    /// carried by the gyros from a record, better than the levelling it replaces. Its
    /// uncertainty stays that of [`Navigator::initialise_in_air`].
    pub fn set_attitude_in_air(&mut self, att: UnitQuaternion<f64>) {
        if let Some(state) = self.state.as_mut()
            && att.coords.iter().all(|x| x.is_finite())
        {
            state.att = att;
            // Nothing before this may be replayed over it.
            self.history.clear();
        }
    }
}

/// How uncertain the attitude is after a levelling in the air (rad): 20 deg — the
/// accelerometers of a helicopter that is speeding up or slowing down lean with it, and the
/// heading, tilt-compensated with that levelling, errs with it.
pub const IN_AIR_ATTITUDE_SIGMA_RAD: f64 = 0.35;

/// How uncertain the velocity is after a start in the air (m/s): a fix a latency old, of a
/// helicopter that may have been braking or speeding up since.
pub const IN_AIR_VEL_SIGMA_MPS: f64 = 2.0;

/// How uncertain the position is after a start in the air (m).
pub const IN_AIR_POS_SIGMA_M: f64 = 5.0;

/// What the estimate learned on the ground and keeps through a start in the air: a flight
/// process started again hands them on ([`Navigator::ground_references`],
/// [`Navigator::restore_ground_references`]), so that its levelling in the air does not
/// teach it the earth's field or the altimeter's reference again.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GroundReferences {
    /// The earth's magnetic field in NED (gauss), learned where the levelling was true.
    pub earth_field_ned_gauss: Option<[f64; 3]>,
    /// The altimeter's reference pressure (mbar) and the height it was set at (m, NED z).
    pub baro_reference: Option<(f64, f64)>,
}

impl Navigator {
    /// The references learned on the ground, to hand on to a successor.
    pub fn ground_references(&self) -> GroundReferences {
        GroundReferences {
            earth_field_ned_gauss: self.earth_field_ned.map(|f| [f.x, f.y, f.z]),
            baro_reference: self
                .baro_reference_mbar
                .map(|p| (p, self.baro_reference_z_m)),
        }
    }

    /// Takes on the references a predecessor learned (before a start in the air: kept
    /// through [`Navigator::initialise_in_air`]). Values that are not finite are ignored.
    pub fn restore_ground_references(&mut self, r: GroundReferences) {
        if let Some(f) = r
            .earth_field_ned_gauss
            .filter(|f| f.iter().all(|x| x.is_finite()))
        {
            self.earth_field_ned = Some(Vector3::from(f));
        }
        if let Some((p_mbar, z_m)) = r
            .baro_reference
            .filter(|(p, z)| p.is_finite() && *p > 0.0 && z.is_finite())
        {
            self.baro_reference_mbar = Some(p_mbar);
            self.baro_reference_z_m = z_m;
        }
    }
}
