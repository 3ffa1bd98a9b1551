//! What a run measured, and the JSON object `heli sim --json` prints.

use std::fmt::Write as _;

use serde::Serialize;

/// How the run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Every criterion passed.
    Pass,
    /// At least one criterion failed.
    Fail,
    /// The helicopter hit the ground too hard or rolled over.
    Crash,
}

/// One pass/fail criterion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Criterion {
    /// What is measured.
    pub name: String,
    /// Measured value; `None` (JSON `null`) when the run never measured it (a hold that
    /// never began, a recovery that never ended), which fails the criterion.
    pub value: Option<f64>,
    /// Limit it is held to.
    pub limit: f64,
    /// Whether it passed.
    pub pass: bool,
}

impl Criterion {
    /// A criterion that passes when `value <= limit`; unmeasured (`None`) fails.
    pub fn at_most(name: &str, value: impl Into<Option<f64>>, limit: f64) -> Self {
        let value = value.into().filter(|v| !v.is_nan());
        Self {
            name: name.into(),
            value,
            limit,
            pass: value.is_some_and(|v| v <= limit),
        }
    }

    /// A criterion that passes when `value >= limit`; unmeasured (`None`) fails.
    pub fn at_least(name: &str, value: impl Into<Option<f64>>, limit: f64) -> Self {
        let value = value.into().filter(|v| !v.is_nan());
        Self {
            name: name.into(),
            value,
            limit,
            pass: value.is_some_and(|v| v >= limit),
        }
    }
}

/// Estimator errors against simulator truth, over the flight after calibration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct EstimatorSummary {
    /// Attitude error RMS (deg); `null` when the estimator never ran.
    pub att_err_rms_deg: Option<f64>,
    /// Largest attitude error (deg).
    pub att_err_max_deg: Option<f64>,
    /// Position error RMS (m), relative navigation: displacement from where the estimate
    /// started, estimated against true.
    pub pos_err_rms_m: Option<f64>,
    /// Velocity error RMS (m/s).
    pub vel_err_rms_mps: Option<f64>,
    /// State estimates compared.
    pub samples: u64,
    /// GPS fixes fused / rejected.
    pub gps_fused: u32,
    /// GPS fixes rejected.
    pub gps_rejected: u32,
    /// Altimeter readings fused.
    pub baro_fused: u32,
    /// Compass readings fused.
    pub compass_fused: u32,
    /// The filter's health: the worst GPS innovation test ratio seen (1 is the gate).
    pub gps_test_ratio_max: Option<f64>,
    /// The longest time without a fused GPS fix once the estimate ran (s).
    pub longest_without_gps_s: Option<f64>,
}

/// The main loop's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LoopSummary {
    /// IMU packets the flight software received.
    pub imu_samples: u32,
    /// IMU packets the simulator dropped (fault injection).
    pub imu_dropped: u32,
    /// Watchdog firings (each repeated the last IMU packet).
    pub watchdog_fires: u32,
    /// 50 Hz control steps.
    pub control_steps: u32,
    /// Longest wall-clock time of one control step in this run (µs; not deterministic).
    pub step_time_max_us: f64,
}

/// Aerobatic maneuvers (none in a hover).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ManeuverSummary {
    /// Autonomous rolls completed.
    pub rolls_completed: u32,
    /// Altitude lost during the maneuver sequence (m): true altitude at its start minus the
    /// lowest true altitude before the recovery ended; `null` without a maneuver.
    pub altitude_loss_m: Option<f64>,
    /// Largest roll or pitch error when the recovery from the last roll ended, against the
    /// trim attitude the sequence began from (deg).
    pub recovery_attitude_deg: Option<f64>,
    /// Airspeed error when the recovery ended, against the airspeed the sequence began
    /// from (m/s).
    pub recovery_speed_error_mps: Option<f64>,
}

/// The position hold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct HoldSummary {
    /// When the hold began (s), if it did.
    pub start_s: Option<f64>,
    /// How long it was measured (s).
    pub duration_s: f64,
    /// Horizontal error RMS, estimate against target (m); `null` without a hold.
    pub horizontal_rms_m: Option<f64>,
    /// Altitude error RMS, estimate against target (m).
    pub altitude_rms_m: Option<f64>,
    /// Largest true distance from the target (m).
    pub true_max_m: Option<f64>,
    /// Mean true roll during the hold (deg): the trim against tail rotor and wind.
    pub mean_roll_deg: Option<f64>,
    /// Mean true pitch during the hold (deg).
    pub mean_pitch_deg: Option<f64>,
}

/// Byte-level health of one serial link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LinkSummary {
    /// Frames delivered.
    pub frames: u32,
    /// Frames dropped for a bad checksum.
    pub checksum_errors: u32,
    /// Framing errors.
    pub framing_errors: u32,
    /// Bytes discarded while hunting for a header.
    pub discarded_bytes: u32,
}

/// Serial links of the run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DeviceSummary {
    /// IMU → computer.
    pub imu: LinkSummary,
    /// Servo board → computer (pilot uplink).
    pub uplink: LinkSummary,
    /// Computer → servo board (servo commands).
    pub servo: LinkSummary,
    /// GPS → computer.
    pub gps: LinkSummary,
    /// Altimeter readings received.
    pub baro_readings: u32,
    /// Altimeter handshake state at the end.
    pub baro_link: String,
    /// Lowest flight-battery voltage read (V); `null` when never read.
    pub battery_min_v: Option<f64>,
}

/// The whole summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Seed of the run.
    pub seed: u64,
    /// Simulated time (s).
    pub sim_time_s: f64,
    /// Wall-clock time (s).
    pub wall_time_s: f64,
    /// Simulated seconds per wall-clock second.
    pub realtime_factor: f64,
    /// How it ended.
    pub outcome: Outcome,
    /// Why it crashed, if it did.
    pub crash: Option<String>,
    /// The criteria.
    pub criteria: Vec<Criterion>,
    /// Estimator errors against truth.
    pub estimator: EstimatorSummary,
    /// Main-loop counters.
    #[serde(rename = "loop")]
    pub loop_: LoopSummary,
    /// Maneuvers.
    pub maneuvers: ManeuverSummary,
    /// Position hold.
    pub hold: HoldSummary,
    /// Serial links.
    pub devices: DeviceSummary,
    /// Events the flight software reported, in order ("t=85.0 s calibration done", ...).
    pub events: Vec<String>,
    /// Flight log written, if any.
    pub log: Option<String>,
    /// The batteries: the truth against the flight software's gauges, the hot-swap.
    pub power: PowerSummary,
    /// The flight core's invariants, checked after every input.
    pub invariants: InvariantSummary,
    /// Hardware in the loop only: what the HILSim measured of the flight computer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hil: Option<HilSummary>,
}

/// What the invariants' checker found (`heli_fsw::invariants`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct InvariantSummary {
    /// Inputs checked.
    pub checked: u64,
    /// Inputs after which an invariant was broken.
    pub violations: u64,
    /// The first broken, with its time ("t=12.34 s: ...").
    pub first: Option<String>,
}

/// The batteries at the end of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PowerSummary {
    /// The flight pack's true charge at the end (fraction).
    pub flight_soc_end: f64,
    /// Its least true charge (fraction).
    pub flight_soc_min: Option<f64>,
    /// The flight software's gauge of it at the end (fraction).
    pub gauge_soc_end: Option<f64>,
    /// The gauge's time left at the end (s).
    pub gauge_time_left_s: Option<f64>,
    /// The true time left at the end, at the load then (s).
    pub true_time_left_s: f64,
    /// Largest error of the gauge's time left against the truth, once the gauge has had
    /// two minutes and while the truth has five minutes left (%).
    pub time_left_err_max_pct: Option<f64>,
    /// The last such error (%).
    pub time_left_err_end_pct: Option<f64>,
    /// The receiver and servo packs' true charge at the end (fraction).
    pub receiver_soc_end: f64,
    /// See [`PowerSummary::receiver_soc_end`].
    pub servo_soc_end: f64,
    /// Time on the flight batteries and on the ground battery, as the flight software
    /// logged them from the hot-swap's input (s).
    pub flight_s: f64,
    /// See [`PowerSummary::flight_s`].
    pub ground_s: f64,
}

/// What a HIL run measured of the flight computer outside.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct HilSummary {
    /// Servo packets received from the flight computer.
    pub servo_packets: u64,
    /// From writing the last byte of an IMU packet to its terminal until a whole servo
    /// packet could be read back from the servo board's terminal (µs): the flight
    /// computer's reaction time through its driver threads, loop and ports.
    pub latency_us: Percentiles,
    /// Device writes that found no reader (a terminal's buffer full).
    pub dropped_writes: u64,
    /// The HILSim's own timing: the latest any device write left after its due time (µs),
    /// a starved HILSim rather than a slow flight computer.
    pub write_late_max_us: f64,
    /// Device writes that left more than 1 ms after their due time.
    pub writes_late_over_1ms: u64,
    /// The stretches in which the HILSim's writes left more than
    /// [`crate::hil::STARVED`] late: the world stood still for the flight computer long
    /// enough for its IMU watchdog to call the IMU silent. A run with any (beyond a stall
    /// injected on purpose) measured the machine, not the flight computer.
    pub starved: Vec<Starved>,
    /// Each IMU packet's write and each servo packet's read, when the run was asked to keep
    /// them ([`crate::hil::HilOptions::stamps`]).
    #[serde(skip)]
    pub stamps: Option<HilStamps>,
}

/// A stretch of the run in which the HILSim was starved (its device writes left late).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Starved {
    /// Simulated time of the first write that left too late (s).
    pub from_s: f64,
    /// Simulated time of the last write in the stretch that left too late (s).
    pub to_s: f64,
    /// The latest any write of the stretch left (ms).
    pub late_ms: f64,
}

/// The HILSim's own stamps on `CLOCK_MONOTONIC` (ns), the clock the flight process's
/// latency trace uses (`heli_vehicle::latency`), in time order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HilStamps {
    /// When each IMU packet's write to its terminal began.
    pub imu_written_ns: Vec<u64>,
    /// When the read that completed each servo packet returned.
    pub servo_read_ns: Vec<u64>,
}

/// Percentiles of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Percentiles {
    /// How many.
    pub samples: usize,
    /// Median.
    pub p50: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest.
    pub max: f64,
}

impl Percentiles {
    /// The percentiles of `values` (sorted here; nearest rank).
    pub fn of(values: &mut [f64]) -> Self {
        values.sort_by(f64::total_cmp);
        let at = |q: f64| {
            if values.is_empty() {
                return 0.0;
            }
            let rank = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len());
            values[rank - 1]
        };
        Self {
            samples: values.len(),
            p50: at(0.5),
            p99: at(0.99),
            p999: at(0.999),
            max: values.last().copied().unwrap_or(0.0),
        }
    }
}

/// Running sum of squares for an RMS, with the maximum.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rms {
    sum_sq: f64,
    max: f64,
    n: u64,
}

impl Rms {
    /// Adds one value.
    pub fn add(&mut self, x: f64) {
        self.sum_sq += x * x;
        self.max = self.max.max(x.abs());
        self.n += 1;
    }

    /// Root mean square (0 if empty).
    pub fn rms(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            (self.sum_sq / self.n as f64).sqrt()
        }
    }

    /// Largest magnitude.
    pub fn max(&self) -> f64 {
        self.max
    }

    /// Root mean square, or `None` when nothing was measured.
    pub fn measured_rms(&self) -> Option<f64> {
        (self.n > 0).then(|| self.rms())
    }

    /// Largest magnitude, or `None` when nothing was measured.
    pub fn measured_max(&self) -> Option<f64> {
        (self.n > 0).then_some(self.max)
    }

    /// Number of values.
    pub fn count(&self) -> u64 {
        self.n
    }
}

/// A measured value with `decimals` decimals, or `-` when it was not measured.
pub fn shown(value: Option<f64>, decimals: usize) -> String {
    value.map_or_else(|| "-".to_string(), |v| format!("{v:.decimals$}"))
}

/// The summary as the table `heli sim` prints.
pub fn table(s: &Summary) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "scenario   {} (seed {})", s.scenario, s.seed);
    let _ = writeln!(
        out,
        "simulated  {:.1} s in {:.2} s wall time: {:.0}x real time",
        s.sim_time_s, s.wall_time_s, s.realtime_factor
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "{:<28} {:>10} {:>10}  result",
        "criterion", "value", "limit"
    );
    for c in &s.criteria {
        let _ = writeln!(
            out,
            "{:<28} {:>10} {:>10.3}  {}",
            c.name,
            shown(c.value, 3),
            c.limit,
            if c.pass { "pass" } else { "FAIL" }
        );
    }
    let _ = writeln!(out);
    if let Some(h) = &s.hil {
        // Hardware in the loop: the flight software is elsewhere; only what crossed the
        // wires is known here.
        let l = &h.latency_us;
        let _ = writeln!(
            out,
            "flight computer  {} servo packets; IMU written -> servo readable p50 {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us",
            h.servo_packets, l.p50, l.p99, l.p999, l.max
        );
        if h.dropped_writes > 0 {
            let _ = writeln!(
                out,
                "devices    {} writes found no reader",
                h.dropped_writes
            );
        }
        let _ = writeln!(
            out,
            "hilsim     its own writes: latest {:.1} ms after due, {} more than 1 ms late",
            h.write_late_max_us / 1e3,
            h.writes_late_over_1ms
        );
        for st in &h.starved {
            let _ = writeln!(
                out,
                "hilsim     STARVED t={:.2}..{:.2} s: writes up to {:.0} ms late (the flight computer saw the world stop)",
                st.from_s, st.to_s, st.late_ms
            );
        }
        let _ = writeln!(
            out,
            "battery    min {} V",
            shown(s.devices.battery_min_v, 2)
        );
    } else {
        let e = &s.estimator;
        let _ = writeln!(
            out,
            "estimator  attitude error rms {} deg (max {}), position rms {} m, velocity rms {} m/s",
            shown(e.att_err_rms_deg, 2),
            shown(e.att_err_max_deg, 2),
            shown(e.pos_err_rms_m, 2),
            shown(e.vel_err_rms_mps, 2)
        );
        let l = &s.loop_;
        let _ = writeln!(
            out,
            "main loop  {} IMU packets ({} dropped), {} watchdog fires, {} control steps, slowest step {:.0} us",
            l.imu_samples, l.imu_dropped, l.watchdog_fires, l.control_steps, l.step_time_max_us
        );
        let _ = writeln!(
            out,
            "links      imu {} frames / {} bad, uplink {} / {}, gps {} / {}, altimeter {} readings ({}), battery min {} V",
            s.devices.imu.frames,
            s.devices.imu.checksum_errors,
            s.devices.uplink.frames,
            s.devices.uplink.checksum_errors,
            s.devices.gps.frames,
            s.devices.gps.checksum_errors,
            s.devices.baro_readings,
            s.devices.baro_link,
            shown(s.devices.battery_min_v, 2)
        );
    }
    let watchdog_events = s
        .events
        .iter()
        .filter(|e| e.ends_with("watchdog fired"))
        .count();
    for event in s.events.iter().filter(|e| !e.ends_with("watchdog fired")) {
        let _ = writeln!(out, "event      {event}");
    }
    if watchdog_events > 0 {
        let _ = writeln!(
            out,
            "event      watchdog fired {watchdog_events} times (each listed in --json)"
        );
    }
    if let Some(crash) = &s.crash {
        let _ = writeln!(out, "CRASH      {crash}");
    }
    let _ = writeln!(out);
    let outcome = match s.outcome {
        Outcome::Pass => "PASS",
        Outcome::Fail => "FAIL",
        Outcome::Crash => "CRASH",
    };
    let _ = writeln!(out, "outcome    {outcome}");
    out
}
