//! Scenarios: what to fly and how to judge it. Built-in ones are listed by `heli sim --list`;
//! a TOML file can describe a new one, starting from a built-in (`base = "hover"`) and
//! overriding any field (see `docs/scenarios.md`).

use serde::{Deserialize, Serialize};

use heli_model::params::{Airframe, Atmosphere};

pub use heli_types::{FlightMode, Leg};

pub use crate::pilot::{Channel, Pilot, Shape, StickInput};

/// Pass/fail limits; a criterion is judged only when its limit is set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Least time spent holding position (s).
    pub hold_min_s: Option<f64>,
    /// Horizontal hold error RMS, estimate against target (m).
    pub hold_horizontal_rms_m: Option<f64>,
    /// Altitude hold error RMS, estimate against target (m).
    pub hold_altitude_rms_m: Option<f64>,
    /// Largest true distance from the target during the holds (m).
    pub hold_true_max_m: Option<f64>,
    /// Fewest autonomous rolls completed.
    pub rolls_min: Option<f64>,
    /// Largest altitude loss over the roll sequence (m): true altitude at its start minus the
    /// lowest true altitude before the recovery ends.
    pub altitude_loss_max_m: Option<f64>,
    /// Largest attitude error (deg, roll or pitch) at the end of the recovery from the last
    /// roll, against the trim attitude the sequence began from (in wind the trim is not
    /// level).
    pub recovery_attitude_max_deg: Option<f64>,
    /// Largest airspeed error at the end of the recovery (m/s), against the airspeed the
    /// sequence began from: judged relative to the air, not the ground.
    pub recovery_speed_max_mps: Option<f64>,
    /// Estimator attitude error RMS over the flight (deg).
    pub att_err_rms_max_deg: Option<f64>,
    /// Estimator attitude error, worst case (deg).
    pub att_err_max_deg: Option<f64>,
    /// Estimator position error RMS, relative navigation (m).
    pub pos_err_rms_max_m: Option<f64>,
    /// After the transmitter is lost: hovering (true speed under 0.5 m/s) within this (s).
    pub rc_loss_hover_within_s: Option<f64>,
    /// After the transmitter is lost: largest true horizontal drift over the 20 s after the
    /// hover began (m).
    pub rc_loss_drift_max_m: Option<f64>,
    /// Estimator position error at the end of each GPS outage (m).
    pub gps_outage_pos_err_max_m: Option<f64>,
    /// The flight plan must be completed.
    pub plan_complete: Option<bool>,
    /// In manual flight (auto switch off): largest true yaw rate (deg/s) — the computer's yaw
    /// damping at work.
    pub manual_yaw_rate_max_dps: Option<f64>,
    /// In manual flight: largest true horizontal distance from where it began (m).
    pub manual_distance_max_m: Option<f64>,
    /// During scripted sweeps: least true roll-rate RMS (deg/s), i.e. the sweep was flown.
    pub sweep_roll_rate_rms_min_dps: Option<f64>,
    /// Augmented velocity mode: largest error between the velocity the sticks command and
    /// the true velocity, over the last second of each scripted aileron or elevator input
    /// (m/s).
    pub velocity_tracking_max_mps: Option<f64>,
    /// Augmented velocity mode: least true height gained (m).
    pub climb_min_m: Option<f64>,
    /// Augmented modes: largest error between the yaw rate the rudder stick commands and the
    /// true yaw rate, over the last second of each scripted rudder input (deg/s).
    pub yaw_rate_tracking_max_dps: Option<f64>,
    /// Stayed on the ground: the greatest height above the start (m) must not exceed this.
    pub ground_max_m: Option<f64>,
    /// Least true height above the start (m) from the end of the take-off climb (flown by
    /// hand: from when it first climbed above 2 m) until it begins to land (or the run ends).
    pub height_min_m: Option<f64>,
    /// Largest true tilt (deg) from level while airborne.
    pub tilt_max_deg: Option<f64>,
    /// After a flight, the touchdown: largest horizontal distance (m) between where the skids
    /// touched and where the flight software meant to land (its last target, as a true
    /// place).
    pub touchdown_distance_max_m: Option<f64>,
    /// Largest sink speed at touchdown (m/s).
    pub touchdown_sink_max_mps: Option<f64>,
    /// Largest horizontal ground speed at touchdown (m/s).
    pub touchdown_speed_max_mps: Option<f64>,
    /// Largest tilt from level (deg) when the skids first touch after a flight.
    pub touchdown_tilt_max_deg: Option<f64>,
    /// After an engine failure: least rotor speed (rpm) before the touchdown while more
    /// than 3 m above the start (the cushion near the ground spends it on purpose).
    pub rotor_min_rpm: Option<f64>,
    /// Least true charge of the flight pack over the run (fraction): the avionics still
    /// powered.
    pub flight_battery_soc_min: Option<f64>,
    /// Largest error of the flight software's time left on the flight pack against the
    /// truth (%), once its gauge has had two minutes and while five are left.
    pub battery_time_left_err_max_pct: Option<f64>,
    /// Time to hover (s): from the start of the first position hold until the true ground
    /// speed has stayed under 0.5 m/s for a second.
    pub hover_within_s: Option<f64>,
}

pub use crate::faults::{ByteLoss, Faults, ForcedSatellites, GpsGlitch};

/// One scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Name.
    pub name: String,
    /// One line on what it flies.
    pub description: String,
    /// Random seed of every noise source.
    pub seed: u64,
    /// Longest simulated time (s); the run ends earlier when the flight plan is complete.
    pub duration_s: f64,
    /// Steady wind, NED (m/s).
    pub wind_ned_mps: [f64; 3],
    /// Turbulence: vertical gust intensity σ_w (m/s); Dryden, low altitude. 0 for none.
    pub turbulence_sigma_mps: f64,
    /// Wind shear: how much the wind changes per metre of height above the take-off point,
    /// NED ((m/s)/m).
    pub wind_shear_mps_per_m: [f64; 3],
    /// Wind changes over time (gusts, steps, ramps), added to the steady wind.
    pub wind_changes: Vec<crate::faults::WindChange>,
    /// Air and gravity.
    pub atmosphere: Atmosphere,
    /// The helicopter's parameters (default: the MIT X-Cell 60 SE).
    pub airframe: Airframe,
    /// The flight battery: capacity, charge at power-on, load, temperature, wear.
    pub battery: crate::faults::Battery,
    /// The servo board's packs and the hot-swap.
    pub power: crate::faults::Power,
    /// Control system.
    pub mode: FlightMode,
    /// The autonomous flight plan.
    pub plan: Vec<Leg>,
    /// Pilot's transmitter.
    pub pilot: Pilot,
    /// Injected faults.
    pub faults: Faults,
    /// Pass/fail limits.
    pub limits: Limits,
    /// Texts that must appear among the flight software's events (each is a criterion):
    /// how a fault scenario checks that the fault was raised, e.g. `"uplink lost"`.
    pub expect_events: Vec<String>,
}

impl Scenario {
    /// The wind at `t_s` and `height_m` above the take-off point, before turbulence: the
    /// steady wind, its shear with height and its changes over time.
    pub fn wind_at(&self, t_s: f64, height_m: f64) -> nalgebra::Vector3<f64> {
        let steady = nalgebra::Vector3::from(self.wind_ned_mps);
        let shear = nalgebra::Vector3::from(self.wind_shear_mps_per_m) * height_m.max(0.0);
        self.wind_changes.iter().fold(steady + shear, |w, c| {
            w + nalgebra::Vector3::from(c.wind_ned_mps) * c.fraction(t_s)
        })
    }
}
