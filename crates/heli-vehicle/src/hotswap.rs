//! The hot-swap's digital input (thesis §4.2.2): which battery powers the avionics, read
//! every [`HOTSWAP_PERIOD`] and handed to the control loop when it changes (and once at
//! start), so the flight core logs the time on the flight and ground batteries.
//!
//! Two kinds of line:
//! - a GPIO line through the Linux character device (`gpiochip0:17` or
//!   `/dev/gpiochip0:17`), requested as an input with the `gpiocdev` crate;
//! - a value file holding `0` or `1` (a sysfs `gpioN/value`, or the HILSim's `DIR/hotswap`).
//!
//! High (1) is the flight batteries, low (0) the ground battery.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::thread::JoinHandle;
use std::time::Duration;

use heli_fsw::RecordedInput;

pub use crate::devices::HotSwapLine;
use crate::error::VehicleError;
use crate::threads::{Clock, LoopMsg, sleep_unless_stopped};

/// How often the line is read.
pub const HOTSWAP_PERIOD: Duration = Duration::from_millis(100);

impl HotSwapLine {
    /// Reads the line once: `true` when high.
    pub fn read(&self) -> Result<bool, VehicleError> {
        LineReader::new(self.clone()).read()
    }
}

/// A line being read: a character-device line stays requested between reads.
pub struct LineReader {
    line: HotSwapLine,
    request: Option<gpiocdev::Request>,
}

impl LineReader {
    /// A reader of `line` (nothing is opened until the first read).
    pub fn new(line: HotSwapLine) -> Self {
        Self {
            line,
            request: None,
        }
    }

    /// Reads the line: `true` when high. A failed read gives the request up, to be made
    /// again next time.
    pub fn read(&mut self) -> Result<bool, VehicleError> {
        match &self.line {
            HotSwapLine::ValueFile(path) => {
                let text = std::fs::read_to_string(path)
                    .map_err(|e| VehicleError::file(path, e).within("hotswap"))?;
                parse_value(&text).ok_or_else(|| {
                    VehicleError::invalid(
                        format!("hotswap {}", path.display()),
                        format!("'{}' is not 0 or 1", text.trim()),
                    )
                })
            }
            HotSwapLine::Chip { chip, offset } => {
                let named = |source: gpiocdev::Error| VehicleError::Gpio {
                    line: format!("hotswap {}:{offset}", chip.display()),
                    source,
                };
                let request = match self.request.take() {
                    Some(r) => r,
                    None => gpiocdev::Request::builder()
                        .on_chip(chip)
                        .with_consumer("heli-hotswap")
                        .with_line(*offset)
                        .as_input()
                        .request()
                        .map_err(named)?,
                };
                let value = request.value(*offset).map_err(named)?;
                self.request = Some(request);
                Ok(on_flight_battery(value))
            }
        }
    }
}

/// A GPIO line's value as a level: active (after the line's polarity) is the flight
/// battery.
fn on_flight_battery(value: gpiocdev::line::Value) -> bool {
    value == gpiocdev::line::Value::Active
}

/// A value file's text as a level.
pub fn parse_value(text: &str) -> Option<bool> {
    match text.trim() {
        "1" => Some(true),
        "0" => Some(false),
        _ => None,
    }
}

/// Starts the hot-swap's reader: the level at start and each change go to the loop; a line
/// that cannot be read is noted once per failing spell (the flight goes on, its source
/// unknown).
pub fn spawn_hotswap(
    line: HotSwapLine,
    clock: Clock,
    tx: Sender<LoopMsg>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    crate::rt::thread("drv-hotswap", crate::rt::HELPER_STACK_BYTES).spawn(move || {
        let mut reader = LineReader::new(line);
        let mut last: Option<bool> = None;
        let mut failing = false;
        while !stop.load(Ordering::Acquire) {
            match reader.read() {
                Ok(high) => {
                    failing = false;
                    if last != Some(high) {
                        last = Some(high);
                        let input = LoopMsg::Input(clock.now_us(), RecordedInput::PowerLine(high));
                        if tx.send(input).is_err() {
                            return;
                        }
                    }
                }
                Err(e) => {
                    if !failing {
                        failing = true;
                        let _ = tx.send(LoopMsg::Note(e.to_string()));
                    }
                }
            }
            sleep_unless_stopped(HOTSWAP_PERIOD, &stop);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_active_line_is_the_flight_battery() {
        assert!(on_flight_battery(gpiocdev::line::Value::Active));
        assert!(!on_flight_battery(gpiocdev::line::Value::Inactive));
    }

    #[test]
    fn a_line_is_named_by_chip_and_offset_or_by_its_value_file() {
        assert_eq!(
            HotSwapLine::parse("gpiochip0:17").ok(),
            Some(HotSwapLine::Chip {
                chip: "/dev/gpiochip0".into(),
                offset: 17
            })
        );
        assert_eq!(
            HotSwapLine::parse("/dev/gpiochip2:5").ok(),
            Some(HotSwapLine::Chip {
                chip: "/dev/gpiochip2".into(),
                offset: 5
            })
        );
        assert_eq!(
            HotSwapLine::parse("/sys/class/gpio/gpio17/value").ok(),
            Some(HotSwapLine::ValueFile(
                "/sys/class/gpio/gpio17/value".into()
            ))
        );
        assert!(
            HotSwapLine::parse("gpiochip0:x")
                .unwrap_err()
                .to_string()
                .contains("'x'")
        );
        assert!(HotSwapLine::parse(" ").is_err());
    }

    #[test]
    fn a_value_file_reads_high_low_and_refuses_anything_else() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hotswap");
        let line = HotSwapLine::ValueFile(path.clone());
        assert!(line.read().unwrap_err().to_string().contains("hotswap"));
        std::fs::write(&path, "1\n").unwrap();
        assert_eq!(line.read().ok(), Some(true));
        std::fs::write(&path, "0").unwrap();
        assert_eq!(line.read().ok(), Some(false));
        std::fs::write(&path, "maybe").unwrap();
        assert!(line.read().unwrap_err().to_string().contains("not 0 or 1"));
    }

    #[test]
    fn a_chip_that_is_not_there_is_a_named_error() {
        let line = HotSwapLine::Chip {
            chip: "/dev/gpiochip-not-here".into(),
            offset: 3,
        };
        assert!(
            line.read()
                .unwrap_err()
                .to_string()
                .contains("gpiochip-not-here:3")
        );
    }
}
