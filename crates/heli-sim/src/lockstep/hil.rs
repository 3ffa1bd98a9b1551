//! Hardware in the loop: the simulation without its flight software. What the devices send
//! the computer collects in an outbox (serial bytes per port, ADC conversions per channel)
//! for the HILSim runtime to write to pseudo-terminals and IIO files; what the real flight
//! computer writes back is injected as bytes arriving at the device. The run is judged on
//! the truth alone: the simulator cannot see the flight software's estimate or targets.

use super::*;

/// ADC channel of the battery divider in the HILSim's IIO directory (the compass's x, y, z
/// are channels 0, 1, 2).
pub const HIL_BATTERY_CHANNEL: u8 = 3;

/// How long after first reaching 90 % of the take-off height the hover is judged from (s).
pub const HIL_HOLD_SETTLE_S: f64 = 5.0;

/// Least hover time for the HIL hold criterion to count as measured (s).
pub const HIL_HOLD_MIN_S: f64 = 10.0;

/// Something the devices send the flight computer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HilOut {
    /// Serial bytes, to write to the port's pseudo-terminal.
    Bytes(Port, Bytes),
    /// A new ADC conversion of a channel.
    Adc {
        /// Channel number.
        channel: u8,
        /// Counts.
        counts: u16,
    },
    /// The hot-swap's digital input changed: high on the flight batteries.
    PowerLine(bool),
}

/// The HIL side of a simulation.
#[derive(Clone, Debug, Default)]
pub(super) struct Hil {
    pub(super) outbox: Vec<(u64, HilOut)>,
    /// Where the helicopter was when the hover began to be judged.
    hold_origin: Option<(u64, Vector3<f64>)>,
    reached_at_us: Option<u64>,
    hold_drift_max_m: f64,
    hold_last_us: u64,
}

impl Simulation {
    /// The scenario's helicopter and devices with the flight software outside: nothing runs
    /// the flight computer; its bytes come through [`Simulation::inject`].
    pub fn hil(scenario: Scenario) -> Result<Self, ScenarioError> {
        if let Some(phase) = &scenario.faults.timed_from {
            return Err(ScenarioError::Invalid(format!(
                "faults.timed_from = {phase:?}: the HILSim does not see the vehicle's phase; \
                 time the faults from the start of the run (or fly it in the lockstep: heli sim, \
                 heli campaign)"
            )));
        }
        let mut sim = Self::build(scenario, CoreConfig::default())?;
        sim.hil = Some(Hil::default());
        Ok(sim)
    }

    /// What the devices sent since the last call, with the time each is due (µs), in time
    /// order.
    pub fn take_outbox(&mut self) -> Vec<(u64, HilOut)> {
        self.hil
            .as_mut()
            .map(|h| std::mem::take(&mut h.outbox))
            .unwrap_or_default()
    }

    /// Bytes the flight computer wrote to `port`, arriving at the device now.
    pub fn inject(&mut self, port: Port, bytes: &[u8]) {
        let now = self.now_us;
        for chunk in bytes.chunks(16) {
            self.schedule(now, Kind::ToDevice(port, Bytes::from_slice(chunk)));
        }
    }

    /// The take-off height of the scenario's plan (m), if it has a take-off.
    fn takeoff_alt_m(&self) -> Option<f64> {
        self.scenario.plan.iter().find_map(|l| match l {
            heli_scenario::Leg::Takeoff { alt_m } => Some(*alt_m),
            _ => None,
        })
    }

    /// Truth measurements of a HIL run, every physics step: the climb and, once the
    /// helicopter has settled at its take-off height, how far it drifts.
    pub(super) fn measure_hil_truth(&mut self) {
        let now = self.now_us;
        let p = self.heli.state.pos_ned_m;
        let alt = -p.z;
        let start_alt = *self.metrics.start_alt_m.get_or_insert(alt);
        self.metrics.max_alt_m = self.metrics.max_alt_m.max(alt - start_alt);
        let target = self.takeoff_alt_m();
        let Some(hil) = self.hil.as_mut() else {
            return;
        };
        if let (None, Some(target)) = (hil.reached_at_us, target)
            && alt - start_alt >= 0.9 * target
        {
            hil.reached_at_us = Some(now);
        }
        let settle_us = (HIL_HOLD_SETTLE_S * 1e6) as u64;
        if let Some(reached) = hil.reached_at_us
            && now >= reached + settle_us
        {
            let (_, origin) = *hil.hold_origin.get_or_insert((now, p));
            hil.hold_drift_max_m = hil.hold_drift_max_m.max((p - origin).norm());
            hil.hold_last_us = now;
        }
    }

    /// The criteria of a HIL run, judged on the truth: the climb to the take-off height,
    /// the drift of the hover after it, and (elsewhere) no crash.
    pub(super) fn hil_criteria(&self) -> Option<Vec<Criterion>> {
        let hil = self.hil.as_ref()?;
        let mut criteria = Vec::new();
        if let Some(target) = self.takeoff_alt_m() {
            criteria.push(Criterion::at_least(
                "climb_m",
                Some(self.metrics.max_alt_m),
                target - 1.0,
            ));
        }
        if let Some(limit) = self.scenario.limits.hold_true_max_m {
            let held_s = hil.hold_origin.map_or(0.0, |(t0, _)| {
                hil.hold_last_us.saturating_sub(t0) as f64 * 1e-6
            });
            let drift = (held_s >= HIL_HOLD_MIN_S).then_some(hil.hold_drift_max_m);
            criteria.push(Criterion::at_most("hil_hold_drift_m", drift, limit));
        }
        Some(criteria)
    }
}
