//! The vehicle's handling of what the ground asks: the thesis's commands (Connect, Start
//! Logging, Stop) answered at once as under way and finally as done or failed, each with a
//! status text; retries answered again, never carried out twice; a Connect refused while a
//! flight is under way; message intervals and parameters set or refused with the reason.

use super::*;

/// The vehicle's `AUTOPILOT_VERSION`: MAVLink 2, parameter values as C casts to float, the mission protocol
/// with integer positions; the software's version (this crate's) as MAVLink encodes it
/// (major, minor, patch, and the type: development).
pub fn autopilot_version() -> MavMessage {
    let number = |s: &str| s.parse::<u32>().unwrap_or(0) & 0xff;
    let version = env!("CARGO_PKG_VERSION_MAJOR").parse::<u32>().unwrap_or(0) << 24
        | number(env!("CARGO_PKG_VERSION_MINOR")) << 16
        | number(env!("CARGO_PKG_VERSION_PATCH")) << 8;
    MavMessage::AUTOPILOT_VERSION(AUTOPILOT_VERSION_DATA {
        capabilities: MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
            | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
            | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT,
        flight_sw_version: version,
        ..Default::default()
    })
}

/// `MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES`: superseded by `REQUEST_MESSAGE`, but ground
/// stations still send it.
#[allow(deprecated)]
fn asks_capabilities(command: MavCmd) -> bool {
    command == MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
}

impl VehicleLink {
    /// A COMMAND_LONG addressed to this vehicle: answered, refused or handed to the bootstrap.
    pub(super) fn command(
        &mut self,
        cmd: &COMMAND_LONG_DATA,
        now_us: u64,
        events: &mut Vec<LinkEvent>,
    ) {
        // Who it is and what it speaks, as QGroundControl and MAVSDK ask at connection.
        let version_asked = asks_capabilities(cmd.command)
            || (cmd.command == MavCmd::MAV_CMD_REQUEST_MESSAGE
                && cmd.param1 == AUTOPILOT_VERSION_DATA::ID as f32);
        if version_asked {
            self.ack(cmd.command, MavResult::MAV_RESULT_ACCEPTED, now_us);
            self.send(&autopilot_version(), now_us);
            return;
        }
        if cmd.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL {
            let result = match self.set_interval(cmd.param1, cmd.param2) {
                Ok(()) => MavResult::MAV_RESULT_ACCEPTED,
                Err(why) => {
                    self.status_text(
                        MavSeverity::MAV_SEVERITY_ERROR,
                        &format!("message interval refused: {why}"),
                        now_us,
                    );
                    MavResult::MAV_RESULT_DENIED
                }
            };
            self.ack(cmd.command, result, now_us);
            return;
        }
        match ground_command(cmd) {
            Ok(command) => {
                // A retry of a command under way, or of one just answered (its ack was
                // lost), is answered again, never carried out twice.
                if self.pending == Some(cmd.command) {
                    self.ack(cmd.command, MavResult::MAV_RESULT_IN_PROGRESS, now_us);
                    return;
                }
                let answered = self.last_result.filter(|(c, _, at)| {
                    *c == cmd.command && now_us.saturating_sub(*at) < RESULT_KEPT_US
                });
                if let Some((_, result, _)) = answered.filter(|_| cmd.confirmation > 0) {
                    self.ack(cmd.command, result, now_us);
                    return;
                }
                // Connect starts a fresh flight process and kills a running one: over the
                // link, never while a flight is under way.
                let flying = matches!(
                    self.status.state,
                    BootstrapState::Starting | BootstrapState::Flying | BootstrapState::Stopping
                );
                if command == GroundCommand::Connect && flying {
                    self.status_text(
                        MavSeverity::MAV_SEVERITY_ERROR,
                        "connect refused: a flight is under way (stop it first)",
                        now_us,
                    );
                    self.ack(cmd.command, MavResult::MAV_RESULT_DENIED, now_us);
                    return;
                }
                // These take time (a process starts or stops): say so at once.
                self.ack(cmd.command, MavResult::MAV_RESULT_IN_PROGRESS, now_us);
                self.pending = Some(cmd.command);
                events.push(LinkEvent::Command {
                    token: CommandToken {
                        command: cmd.command,
                    },
                    command,
                });
            }
            Err(crate::command::CommandError::Unsupported(_)) => {
                self.ack(cmd.command, MavResult::MAV_RESULT_UNSUPPORTED, now_us);
            }
            Err(e) => {
                self.status_text(
                    MavSeverity::MAV_SEVERITY_ERROR,
                    &format!("command refused: {e}"),
                    now_us,
                );
                self.ack(cmd.command, MavResult::MAV_RESULT_DENIED, now_us);
            }
        }
    }

    /// A PARAM_SET: the value kept (or the reason it was refused), and the table's value sent back.
    pub(super) fn param_set(
        &mut self,
        name: &str,
        value: f32,
        now_us: u64,
        events: &mut Vec<LinkEvent>,
    ) {
        match self.params.set(name, value) {
            Ok(()) => events.push(LinkEvent::ParamSet {
                table_text: self.params.to_text(),
            }),
            Err(e) => self.status_text(MavSeverity::MAV_SEVERITY_ERROR, &e.to_string(), now_us),
        }
        // The value kept, changed or not, as the protocol asks.
        if let Some(m) = self.params.value_message_named(name) {
            self.send(&m, now_us);
        }
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL for one telemetry message (µs; −1 off, 0 the default);
    /// `Err` says why it is refused.
    fn set_interval(&mut self, message_id: f32, interval_us: f32) -> Result<(), String> {
        let id = message_id as u32;
        if !self.intervals.contains_key(&id) || !message_id.is_finite() || message_id.fract() != 0.0
        {
            return Err(format!(
                "message {message_id} is not one of the telemetry's ({})",
                telemetry::TELEMETRY_MESSAGES
                    .iter()
                    .map(u32::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let interval = if (interval_us + 1.0).abs() < 0.5 {
            None
        } else if interval_us.abs() < 0.5 {
            Some(DEFAULT_INTERVAL_US)
        } else if interval_us.is_finite() && interval_us >= 10_000.0 {
            Some(interval_us as u64)
        } else {
            // Faster than 100 Hz is more than the telemetry has.
            return Err(format!(
                "interval {interval_us} us for message {id}: -1 (off), 0 (the default) or 10000 us (100 Hz) and more"
            ));
        };
        self.intervals.insert(id, interval);
        self.next_due.remove(&id);
        Ok(())
    }

    /// A COMMAND_ACK for `command`.
    fn ack(&mut self, command: MavCmd, result: MavResult, now_us: u64) {
        self.send(
            &MavMessage::COMMAND_ACK(COMMAND_ACK_DATA { command, result }),
            now_us,
        );
    }

    /// The final acknowledgement of a command, with a status text saying what was done or
    /// why it failed.
    pub fn finish(&mut self, token: CommandToken, result: CommandOutcome, now_us: u64) {
        if self.pending == Some(token.command) {
            self.pending = None;
        }
        let code = if matches!(result, CommandOutcome::Accepted(_)) {
            MavResult::MAV_RESULT_ACCEPTED
        } else {
            MavResult::MAV_RESULT_FAILED
        };
        self.last_result = Some((token.command, code, now_us));
        let name = match token.command {
            CMD_CONNECT => "connect",
            CMD_START_LOGGING => "start logging",
            CMD_STOP => "stop",
            _ => "command",
        };
        match result {
            CommandOutcome::Accepted(text) => {
                self.status_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("{name}: {text}"),
                    now_us,
                );
                self.ack(token.command, MavResult::MAV_RESULT_ACCEPTED, now_us);
            }
            CommandOutcome::Failed(why) => {
                self.status_text(
                    MavSeverity::MAV_SEVERITY_ERROR,
                    &format!("{name}: {why}"),
                    now_us,
                );
                self.ack(token.command, MavResult::MAV_RESULT_FAILED, now_us);
            }
        }
    }
}
