//! `heli hilsim --replay FLIGHT.mcap --ptys DIR`: a recorded flight played back to a flight
//! computer, as the thesis's HILSim certification asks ("the system still accepts these
//! already-tested inputs despite changes to the flight software").
//!
//! The recorded device inputs — the bytes each serial port delivered, the compass's and the
//! battery's ADC readings — go onto the same pseudo-terminals and ADC files as
//! [`crate::hil`]'s, at their recorded times (times `speed`). Nothing is simulated: the
//! helicopter does not answer the new commands, so any difference in them comes from the
//! software. The flight computer's servo commands are read back from the servo board's
//! terminal and compared with the recorded ones ([`crate::replay::compare`]).
//!
//! The playback starts when the computer first writes to a device (its flight process
//! starting: the altimeter's handshake), lined up with the recorded flight's start.
//! Inputs the flight computer made itself (its timer ticks, a port failure, the ground
//! link's state) are not played.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use heli_fsw::RecordedInput;
use heli_log::LogContents;
use heli_log::inputs::{self, Logged};
use heli_proto::scb::{Controls, Pulses, ServoFramer, ServoPacket};
use heli_types::Port;

use super::log::ReplayError;
use crate::hil::{HilDevices, HilError, device, expose, spawn_readers, write_adc};
use crate::replay::compare::{Comparison, Tolerance, compare};

/// A recorded flight, as the replay needs it.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// When the recorded flight computer started (its clock, µs).
    pub start_us: u64,
    /// The device inputs, in time order.
    pub inputs: Vec<(u64, RecordedInput)>,
    /// The servo commands it sent, as pulse widths.
    pub servo: Vec<(u64, Pulses)>,
    /// When a new flight computer was started in place of the recorded one (a simulated
    /// brown-out's end, its clock, µs): the flight computer played to is not restarted by
    /// the playback, so its commands after it are not the recording's.
    pub restart_us: Option<u64>,
}

impl Recording {
    /// When the recorded flight's operator asked it to Stop (its clock, µs), if it was
    /// asked: the replay plays device inputs, not the operator, so the flight computer
    /// fed them flies on past it, and its commands after it are not the recording's.
    pub fn operator_stop_us(&self) -> Option<u64> {
        self.inputs
            .iter()
            .find(|(_, i)| matches!(i, RecordedInput::StopRequested))
            .map(|(t, _)| *t)
    }

    /// Where the comparison ends, if before the recording's end: the first of the
    /// operator's Stop and a recorded restart (the replay does neither).
    fn comparison_end_us(&self) -> Option<u64> {
        [self.operator_stop_us(), self.restart_us]
            .into_iter()
            .flatten()
            .min()
    }

    /// The recorded commands a replay played to `last_us` is compared with: from the
    /// start to the last input played, and not past the operator's Stop or a restart.
    fn compared(&self, last_us: u64) -> Vec<(u64, Pulses)> {
        let end_us = self
            .comparison_end_us()
            .map_or(last_us, |end| end.min(last_us));
        self.servo
            .iter()
            .copied()
            .filter(|(t, _)| *t >= self.start_us && *t < end_us.saturating_add(1))
            .collect()
    }
}

impl Recording {
    /// Reads the `device` and `servo` channels of a log. Errors name the message that is
    /// malformed, or say that the log has no device inputs.
    pub fn from_log(contents: &LogContents) -> Result<Self, ReplayError> {
        let mut rec = Recording::default();
        let mut started = None;
        let mut restarted = None;
        for m in &contents.messages {
            if m.topic == inputs::CHANNEL {
                match inputs::logged_from_json(&m.value).map_err(|why| ReplayError::BadInput {
                    t_s: m.t_us as f64 * 1e-6,
                    why: why.to_string(),
                })? {
                    Logged::Start => {
                        started.get_or_insert(m.t_us);
                    }
                    Logged::Restart { .. } => {
                        restarted.get_or_insert(m.t_us);
                    }
                    Logged::Input(input) => rec.inputs.push((m.t_us, input)),
                }
            } else if m.topic == "servo" {
                let field = |name: &str| {
                    m.value
                        .get(name)
                        .and_then(serde_json::Value::as_f64)
                        .ok_or_else(|| ReplayError::BadServo {
                            t_s: m.t_us as f64 * 1e-6,
                            field: name.to_string(),
                        })
                };
                let controls = Controls {
                    aileron: field("aileron")?,
                    elevator: field("elevator")?,
                    rudder: field("rudder")?,
                    collective: field("collective")?,
                    throttle: field("throttle")?,
                };
                rec.servo.push((m.t_us, Pulses::from_controls(&controls)));
            }
        }
        if rec.inputs.is_empty() {
            return Err(ReplayError::NoInputs);
        }
        rec.inputs.sort_by_key(|(t, _)| *t);
        rec.servo.sort_by_key(|(t, _)| *t);
        rec.start_us = started.unwrap_or_else(|| rec.inputs.first().map_or(0, |(t, _)| *t));
        rec.restart_us = restarted;
        Ok(rec)
    }

    /// Seconds of recorded inputs.
    pub fn duration_s(&self) -> f64 {
        self.inputs
            .last()
            .map_or(0.0, |(t, _)| t.saturating_sub(self.start_us) as f64 * 1e-6)
    }
}

/// How to replay.
#[derive(Clone, Copy, Debug)]
pub struct ReplayOptions {
    /// Recorded seconds per wall-clock second (the flight computer's clock must run as fast).
    pub speed: f64,
    /// How long to wait for a flight computer to start (s).
    pub wait_s: f64,
    /// What counts as the same command.
    pub tolerance: Tolerance,
}

/// What a replay found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReplayReport {
    /// Device inputs played.
    pub inputs_played: usize,
    /// Writes that found no reader.
    pub dropped_writes: u64,
    /// Seconds of recorded flight played.
    pub played_s: f64,
    /// Seconds into the recorded flight at which its operator asked it to Stop, if it did:
    /// the commands are compared up to it (the replay does not press Stop).
    pub operator_stop_s: Option<f64>,
    /// Seconds into the recorded flight at which a new flight computer was started in place
    /// of the recorded one (a simulated brown-out's end), if one was: the commands are
    /// compared up to it (the replay does not restart the flight computer played to).
    pub restart_s: Option<f64>,
    /// The servo commands compared.
    pub comparison: Comparison,
}

/// The whole servo packets in `bytes` the computer wrote on `port` (only the servo board's
/// carries them), each at `t_us`.
fn servo_commands(
    framer: &mut ServoFramer,
    port: Port,
    bytes: &[u8],
    t_us: u64,
    out: &mut Vec<(u64, Pulses)>,
) {
    if port != Port::Scb {
        return;
    }
    for &b in bytes {
        if let Some(packet) = framer.push(b).and_then(|f| ServoPacket::parse(f).ok()) {
            out.push((t_us, packet.pulses));
        }
    }
}

/// The ADC files and the power line hold the recorded flight's first readings before the
/// flight computer starts: it reads them as it starts, as the recorded one read the
/// HILSim's. Files of zeros gave it a 0 V battery and a compass of no field that the
/// recorded computer never saw (a battery reading refused, a heading moved in the
/// calibration: a different flight).
fn seed_files(rec: &Recording, devices: &HilDevices) -> Result<(), HilError> {
    let (mut compass, mut battery, mut line) = (None, None, None);
    for (_, input) in &rec.inputs {
        match input {
            RecordedInput::Compass(adc) => compass = compass.or(Some(adc.counts)),
            RecordedInput::Battery(adc) => battery = battery.or(Some(adc.counts)),
            RecordedInput::PowerLine(high) => line = line.or(Some(*high)),
            _ => {}
        }
    }
    for (channel, counts) in (0u8..).zip(compass.unwrap_or([0; 3])) {
        write_adc(&devices.adc, channel, counts).map_err(device("writing an ADC file"))?;
    }
    write_adc(
        &devices.adc,
        crate::lockstep::HIL_BATTERY_CHANNEL,
        battery.unwrap_or(0),
    )
    .map_err(device("writing an ADC file"))?;
    if let Some(high) = line {
        crate::hil::write_line(&devices.hotswap, high)
            .map_err(device("writing the power line file"))?;
    }
    Ok(())
}

/// Plays `rec` on the devices under `dir` to a flight computer, until the inputs end or
/// `stop` is set; `ready` is called once the devices exist.
pub fn run(
    rec: &Recording,
    dir: &Path,
    options: ReplayOptions,
    stop: &Arc<AtomicBool>,
    ready: impl FnOnce(&HilDevices),
) -> Result<ReplayReport, HilError> {
    if !(options.speed.is_finite() && options.speed > 0.0 && options.speed <= 100.0) {
        return Err(HilError::Speed(options.speed));
    }
    let (mut ptys, devices) = expose(dir)?;
    let from_computer = spawn_readers(&ptys, stop, None)?;
    seed_files(rec, &devices)?;
    ready(&devices);

    // Wait for the flight computer to start.
    let waited = Instant::now();
    let mut framer = ServoFramer::new();
    let mut replayed = Vec::new();
    let t0 = loop {
        if stop.load(Ordering::Acquire) {
            return Err(HilError::Stopped);
        }
        match from_computer.recv_timeout(Duration::from_millis(50)) {
            Ok((port, bytes, at)) => {
                // A command this early is compared like any other (at time zero).
                servo_commands(&mut framer, port, &bytes, rec.start_us, &mut replayed);
                break at;
            }
            Err(_) if waited.elapsed().as_secs_f64() > options.wait_s => {
                return Err(HilError::NoComputer(options.wait_s));
            }
            Err(_) => {}
        }
    };
    let recorded_time = |at: Instant| {
        rec.start_us + (at.saturating_duration_since(t0).as_secs_f64() * options.speed * 1e6) as u64
    };
    let wall_of = |t_us: u64| {
        t0 + Duration::from_secs_f64(
            t_us.saturating_sub(rec.start_us) as f64 * 1e-6 / options.speed,
        )
    };
    let collect = |framer: &mut ServoFramer, replayed: &mut Vec<(u64, Pulses)>| {
        while let Ok((port, bytes, at)) = from_computer.try_recv() {
            servo_commands(framer, port, &bytes, recorded_time(at), replayed);
        }
    };
    let mut played = 0usize;
    let mut dropped = 0u64;
    let mut last_t = rec.start_us;
    for (t_us, input) in &rec.inputs {
        if stop.load(Ordering::Acquire) {
            break;
        }
        if let Some(wait) = wall_of(*t_us).checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        collect(&mut framer, &mut replayed);
        let written = match input {
            RecordedInput::Bytes(port, bytes) => ptys
                .iter_mut()
                .find(|p| p.port == *port)
                .map(|p| p.master.write_all(bytes).is_ok()),
            RecordedInput::Compass(adc) => Some(
                adc.counts
                    .iter()
                    .zip(0u8..)
                    .all(|(counts, channel)| write_adc(&devices.adc, channel, *counts).is_ok()),
            ),
            RecordedInput::Battery(adc) => Some(
                write_adc(
                    &devices.adc,
                    crate::lockstep::HIL_BATTERY_CHANNEL,
                    adc.counts,
                )
                .is_ok(),
            ),
            RecordedInput::PowerLine(high) => {
                Some(crate::hil::write_line(&devices.hotswap, *high).is_ok())
            }
            RecordedInput::PortFailed(_)
            | RecordedInput::Tick
            | RecordedInput::GroundLink(_)
            | RecordedInput::StopRequested => None,
        };
        match written {
            Some(true) => played += 1,
            Some(false) => dropped += 1,
            None => {}
        }
        last_t = *t_us;
    }
    // The commands answering the last inputs.
    let tail = Instant::now() + Duration::from_secs_f64(0.2 / options.speed);
    while Instant::now() < tail {
        std::thread::sleep(Duration::from_millis(5));
        collect(&mut framer, &mut replayed);
    }
    let window = rec.compared(last_t);
    // The replayed computer's commands past the operator's Stop, or a recorded restart, are
    // not compared either.
    if let Some(end_us) = rec.comparison_end_us() {
        replayed.retain(|(t, _)| *t <= end_us);
    }
    Ok(ReplayReport {
        inputs_played: played,
        dropped_writes: dropped,
        played_s: last_t.saturating_sub(rec.start_us) as f64 * 1e-6,
        operator_stop_s: rec
            .operator_stop_us()
            .map(|t| t.saturating_sub(rec.start_us) as f64 * 1e-6),
        restart_s: rec
            .restart_us
            .map(|t| t.saturating_sub(rec.start_us) as f64 * 1e-6),
        comparison: compare(&window, &replayed, options.tolerance),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use heli_proto::battery::BatteryAdc;
    use heli_proto::compass::CompassAdc;

    #[test]
    fn the_commands_are_compared_up_to_the_operator_s_stop_and_the_last_input_played() {
        let command = Pulses::from_controls(&Controls::default());
        let mut rec = Recording {
            start_us: 100,
            inputs: vec![
                (150, RecordedInput::Tick),
                (300, RecordedInput::StopRequested),
                (400, RecordedInput::StopRequested),
            ],
            servo: [50, 100, 200, 300, 301, 500]
                .into_iter()
                .map(|t| (t, command))
                .collect(),
            restart_us: None,
        };
        let times = |v: Vec<(u64, Pulses)>| v.into_iter().map(|(t, _)| t).collect::<Vec<_>>();
        assert_eq!(rec.operator_stop_us(), Some(300), "the first Stop");
        assert_eq!(times(rec.compared(600)), [100, 200, 300]);
        assert_eq!(
            times(rec.compared(200)),
            [100, 200],
            "not past the inputs played"
        );
        rec.inputs
            .retain(|(_, i)| !matches!(i, RecordedInput::StopRequested));
        assert_eq!(rec.operator_stop_us(), None);
        assert_eq!(times(rec.compared(600)), [100, 200, 300, 301, 500]);
        // A new flight computer in the recording: the one played to is not restarted.
        rec.restart_us = Some(301);
        assert_eq!(times(rec.compared(600)), [100, 200, 300, 301]);
        rec.inputs.push((250, RecordedInput::StopRequested));
        assert_eq!(
            times(rec.compared(600)),
            [100, 200],
            "the earlier of the two"
        );
    }

    #[test]
    fn the_files_hold_the_recorded_first_readings_before_the_computer_starts() {
        let dir = std::env::temp_dir().join(format!("heli-replay-seed-{}", std::process::id()));
        let adc = dir.join("adc");
        std::fs::create_dir_all(&adc).unwrap();
        let devices = HilDevices {
            dir: dir.clone(),
            ports: Vec::new(),
            adc: adc.clone(),
            hotswap: dir.join("hotswap"),
        };
        let rec = Recording {
            start_us: 0,
            inputs: vec![
                (10, RecordedInput::Bytes(Port::Imu, vec![0x55])),
                (20, RecordedInput::PowerLine(true)),
                (30, RecordedInput::Battery(BatteryAdc { counts: 3518 })),
                (
                    40,
                    RecordedInput::Compass(CompassAdc {
                        counts: [2255, 2015, 2515],
                    }),
                ),
                (50, RecordedInput::Battery(BatteryAdc { counts: 3000 })),
                (60, RecordedInput::PowerLine(false)),
            ],
            servo: Vec::new(),
            restart_us: None,
        };
        seed_files(&rec, &devices).unwrap();
        let read = |name: &str| std::fs::read_to_string(adc.join(name)).unwrap();
        assert_eq!(read("in_voltage0_raw"), "2255\n");
        assert_eq!(read("in_voltage1_raw"), "2015\n");
        assert_eq!(read("in_voltage2_raw"), "2515\n");
        assert_eq!(read("in_voltage3_raw"), "3518\n", "the first, not the last");
        assert_eq!(std::fs::read_to_string(&devices.hotswap).unwrap(), "1\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
