//! The flight computer's reaction time cut into its stages: the HILSim's stamps (IMU packet
//! written, servo packet read back) joined with the flight process's latency trace (driver
//! read, loop woken, step start, servo written, step end), all on `CLOCK_MONOTONIC`.

use heli_vehicle::latency::StepStamps;
use serde::Serialize;

use crate::summary::{HilStamps, Percentiles};

/// The stages, in the order a servo command goes through them: name and what it is.
pub const STAGES: [(&str, &str); 7] = [
    (
        "imu_terminal",
        "IMU packet's write begins -> IMU driver's read returns (write, pseudo-terminal, driver wake-up)",
    ),
    (
        "hand_over",
        "driver's read -> control loop woken (channel, loop wake-up)",
    ),
    ("before_step", "loop woken -> control step starts"),
    (
        "step_to_servo",
        "step starts -> servo packet's write begins (parse, estimate, control)",
    ),
    (
        "servo_terminal",
        "servo packet's write begins -> HILSim's read returns (write, pseudo-terminal, reader wake-up)",
    ),
    (
        "end_to_end",
        "IMU packet's write begins -> servo packet read back",
    ),
    (
        "whole_step",
        "step starts -> step ends (with logging, streams, records)",
    ),
];

/// One stage's percentiles (µs).
#[derive(Clone, Debug, Serialize)]
pub struct Stage {
    /// Its short name.
    pub name: &'static str,
    /// What it spans.
    pub what: &'static str,
    /// Its percentiles (µs).
    pub us: Percentiles,
}

/// The stage table, and how many servo commands it covers.
#[derive(Clone, Debug, Serialize)]
pub struct StageTable {
    /// Servo commands of the trace that matched an IMU write and a servo read.
    pub matched: usize,
    /// Servo commands of the trace that did not (the first and last, a lost packet).
    pub unmatched: usize,
    /// Each stage.
    pub stages: Vec<Stage>,
}

/// Farthest apart a trace's stamp and the HILSim's may be to belong to the same packet.
const MATCH_NS: u64 = 20_000_000;

/// The newest of the sorted `times` at or before `t`.
fn at_or_before(times: &[u64], t: u64) -> Option<u64> {
    let i = times.partition_point(|&x| x <= t);
    i.checked_sub(1).and_then(|i| times.get(i)).copied()
}

/// The oldest of the sorted `times` at or after `t`.
fn at_or_after(times: &[u64], t: u64) -> Option<u64> {
    times.get(times.partition_point(|&x| x < t)).copied()
}

/// Microseconds from `a` to `b` (0 if `b` is before `a`: the trace's driver stamp is
/// rounded to the microsecond).
fn us(a: u64, b: u64) -> f64 {
    b.saturating_sub(a) as f64 / 1e3
}

/// Joins the flight process's trace with the HILSim's stamps: for each servo command, the
/// IMU packet written last before the driver read it, and the first servo packet read back
/// after it was written.
pub fn table(trace: &[StepStamps], hil: &HilStamps) -> StageTable {
    let mut samples: Vec<Vec<f64>> = vec![Vec::with_capacity(trace.len()); STAGES.len()];
    let mut unmatched = 0;
    for r in trace {
        // The trace's read stamp is rounded down to the microsecond.
        let imu = at_or_before(&hil.imu_written_ns, r.imu_read_ns.saturating_add(1_000))
            .filter(|&w| r.imu_read_ns.saturating_sub(w) < MATCH_NS);
        let servo = at_or_after(&hil.servo_read_ns, r.servo_written_ns)
            .filter(|&s| s - r.servo_written_ns < MATCH_NS);
        let (Some(imu), Some(servo)) = (imu, servo) else {
            unmatched += 1;
            continue;
        };
        let values = [
            us(imu, r.imu_read_ns),
            us(r.imu_read_ns, r.loop_woken_ns),
            us(r.loop_woken_ns, r.step_start_ns),
            us(r.step_start_ns, r.servo_written_ns),
            us(r.servo_written_ns, servo),
            us(imu, servo),
            us(r.step_start_ns, r.step_end_ns),
        ];
        for (s, v) in samples.iter_mut().zip(values) {
            s.push(v);
        }
    }
    StageTable {
        matched: trace.len() - unmatched,
        unmatched,
        stages: STAGES
            .iter()
            .zip(samples.iter_mut())
            .map(|(&(name, what), s)| Stage {
                name,
                what,
                us: Percentiles::of(s),
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamps(base: u64) -> StepStamps {
        StepStamps {
            imu_read_ns: base + 50_000,
            loop_woken_ns: base + 60_000,
            step_start_ns: base + 61_000,
            servo_written_ns: base + 90_000,
            step_end_ns: base + 120_000,
        }
    }

    #[test]
    fn each_command_is_joined_to_its_own_imu_write_and_servo_read() {
        // IMU packets every 10 ms, servo commands on every second one; the HILSim reads each
        // servo packet 40 µs after it was written.
        let period = 10_000_000;
        let hil = HilStamps {
            imu_written_ns: (0..10).map(|i| 1_000_000_000 + i * period).collect(),
            servo_read_ns: (0..5)
                .map(|i| 1_000_000_000 + 2 * i * period + 130_000)
                .collect(),
        };
        let trace: Vec<StepStamps> = (0..5)
            .map(|i| stamps(1_000_000_000 + 2 * i * period))
            .collect();
        let t = table(&trace, &hil);
        assert_eq!((t.matched, t.unmatched), (5, 0));
        let stage = |name: &str| t.stages.iter().find(|s| s.name == name).unwrap().us;
        assert_eq!(stage("imu_terminal").max, 50.0);
        assert_eq!(stage("hand_over").p50, 10.0);
        assert_eq!(stage("before_step").p50, 1.0);
        assert_eq!(stage("step_to_servo").p50, 29.0);
        assert_eq!(stage("servo_terminal").p50, 40.0);
        assert_eq!(stage("end_to_end").p50, 130.0);
        assert_eq!(stage("whole_step").p50, 59.0);
        // The stages up to the servo read add up to the whole.
        let sum: f64 = [
            "imu_terminal",
            "hand_over",
            "before_step",
            "step_to_servo",
            "servo_terminal",
        ]
        .iter()
        .map(|n| stage(n).p50)
        .sum();
        assert_eq!(sum, stage("end_to_end").p50);
    }

    #[test]
    fn a_command_with_no_write_or_read_near_it_is_counted_not_joined() {
        let hil = HilStamps {
            imu_written_ns: vec![1_000_000_000],
            servo_read_ns: vec![1_000_130_000],
        };
        // One before any IMU write, one whose servo packet was never read back.
        let trace = [
            stamps(900_000_000),
            stamps(1_000_000_000),
            stamps(2_000_000_000),
        ];
        let t = table(&trace, &hil);
        assert_eq!((t.matched, t.unmatched), (1, 2));
    }
}
