//! `heli bench`: the project's performance numbers, measured on this machine — parser
//! throughput, control-step latency, lockstep real-time factor, memory. Wall-clock numbers:
//! for the record (docs/BENCHMARKS.md), never for pass/fail.

use std::time::{Duration, Instant};

use heli_fsw::drivers::{gps_driver, imu_driver, uplink_driver};
use heli_proto::gps::{FixType, GpsNav};
use heli_proto::imu::ImuRepr;
use heli_proto::scb::{Controls, PilotUplink, Pulses};
use serde::Serialize;

use crate::devices::Bytes;
use crate::lockstep::{RunOptions, Simulation};
use heli_scenario as scenario;

pub mod hil;
pub mod stages;

/// Throughput of one device parser.
#[derive(Clone, Debug, Serialize)]
pub struct ParserBench {
    /// Device.
    pub device: String,
    /// Bytes parsed.
    pub bytes: u64,
    /// Frames delivered.
    pub frames: u64,
    /// Megabytes per second.
    pub mb_per_s: f64,
}

/// Control-step wall time over a whole flight.
#[derive(Clone, Debug, Serialize)]
pub struct StepBench {
    /// Steps timed.
    pub steps: usize,
    /// Median (µs).
    pub median_us: f64,
    /// 99th percentile (µs).
    pub p99_us: f64,
    /// Slowest (µs).
    pub max_us: f64,
}

/// Everything `heli bench` measures.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Parser throughput.
    pub parsers: Vec<ParserBench>,
    /// Control-step latency in the `hover` scenario.
    pub control_step: StepBench,
    /// Simulated seconds per wall-clock second, `hover` and `demo`.
    pub realtime_factor: Vec<(String, f64)>,
    /// Peak resident memory of this process (MiB), if the OS says.
    pub peak_rss_mib: Option<f64>,
}

fn throughput(device: &str, frame: &Bytes, mut parse: impl FnMut(&[u8]) -> u64) -> ParserBench {
    let mut stream = Vec::with_capacity(8 << 20);
    while stream.len() < 8 << 20 {
        stream.extend_from_slice(frame.as_slice());
    }
    let start = Instant::now();
    let frames = parse(&stream);
    let secs = start.elapsed().as_secs_f64().max(1e-9);
    ParserBench {
        device: device.into(),
        bytes: stream.len() as u64,
        frames,
        mb_per_s: stream.len() as f64 / secs / 1e6,
    }
}

fn percentile(sorted: &[Duration], q: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * q).round() as usize;
    sorted.get(i).map_or(0.0, |d| d.as_secs_f64() * 1e6)
}

fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Runs every measurement.
pub fn run() -> BenchReport {
    let imu = ImuRepr {
        rate_rps: [0.1, -0.2, 0.3],
        accel_mps2: [0.5, -0.4, -9.8],
        temp_c: 25.0,
    };
    let uplink = PilotUplink {
        rotor_rpm: 1600,
        pulses: Pulses::from_controls(&Controls {
            throttle: 0.8,
            ..Controls::default()
        }),
        auto_mode: true,
        bypass: false,
        receiver_batt_v: 5.1,
        servo_batt_v: 5.1,
    };
    let gps = GpsNav {
        tow_ms: 1000,
        lat_deg: 42.36,
        lon_deg: -71.09,
        alt_m: 10.0,
        vel_ned_mps: [1.0, 2.0, 0.1],
        satellites: 8,
        fix: FixType::Fix3D,
    };
    let parsers = vec![
        throughput("imu", &Bytes::encode(|b| imu.emit(b)), |s| {
            let mut n = 0;
            imu_driver().receive(s, |_| n += 1);
            n
        }),
        throughput("uplink", &Bytes::encode(|b| uplink.emit(b)), |s| {
            let mut n = 0;
            uplink_driver().receive(s, |_| n += 1);
            n
        }),
        throughput("gps", &Bytes::encode(|b| gps.emit(b)), |s| {
            let mut n = 0;
            gps_driver().receive(s, |_| n += 1);
            n
        }),
    ];

    let mut hover =
        Simulation::new(scenario::hover()).unwrap_or_else(|e| panic!("built-in scenario: {e}"));
    hover.time_control_steps();
    let end = (scenario::hover().duration_s * 1e6) as u64;
    let wall = Instant::now();
    while hover.advance(end) {}
    let hover_rtf = hover.now_us() as f64 * 1e-6 / wall.elapsed().as_secs_f64().max(1e-9);
    let mut times = hover.control_step_times().to_vec();
    times.sort();
    let control_step = StepBench {
        steps: times.len(),
        median_us: percentile(&times, 0.5),
        p99_us: percentile(&times, 0.99),
        max_us: percentile(&times, 1.0),
    };
    let demo = Simulation::new(scenario::demo())
        .unwrap_or_else(|e| panic!("built-in scenario: {e}"))
        .run(RunOptions::default(), |_, _| {});
    BenchReport {
        parsers,
        control_step,
        realtime_factor: vec![
            ("hover".into(), hover_rtf),
            ("demo".into(), demo.realtime_factor),
        ],
        peak_rss_mib: peak_rss_mib(),
    }
}

/// Prints the report as `heli bench` does.
pub fn print(report: &BenchReport) {
    println!("parsers (8 MB of back-to-back frames through the flight software's drivers)");
    for p in &report.parsers {
        println!(
            "  {:<8} {:>8.1} MB/s  ({} frames)",
            p.device, p.mb_per_s, p.frames
        );
    }
    let c = &report.control_step;
    println!(
        "control step (hover, {} steps with the estimator running): median {:.1} us, p99 {:.1} us, max {:.1} us (budget 20 000 us)",
        c.steps, c.median_us, c.p99_us, c.max_us
    );
    for (name, rtf) in &report.realtime_factor {
        println!("lockstep {name:<6} {rtf:.0}x real time");
    }
    if let Some(mib) = report.peak_rss_mib {
        println!("peak memory {mib:.1} MiB");
    }
}
