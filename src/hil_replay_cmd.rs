//! `heli hilsim --replay FLIGHT.mcap --ptys DIR`: a recorded flight's device inputs played
//! to a flight computer on the pseudo-terminals, and its servo commands compared with the
//! recorded ones (docs/architecture.md, "Replaying a recorded flight").

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow};
use heli_sim::replay::compare::{CHANNELS, Tolerance};
use heli_sim::replay::hil::{self as hil_replay, Recording, ReplayOptions};

/// Replays `flight`; exit 0 when the commands match, 1 when they differ.
pub fn replay(args: &crate::hilsim_cmd::HilsimArgs, flight: &Path) -> Result<ExitCode> {
    let bytes = std::fs::read(flight).with_context(|| format!("{}", flight.display()))?;
    let contents = heli_log::read(&bytes);
    let setup = heli_sim::replay::setup::setup_of(&contents)
        .with_context(|| format!("{}", flight.display()))?;
    let rec = Recording::from_log(&contents)
        .map_err(|e| anyhow!(e))
        .with_context(|| format!("{}", flight.display()))?;
    if !(args.wait_s.is_finite() && args.wait_s > 0.0) {
        anyhow::bail!(
            "--wait-s must be a positive number of seconds, not {}",
            args.wait_s
        );
    }
    // A lockstep flight names its scenario (whose plan the vehicle knows by that name); a
    // vehicle's flight names its plan.
    let flight_entry = |key: &str| {
        contents
            .metadata
            .iter()
            .filter(|m| m.name == heli_log::metadata::FLIGHT)
            .find_map(|m| m.entries.get(key).cloned())
    };
    let plan_name = flight_entry("plan")
        .or_else(|| flight_entry("scenario"))
        .unwrap_or_else(|| "(not recorded)".into());
    let stop = crate::hilsim_cmd::stop_on_signals()?;
    let options = ReplayOptions {
        speed: args.speed,
        wait_s: args.wait_s,
        tolerance: Tolerance {
            pulse_us: args.tolerance_us,
            share: args.tolerance_share,
            ..Tolerance::default()
        },
    };
    let report = hil_replay::run(&rec, &args.ptys, options, &stop, |devices| {
        let cal = devices.dir.join(heli_vehicle::compass_file::HIL_FILE_NAME);
        if let Err(e) = heli_vehicle::compass_file::write(&cal, &setup.config.compass) {
            eprintln!("heli hilsim: {e:#}");
        }
        println!(
            "hilsim: replaying {} ({:.1} s of device inputs, {} servo commands), {}x real time",
            flight.display(),
            rec.duration_s(),
            rec.servo.len(),
            args.speed
        );
        println!(
            "hilsim: recorded with calibration {} s, warm-up {} s, mode {}, plan {}: start the flight computer the same way",
            setup.config.calibration_s,
            setup.config.imu_warm_up_s,
            setup.params.mode.name(),
            plan_name
        );
        crate::hilsim_cmd::print_devices(devices, &cal);
    })
    .map_err(|e| anyhow!(e))?;
    let c = &report.comparison;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "played      {} device inputs over {:.1} s",
            report.inputs_played, report.played_s
        );
        println!(
            "compared    {} of {} recorded servo commands paired ({} sent), largest time offset {:.1} ms, {} on the other IMU samples",
            c.paired,
            c.recorded,
            c.replayed,
            c.max_offset_us as f64 * 1e-3,
            c.shifted
        );
        for (name, ch) in CHANNELS.iter().zip(&c.channels) {
            println!(
                "  {name:<10} largest difference {:>4} us at t={:.2} s, rms {:.2} us",
                ch.max_us, ch.at_s, ch.rms_us
            );
        }
        println!(
            "tolerance   {} us and {} ms; {} commands out of it ({:.2} %, {:.1} % allowed), first at {}",
            c.tolerance.pulse_us,
            c.tolerance.window_us / 1000,
            c.out_of_tolerance,
            100.0 * c.out_of_tolerance as f64 / (c.recorded.max(1)) as f64,
            100.0 * c.tolerance.share,
            c.first_difference_s
                .map_or("none".to_string(), |t| format!("t={t:.2} s"))
        );
        println!(
            "outcome     {}",
            if c.matches() {
                "MATCH: the flight software gives the recorded commands"
            } else if c.recorded == 0 {
                "NOTHING COMPARED: the log has no servo commands"
            } else {
                "DIFFERENT"
            }
        );
    }
    Ok(if c.matches() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
