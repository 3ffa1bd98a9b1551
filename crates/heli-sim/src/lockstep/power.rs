//! The flight computer's power: started at the beginning, and during a brown-out off (its
//! flight process gone but for the record it persisted) and on again with a new process
//! that resumes from that record (docs/architecture.md, restart in the air).

use super::*;

/// A flight computer started in place of the one before (a brown-out's end), as the device
/// inputs' log must say so that a replay starts a new one there too.
#[derive(Clone, Debug, PartialEq)]
pub struct Restarted {
    /// How many device inputs the log had kept before it ([`Simulation::device_inputs`]).
    pub inputs_before: usize,
    /// When (µs).
    pub t_us: u64,
    /// The record it started from (`None`: a cold start).
    pub warm: Option<heli_fsw::core::WarmStart>,
}

impl Simulation {
    /// The flight software arms its watchdogs, checks the servo board and starts its
    /// altimeter handshake.
    pub(super) fn start_flight_computer(&mut self) {
        let now = self.now_us;
        let mut sent = Vec::new();
        // Every simulated flight checks the flight core's invariants after every input.
        self.computer.watch_invariants();
        self.computer.start(now, &mut |port, b: &[u8]| {
            sent.push((port, Bytes::from_slice(b)))
        });
        for (port, b) in sent {
            self.send_to_device(port, b, now);
        }
        self.reschedule_tick();
    }

    /// Flight processes started after a brown-out calibrate from scratch, as if nothing was
    /// persisted (to show what the warm start is worth).
    pub fn forget_warm_start(&mut self) {
        self.cold_restarts = true;
    }

    /// A brown-out begins or ends: the flight computer loses its power (and its flight
    /// process, all but the record it persisted), or boots and starts a new flight process
    /// from that record.
    pub(super) fn power_flight_computer(&mut self) {
        if self.hil.is_some() {
            return; // the flight computer is outside: its power is its own
        }
        let off = self.scenario.faults.browned_out(self.t_s());
        match (off, self.browned_out) {
            (true, None) => {
                let warm = self.computer.core().warm_start();
                self.browned_out = Some(warm.filter(|_| !self.cold_restarts));
                self.metrics.brownouts += 1;
            }
            (false, Some(warm)) => {
                self.browned_out = None;
                let (config, params) = self.core_setup;
                let rate = heli_proto::baro::DEFAULT_RATE_HZ;
                if let Some(report) = self.computer.invariant_report() {
                    self.metrics.invariants_past.merge(report);
                }
                self.computer = match warm {
                    Some(warm) => FlightComputer::restarted(config, params, rate, warm),
                    None => FlightComputer::new(config, params, rate),
                };
                if let Some(log) = self.input_log.as_ref() {
                    self.restarts.push(Restarted {
                        inputs_before: log.len(),
                        t_us: self.now_us,
                        warm,
                    });
                }
                self.tick_at = None;
                self.start_flight_computer();
            }
            _ => {}
        }
    }
}
