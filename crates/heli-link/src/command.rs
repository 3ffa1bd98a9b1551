//! The thesis's ground commands as MAVLink `COMMAND_LONG`s (docs/link.md):
//!
//! | thesis | command | parameters |
//! |---|---|---|
//! | Connect | `MAV_CMD_USER_1` (31010) | — |
//! | Start Logging | `MAV_CMD_USER_2` (31011) | 1: controller (0 manual, 1 autonomous, 2 rate, 3 attitude, 4 velocity), plus [`OVERRIDE_UNTESTED`] for the operator's override of a configuration that is not lab-tested; 2: plan (0 the vehicle's default, else the index in [`PLANS`] plus one); 3–7: the file suffix, 3 ASCII bytes per parameter |
//! | Stop | `MAV_CMD_USER_3` (31012) | — |
//! | Kill (Stop in the air, confirmed) | `MAV_CMD_USER_3` (31012) | 1: [`KILL_CODE`] (21196, MAVLink's force code) |
//!
//! MAVLink has no string parameter in a command; the suffix (up to 15 characters) travels as
//! whole numbers below 2²⁴, which a float carries exactly ([`pack_text`]).

use mavlink::dialects::common::{COMMAND_LONG_DATA, MavCmd};

use crate::messages::{GroundCommand, StartParameters};
use heli_types::{AugmentedMode, FlightMode};

/// Connect: start the flight process.
pub const CMD_CONNECT: MavCmd = MavCmd::MAV_CMD_USER_1;
/// Start Logging with the flight parameters.
pub const CMD_START_LOGGING: MavCmd = MavCmd::MAV_CMD_USER_2;
/// Stop the flight process.
pub const CMD_STOP: MavCmd = MavCmd::MAV_CMD_USER_3;
/// Stop's first parameter for a kill: the code MAVLink's `MAV_CMD_COMPONENT_ARM_DISARM`
/// takes to force a disarm in flight, so that no stray value kills.
pub const KILL_CODE: f32 = 21196.0;

/// Longest file suffix a Start Logging command carries (the suffix's one limit, kept with
/// the parameters it limits).
pub use crate::messages::MAX_LINK_SUFFIX;

/// Added to Start Logging's controller parameter: the operator overrides the lab-tested
/// check (`StartParameters::override_untested`).
pub const OVERRIDE_UNTESTED: usize = 16;

/// The flight plans the vehicle knows by name, by their link index (plan parameter − 1).
pub const PLANS: [&str; 3] = ["hover", "demo", "rolls"];

/// The controllers in link order.
const CONTROLLERS: [FlightMode; 5] = [
    FlightMode::Manual,
    FlightMode::Autonomous,
    FlightMode::Augmented(AugmentedMode::Rate),
    FlightMode::Augmented(AugmentedMode::Attitude),
    FlightMode::Augmented(AugmentedMode::Velocity),
];

/// Packs `text` (ASCII, at most 15 bytes) into five floats, 3 bytes each, little-endian.
pub fn pack_text(text: &str) -> [f32; 5] {
    let mut out = [0f32; 5];
    let bytes = text.as_bytes();
    for (i, slot) in out.iter_mut().enumerate() {
        let at = i.saturating_mul(3);
        let b = |k: usize| u32::from(bytes.get(at.saturating_add(k)).copied().unwrap_or(0));
        *slot = (b(0) | (b(1) << 8) | (b(2) << 16)) as f32;
    }
    out
}

/// The text packed by [`pack_text`]; `None` if a value is not a whole number below 2²⁴ or a
/// byte is not printable ASCII.
pub fn unpack_text(values: [f32; 5]) -> Option<String> {
    let mut bytes = Vec::new();
    for v in values {
        if !((0.0..16_777_216.0).contains(&v) && v.fract() == 0.0) {
            return None;
        }
        let n = v as u32;
        bytes.extend([n & 0xFF, (n >> 8) & 0xFF, (n >> 16) & 0xFF].map(|b| b as u8));
    }
    while bytes.last() == Some(&0) {
        bytes.pop();
    }
    if bytes.iter().any(|b| !(0x20..0x7F).contains(b)) {
        return None;
    }
    String::from_utf8(bytes).ok()
}

/// Why a command from the link is refused.
#[derive(Clone, Debug, PartialEq)]
pub enum CommandError {
    /// Not one of the thesis's commands.
    Unsupported(MavCmd),
    /// A parameter is out of range; the words say which.
    BadParameter(String),
}

impl std::fmt::Display for CommandError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CommandError::Unsupported(c) => write!(f, "command {c:?} is not supported"),
            CommandError::BadParameter(why) => write!(f, "{why}"),
        }
    }
}

/// The thesis command a `COMMAND_LONG` carries.
pub fn ground_command(cmd: &COMMAND_LONG_DATA) -> Result<GroundCommand, CommandError> {
    match cmd.command {
        CMD_CONNECT => Ok(GroundCommand::Connect),
        CMD_STOP if cmd.param1 == KILL_CODE => Ok(GroundCommand::Kill),
        CMD_STOP if cmd.param1 == 0.0 => Ok(GroundCommand::Stop),
        CMD_STOP => Err(CommandError::BadParameter(format!(
            "stop's parameter 1 is {}: 0 for Stop, {KILL_CODE} for a kill",
            cmd.param1
        ))),
        CMD_START_LOGGING => {
            let (controller, override_untested) = whole(cmd.param1)
                .and_then(|code| {
                    let overridden = code >= OVERRIDE_UNTESTED;
                    let index = code.checked_sub(OVERRIDE_UNTESTED).unwrap_or(code);
                    CONTROLLERS.get(index).map(|c| (*c, overridden))
                })
                .ok_or_else(|| {
                    CommandError::BadParameter(format!(
                        "controller {} is not 0-4 (manual, autonomous, rate, attitude, velocity), or 16-20 with the override of the lab-tested check",
                        cmd.param1
                    ))
                })?;
            let plan = match whole(cmd.param2) {
                Some(0) => None,
                Some(i) => Some(
                    PLANS
                        .get(i.saturating_sub(1))
                        .ok_or_else(|| {
                            CommandError::BadParameter(format!(
                                "plan {} is not 0-{}",
                                cmd.param2,
                                PLANS.len()
                            ))
                        })?
                        .to_string(),
                ),
                None => {
                    return Err(CommandError::BadParameter(format!(
                        "plan {} is not a whole number",
                        cmd.param2
                    )));
                }
            };
            let suffix = unpack_text([cmd.param3, cmd.param4, cmd.param5, cmd.param6, cmd.param7])
                .ok_or_else(|| {
                    CommandError::BadParameter(
                        "the file suffix (parameters 3-7) is not packed ASCII text".into(),
                    )
                })?;
            let mut params = StartParameters::new(&suffix, controller.name())
                .map_err(|e| CommandError::BadParameter(e.to_string()))?;
            params.plan = plan;
            params.override_untested = override_untested;
            Ok(GroundCommand::StartLogging(params))
        }
        other => Err(CommandError::Unsupported(other)),
    }
}

fn whole(v: f32) -> Option<usize> {
    (v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v < 256.0).then_some(v as usize)
}

/// The `COMMAND_LONG` for a thesis command, addressed to `target` (system, component);
/// `None` for a command with no link form (the telemetry request and the final parameters
/// are other messages) or parameters the link cannot carry.
pub fn command_long(command: &GroundCommand, target: (u8, u8)) -> Option<COMMAND_LONG_DATA> {
    let base = COMMAND_LONG_DATA {
        target_system: target.0,
        target_component: target.1,
        ..Default::default()
    };
    match command {
        GroundCommand::Connect => Some(COMMAND_LONG_DATA {
            command: CMD_CONNECT,
            ..base
        }),
        GroundCommand::Stop => Some(COMMAND_LONG_DATA {
            command: CMD_STOP,
            ..base
        }),
        GroundCommand::Kill => Some(COMMAND_LONG_DATA {
            command: CMD_STOP,
            param1: KILL_CODE,
            ..base
        }),
        GroundCommand::StartLogging(p) => {
            if p.file_suffix.len() > MAX_LINK_SUFFIX {
                return None;
            }
            let controller = CONTROLLERS
                .iter()
                .position(|c| *c == p.controller)?
                .saturating_add(if p.override_untested {
                    OVERRIDE_UNTESTED
                } else {
                    0
                });
            let plan = match &p.plan {
                None => 0,
                Some(name) => PLANS.iter().position(|n| n == name)?.saturating_add(1),
            };
            let [p3, p4, p5, p6, p7] = pack_text(&p.file_suffix);
            Some(COMMAND_LONG_DATA {
                command: CMD_START_LOGGING,
                param1: controller as f32,
                param2: plan as f32,
                param3: p3,
                param4: p4,
                param5: p5,
                param6: p6,
                param7: p7,
                ..base
            })
        }
        GroundCommand::TelemetryRequest | GroundCommand::Final(_) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_round_trips_and_nonsense_is_refused() {
        for s in ["a", "flight-07", "abcdefghijklmno"] {
            assert_eq!(unpack_text(pack_text(s)).as_deref(), Some(s));
        }
        assert_eq!(unpack_text([f32::NAN, 0.0, 0.0, 0.0, 0.0]), None);
        assert_eq!(unpack_text([1.5, 0.0, 0.0, 0.0, 0.0]), None);
        assert_eq!(
            unpack_text([7.0, 0.0, 0.0, 0.0, 0.0]),
            None,
            "a control byte"
        );
    }

    #[test]
    fn every_thesis_command_round_trips() {
        let mut start = StartParameters::new("hover1", "velocity").unwrap();
        start.plan = Some("demo".into());
        let mut overridden = StartParameters::new("untested", "autonomous").unwrap();
        overridden.override_untested = true;
        for c in [
            GroundCommand::StartLogging(overridden),
            GroundCommand::Connect,
            GroundCommand::Stop,
            GroundCommand::Kill,
            GroundCommand::StartLogging(start),
            GroundCommand::StartLogging(StartParameters::new("x", "manual").unwrap()),
        ] {
            let long = command_long(&c, (1, 1)).unwrap();
            assert_eq!(ground_command(&long), Ok(c));
        }
    }

    #[test]
    fn bad_parameters_are_refused_with_their_reason() {
        let mut long = command_long(
            &GroundCommand::StartLogging(StartParameters::new("x", "manual").unwrap()),
            (1, 1),
        )
        .unwrap();
        long.param1 = 9.0;
        let err = ground_command(&long).unwrap_err().to_string();
        assert!(err.contains("controller 9"), "{err}");
        for bad in [5.0, 15.0, 21.0, 32.0] {
            long.param1 = bad;
            let err = ground_command(&long).unwrap_err().to_string();
            assert!(err.contains(&format!("controller {bad}")), "{err}");
        }
        long.param1 = 17.0;
        let GroundCommand::StartLogging(p) = ground_command(&long).unwrap() else {
            panic!("not a start")
        };
        assert!(p.override_untested);
        assert_eq!(p.controller, FlightMode::Autonomous);
        long.param1 = 0.0;
        long.param2 = 7.0;
        assert!(
            ground_command(&long)
                .unwrap_err()
                .to_string()
                .contains("plan 7")
        );
        long.param2 = 0.0;
        long.param3 = pack_text("../")[0];
        assert!(
            ground_command(&long)
                .unwrap_err()
                .to_string()
                .contains("suffix")
        );
        long.command = MavCmd::MAV_CMD_NAV_TAKEOFF;
        assert!(matches!(
            ground_command(&long),
            Err(CommandError::Unsupported(_))
        ));
    }
}
