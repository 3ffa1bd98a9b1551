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
    /// How long the hover is judged for from its origin ([`hold_window_us`]).
    hold_window_us: Option<u64>,
}

/// How long the hover is judged for from its origin (µs): the scenario's hold time less the
/// settling (at least [`HIL_HOLD_MIN_S`]), so that what the helicopter does after its plan's
/// hold (a Stop's landing, the next leg) is not counted as drift; to the run's end for a
/// scenario that sets no hold time.
fn hold_window_us(limits: &heli_scenario::Limits) -> Option<u64> {
    let hold_s = limits.hold_min_s?;
    let window_s = (hold_s - HIL_HOLD_SETTLE_S).max(HIL_HOLD_MIN_S);
    Some((window_s * 1e6) as u64)
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
        sim.hil = Some(Hil {
            hold_window_us: hold_window_us(&sim.scenario.limits),
            ..Hil::default()
        });
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
            let (t0, origin) = *hil.hold_origin.get_or_insert((now, p));
            if hil
                .hold_window_us
                .is_none_or(|w| now <= t0.saturating_add(w))
            {
                hil.hold_drift_max_m = hil.hold_drift_max_m.max((p - origin).norm());
                hil.hold_last_us = now;
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Moves the simulated helicopter to `pos` at `t_s` and measures.
    fn at(sim: &mut Simulation, t_s: f64, pos: [f64; 3]) {
        sim.now_us = (t_s * 1e6) as u64;
        sim.heli.state.pos_ned_m = Vector3::new(pos[0], pos[1], pos[2]);
        sim.measure_hil_truth();
    }

    fn drift(sim: &Simulation) -> Option<f64> {
        let criteria = sim.hil_criteria().unwrap();
        let c = criteria
            .iter()
            .find(|c| c.name == "hil_hold_drift_m")
            .unwrap();
        c.value
    }

    /// The hover scenario (take-off to 10 m, 60 s hold, 3 m of true drift allowed), its
    /// helicopter at 90 % of the take-off height at 20 s and settled 5 s later.
    fn hovering() -> Simulation {
        let mut sim = Simulation::hil(heli_scenario::hover()).unwrap();
        at(&mut sim, 0.0, [0.0, 0.0, 0.0]);
        at(&mut sim, 20.0, [0.0, 0.0, -9.5]);
        at(&mut sim, 25.0, [0.0, 0.0, -10.0]);
        sim
    }

    #[test]
    fn the_hold_is_judged_over_the_plans_hold_not_the_landing_after_it() {
        let mut sim = hovering();
        at(&mut sim, 50.0, [1.0, 0.0, -10.5]);
        at(&mut sim, 79.9, [1.5, 0.0, -10.0]);
        assert!((drift(&sim).unwrap() - 1.5).abs() < 1e-9);
        // The plan's hold is over (55 s after the origin): a Stop's landing is not drift.
        at(&mut sim, 81.0, [1.5, 0.0, -6.0]);
        at(&mut sim, 95.0, [1.5, 0.0, 0.0]);
        assert!((drift(&sim).unwrap() - 1.5).abs() < 1e-9);
        // Within the hold, a sink is drift.
        let mut sim = hovering();
        at(&mut sim, 40.0, [0.0, 0.0, -6.0]);
        assert!((drift(&sim).unwrap() - 4.0).abs() < 1e-9);
        // Under 10 s of hold: not measured.
        let mut sim = hovering();
        at(&mut sim, 30.0, [0.0, 0.0, -10.0]);
        assert_eq!(drift(&sim), None);
    }
}
