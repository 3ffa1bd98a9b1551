//! Simulated servo controller board: reads the pilot's receiver and reports it (with rotor
//! rpm, the switches and its batteries) at 50 Hz; reads the computer's servo command packets
//! and drives the servos with them. With the emergency bypass switch engaged it drives the
//! servos with the pilot's commands directly.
//!
//! The board has a watchdog of its own on the computer's commands (as PX4's I/O processor
//! does on its flight management unit): it holds the last command for
//! [`COMPUTER_SILENT_US`], then gives every servo to the pilot until the computer speaks
//! again — a computer that browns out or hangs does not leave the servos frozen.

use heli_proto::framer::FramerStats;
use heli_proto::scb::{Controls, PilotUplink, Pulses, ServoFramer, ServoPacket};

use super::Bytes;

/// What the pilot's transmitter sends (normalised sticks and switches).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PilotCommand {
    /// Sticks.
    pub sticks: Controls,
    /// Auto switch on.
    pub auto_mode: bool,
    /// Emergency bypass switch engaged.
    pub bypass: bool,
    /// Transmitter signal lost: the receiver commands every channel to zero.
    pub signal_lost: bool,
}

/// How long the board holds the computer's last command after the computer fell silent
/// before it passes the pilot through (µs).
pub const COMPUTER_SILENT_US: u64 = 1_000_000;

/// The simulated board.
#[derive(Clone, Debug)]
pub struct ScbDevice {
    framer: ServoFramer,
    computer: Option<Controls>,
    /// When the last command from the computer came (µs).
    computer_at_us: u64,
    /// Check bytes seen in a row.
    check_run: usize,
    /// The computer's start-up check was received and wants an answer.
    check_due: bool,
    /// Start-up checks answered.
    pub checks_answered: u32,
    /// Receiver battery (V).
    pub receiver_batt_v: f64,
    /// Servo battery (V).
    pub servo_batt_v: f64,
}

impl Default for ScbDevice {
    fn default() -> Self {
        Self {
            framer: ServoFramer::new(),
            computer: None,
            computer_at_us: 0,
            check_run: 0,
            check_due: false,
            checks_answered: 0,
            receiver_batt_v: 4.9,
            servo_batt_v: 4.9,
        }
    }
}

impl ScbDevice {
    /// The uplink packet for the pilot's command and the rotor speed.
    pub fn uplink(&self, pilot: &PilotCommand, rotor_rpm: f64) -> Bytes {
        let pulses = if pilot.signal_lost {
            Pulses::default()
        } else {
            Pulses::from_controls(&pilot.sticks)
        };
        let repr = PilotUplink {
            rotor_rpm: rotor_rpm.round().clamp(0.0, f64::from(u16::MAX)) as u16,
            pulses,
            auto_mode: pilot.auto_mode,
            bypass: pilot.bypass,
            receiver_batt_v: self.receiver_batt_v,
            servo_batt_v: self.servo_batt_v,
        };
        Bytes::encode(|buf| repr.emit(buf))
    }

    /// Bytes from the flight computer's port, arriving at `now_us`.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) {
        for &b in bytes {
            if b == heli_proto::scb::CHECK_BYTE {
                self.check_run += 1;
                if self.check_run == heli_proto::scb::CHECK_LEN {
                    self.check_due = true;
                    self.check_run = 0;
                }
            } else {
                self.check_run = 0;
            }
            if let Some(frame) = self.framer.push(b)
                && let Ok(packet) = ServoPacket::parse(frame)
            {
                self.computer = Some(packet.pulses.to_controls());
                self.computer_at_us = now_us;
            }
        }
    }

    /// True (once) when the computer's start-up check came in and must be answered with an
    /// uplink packet at once.
    pub fn take_check(&mut self) -> bool {
        let due = std::mem::take(&mut self.check_due);
        if due {
            self.checks_answered += 1;
        }
        due
    }

    /// What the servos are driven with at `now_us`: the computer's last command; in bypass
    /// the pilot's, but for the tail; the pilot's before the computer has said anything and
    /// once it has been silent for [`COMPUTER_SILENT_US`].
    pub fn servo_commands(&self, pilot: &PilotCommand, now_us: u64) -> Controls {
        let computer = self
            .computer
            .filter(|_| now_us.saturating_sub(self.computer_at_us) <= COMPUTER_SILENT_US);
        match (pilot.bypass, computer) {
            (false, Some(c)) => c,
            // Bypass: the pilot drives the servos directly, except the tail, which keeps the
            // computer's yaw-rate feedback (thesis §2.2.3).
            (true, Some(c)) => Controls {
                rudder: c.rudder,
                ..pilot.sticks
            },
            (_, None) => pilot.sticks,
        }
    }

    /// Framer counters of the servo-command direction.
    pub fn stats(&self) -> FramerStats {
        self.framer.stats()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_start_up_check_is_answered_once_and_commands_never_look_like_it() {
        let mut board = ScbDevice::default();
        // Servo commands at every extreme: no two zero bytes in a row, so no answer.
        for v in [-1.0, 0.0, 1.0] {
            let c = Controls {
                aileron: v,
                elevator: v,
                rudder: v,
                collective: v,
                throttle: (v + 1.0) / 2.0,
            };
            let mut buf = [0u8; heli_proto::scb::SERVO_LEN];
            let n = heli_proto::scb::ServoPacket {
                pulses: Pulses::from_controls(&c),
            }
            .emit(&mut buf)
            .unwrap_or(0);
            board.receive(&buf[..n], 0);
        }
        assert!(!board.take_check());
        board.receive(
            &[heli_proto::scb::CHECK_BYTE; heli_proto::scb::CHECK_LEN - 1],
            0,
        );
        assert!(!board.take_check(), "eight zeros are not the check");
        board.receive(&[heli_proto::scb::CHECK_BYTE], 0);
        assert!(board.take_check());
        assert!(!board.take_check(), "answered once");
        assert_eq!(board.checks_answered, 1);
    }

    #[test]
    fn bypass_gives_the_pilot_the_servos_but_keeps_the_computer_tail() {
        let mut board = ScbDevice::default();
        let computer = Controls {
            aileron: 0.1,
            elevator: 0.1,
            rudder: 0.45,
            collective: 0.5,
            throttle: 0.8,
        };
        let packet = heli_proto::scb::ServoPacket {
            pulses: Pulses::from_controls(&computer),
        };
        board.receive(Bytes::encode(|buf| packet.emit(buf)).as_slice(), 0);
        let sticks = Controls {
            aileron: -0.3,
            elevator: 0.2,
            rudder: -0.2,
            collective: 0.6,
            throttle: 0.8,
        };
        let pilot = PilotCommand {
            sticks,
            auto_mode: false,
            bypass: true,
            signal_lost: false,
        };
        let out = board.servo_commands(&pilot, 0);
        assert!((out.aileron + 0.3).abs() < 0.01 && (out.collective - 0.6).abs() < 0.01);
        assert!(
            (out.rudder - 0.45).abs() < 0.01,
            "the tail stays with the computer: {out:?}"
        );
        let normal = PilotCommand {
            bypass: false,
            ..pilot
        };
        assert!((board.servo_commands(&normal, 0).aileron - 0.1).abs() < 0.01);
        // The computer silent: held for a second, then the pilot has every servo.
        let held = board.servo_commands(&normal, COMPUTER_SILENT_US);
        assert!((held.aileron - 0.1).abs() < 0.01);
        let given_up = board.servo_commands(&normal, COMPUTER_SILENT_US + 1);
        assert!((given_up.aileron + 0.3).abs() < 0.01 && (given_up.rudder + 0.2).abs() < 0.01);
    }
}
