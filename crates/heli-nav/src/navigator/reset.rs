//! The filter's way back from a long coast: when GPS fixes keep failing the innovation gate
//! long after the last one was fused — the inertial solution drifted during a gap, and the
//! gate, sized by a covariance that underestimates that drift, would refuse every later fix
//! — the position and velocity are reset to the GPS and their uncertainty to the GPS's, as
//! PX4 resets on a timeout and ArduPilot beyond its glitch radius. The reset is counted;
//! the flight core raises it.

use super::*;

impl Navigator {
    /// Resets position and velocity to the fix valid at `t_valid_us` when the gate has
    /// refused [`NavConfig::gps_reset_rejections`] fixes in a row and none was fused for
    /// [`NavConfig::gps_reset_after_s`].
    pub(super) fn reset_to_gps_if_due(
        &mut self,
        t_arrival_us: u64,
        t_valid_us: u64,
        gps_pos: &Vector3<f64>,
        gps_vel: &Vector3<f64>,
    ) {
        let since = self.stats.last_gps_fused_us.max(self.initialised_us);
        let long_coast = seconds_between(since, t_arrival_us) >= self.config.gps_reset_after_s;
        if !long_coast || self.stats.gps_rejected_in_row < self.config.gps_reset_rejections {
            return;
        }
        let Some(state) = self.state.as_mut() else {
            return;
        };
        // The fix was valid a latency ago: carried forward on its own velocity to now.
        let ahead_s = seconds_between(t_valid_us, state.t_us);
        let pos_now = gps_pos + gps_vel * ahead_s;
        state.pos_ned_m.x = pos_now.x;
        state.pos_ned_m.y = pos_now.y;
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
        // The past kept for delayed fixes belongs to the drifted solution.
        self.history.clear();
        self.stats.gps_resets = self.stats.gps_resets.saturating_add(1);
        self.stats.gps_rejected_in_row = 0;
        self.stats.last_gps_fused_us = t_arrival_us;
    }
}

impl Navigator {
    /// Starts the estimate in the air (a flight process started again in flight): as
    /// [`Navigator::initialise`], but moving at the GPS's velocity `vel_ned_mps` if a fix
    /// gave one, with no accelerometer bias taken from the mean specific force (in the air it
    /// holds the helicopter's acceleration, not only gravity), and with roll and pitch as
    /// uncertain as [`IN_AIR_TILT_SIGMA_RAD`] so that the GPS corrects a levelling taken
    /// while manoeuvring.
    pub fn initialise_in_air(
        &mut self,
        t_us: u64,
        biases: &ImuBiases,
        vel_ned_mps: Option<Vector3<f64>>,
    ) {
        self.initialise(t_us, biases);
        if let Some(state) = self.state.as_mut() {
            if let Some(v) = vel_ned_mps {
                state.vel_ned_mps = v;
            }
            state.accel_bias_mps2 = Vector3::zeros();
        }
        let tilt = IN_AIR_TILT_SIGMA_RAD * IN_AIR_TILT_SIGMA_RAD;
        for i in ix::ATT..ix::ATT.saturating_add(2) {
            if let Some(x) = self.cov.get_mut((i, i)) {
                *x = x.max(tilt);
            }
        }
    }
}

/// How uncertain roll and pitch are after a levelling in the air (rad): 10 deg.
pub const IN_AIR_TILT_SIGMA_RAD: f64 = 0.17;
