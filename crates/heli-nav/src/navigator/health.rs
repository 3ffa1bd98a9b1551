//! The filter's health, as PX4's estimator reports it: for each aid the last innovation test
//! ratio (the squared innovation over its gate, the worst component; above 1 the sample was
//! refused) and the time since it was last fused.

use super::*;

/// The filter's health at a moment.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterHealth {
    /// Last GPS innovation test ratio (1 is the gate).
    pub gps_test_ratio: f64,
    /// Last altimeter innovation test ratio.
    pub baro_test_ratio: f64,
    /// Last compass innovation test ratio.
    pub compass_test_ratio: f64,
    /// Since a GPS fix was last fused (s); `None` if none ever was.
    pub since_gps_s: Option<f64>,
    /// Since an altimeter reading was last fused (s).
    pub since_baro_s: Option<f64>,
    /// Since a compass reading was last fused (s).
    pub since_compass_s: Option<f64>,
}

/// The last test ratio of each aid.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct TestRatios {
    pub(super) gps: f64,
    pub(super) baro: f64,
    pub(super) compass: f64,
}

impl Navigator {
    /// The filter's health at `now_us`.
    pub fn health(&self, now_us: u64) -> FilterHealth {
        let since = |t_us: u64| (t_us > 0).then(|| seconds_between(t_us, now_us));
        FilterHealth {
            gps_test_ratio: self.ratios.gps,
            baro_test_ratio: self.ratios.baro,
            compass_test_ratio: self.ratios.compass,
            since_gps_s: since(self.stats.last_gps_fused_us),
            since_baro_s: since(self.stats.last_baro_fused_us),
            since_compass_s: since(self.stats.last_compass_fused_us),
        }
    }
}
