//! What the vehicle says of itself: the heartbeat (the bootstrap's state and the control
//! mode, docs/link.md) and status texts cut to a STATUSTEXT's size.

use mavlink::dialects::common::*;

/// The bootstrap's state, as the heartbeat's custom mode (low byte) tells it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BootstrapState {
    /// No flight process.
    #[default]
    Idle = 0,
    /// Flight process starting.
    Connecting = 1,
    /// Flight process up, waiting for Start Logging.
    Connected = 2,
    /// Start Logging sent, waiting for the process.
    Starting = 3,
    /// Flying and logging.
    Flying = 4,
    /// Stopping.
    Stopping = 5,
}

/// What the heartbeat says of the vehicle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VehicleStatus {
    /// The bootstrap's state.
    pub state: BootstrapState,
    /// The control mode of the flight under way, as asked at Start Logging (custom mode's
    /// second byte: 1 manual, 2 autonomous, 3 rate, 4 attitude, 5 velocity; 0 none).
    pub mode: u8,
    /// The phase the flight software is flying (custom mode's third byte: its place in
    /// [`PHASES`] from 1; 0 not known): what the helicopter actually does, which a refusal
    /// or a failsafe can make differ from the mode asked.
    pub phase: u8,
    /// Whether the vehicle's configuration is the one the lab tested (custom mode's fourth
    /// byte; `heli certify`).
    pub tested: Tested,
}

/// Whether the vehicle flies what the lab tested (`heli certify`): its build and parameters
/// match a lab's signed attestation. Why not travels as a STATUSTEXT beginning with
/// [`NOT_LAB_TESTED`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tested {
    /// Not said (an older vehicle).
    #[default]
    Unknown = 0,
    /// The build and parameters match the lab's attestation.
    LabTested = 1,
    /// They do not, or no attestation can be checked.
    NotTested = 2,
    /// Not lab-tested, on a lab bench whose standing override flies it anyway
    /// (`--fly-untested`): a ground asks no per-flight override.
    BenchOverride = 3,
}

/// How the vehicle's statement begins when its configuration is not lab-tested.
pub const NOT_LAB_TESTED: &str = "NOT lab-tested";
/// How it begins when it is.
pub const LAB_TESTED: &str = "lab-tested";
/// The heartbeat's name of [`Tested::BenchOverride`].
pub const NOT_LAB_TESTED_BENCH: &str = "NOT lab-tested (bench)";

impl Tested {
    /// Its name on displays.
    pub const fn name(self) -> &'static str {
        match self {
            Tested::Unknown => "unknown",
            Tested::LabTested => LAB_TESTED,
            Tested::NotTested => NOT_LAB_TESTED,
            Tested::BenchOverride => NOT_LAB_TESTED_BENCH,
        }
    }

    fn from_code(code: u32) -> Self {
        match code {
            1 => Tested::LabTested,
            2 => Tested::NotTested,
            3 => Tested::BenchOverride,
            _ => Tested::Unknown,
        }
    }
}

/// The flight software's phases, by name, in the heartbeat's order
/// ([`heli_types::phases::PHASES`]).
pub use heli_types::phases::PHASES;

/// The heartbeat's code of a phase name (0: not one of [`PHASES`]).
pub fn phase_code(name: &str) -> u8 {
    PHASES
        .iter()
        .position(|p| *p == name)
        .and_then(|i| u8::try_from(i.saturating_add(1)).ok())
        .unwrap_or(0)
}

impl BootstrapState {
    /// Every state, in number order.
    pub const ALL: [BootstrapState; 6] = [
        BootstrapState::Idle,
        BootstrapState::Connecting,
        BootstrapState::Connected,
        BootstrapState::Starting,
        BootstrapState::Flying,
        BootstrapState::Stopping,
    ];

    /// Its name on displays.
    pub const fn name(self) -> &'static str {
        match self {
            BootstrapState::Idle => "idle",
            BootstrapState::Connecting => "connecting",
            BootstrapState::Connected => "connected",
            BootstrapState::Starting => "starting",
            BootstrapState::Flying => "flying",
            BootstrapState::Stopping => "stopping",
        }
    }
}

impl VehicleStatus {
    /// What a vehicle's heartbeat says (`None`: not one of ours: an unknown state number).
    pub fn from_heartbeat(hb: &HEARTBEAT_DATA) -> Option<Self> {
        let state = BootstrapState::ALL
            .into_iter()
            .find(|s| *s as u32 == hb.custom_mode & 0xFF)?;
        Some(Self {
            state,
            mode: u8::try_from((hb.custom_mode >> 8) & 0xFF).unwrap_or(0),
            phase: u8::try_from((hb.custom_mode >> 16) & 0xFF).unwrap_or(0),
            tested: Tested::from_code((hb.custom_mode >> 24) & 0xFF),
        })
    }

    /// The phase flown, if known.
    pub fn phase_name(self) -> Option<&'static str> {
        let index = usize::from(self.phase).checked_sub(1)?;
        PHASES.get(index).copied()
    }

    /// The control mode of the flight under way, if any.
    pub fn flight_mode(self) -> Option<heli_types::FlightMode> {
        let index = usize::from(self.mode).checked_sub(1)?;
        heli_types::FlightMode::ALL.get(index).copied()
    }
}

/// The heartbeat's code of a control mode (1 manual, 2 autonomous, 3 rate, 4 attitude, 5
/// velocity: its place in [`heli_types::FlightMode::ALL`] from 1; 0 is none).
pub fn mode_code(mode: heli_types::FlightMode) -> u8 {
    heli_types::FlightMode::ALL
        .iter()
        .position(|m| *m == mode)
        .and_then(|i| u8::try_from(i).ok())
        .map_or(0, |i| i.saturating_add(1))
}

/// `text` in pieces of at most `max` bytes (a STATUSTEXT holds 50) that join back to it
/// exactly: each piece but the last ends with a space of the text (cut after a word) or, where
/// a word is longer than the room, is cut inside the word and full (`max` bytes); the last
/// piece is never full and never ends with a space (a text of exactly `max` bytes is cut
/// too, and one ending with a space gets an empty last piece), so that the ground, which joins
/// a piece that ends with a space or is full to the next one (`GroundLink`), knows where a
/// text ends, adding nothing. (Only a word of more than `max` bytes whose cut would fall inside a character of
/// several bytes makes a piece that is neither: the line then arrives as two.)
pub fn chunks(text: &str, max: usize) -> Vec<String> {
    let max = max.max(4);
    let mut out = Vec::new();
    let mut rest = text;
    while rest.len() >= max || (rest.ends_with(' ') && !rest.is_empty()) {
        // The longest prefix of at most `max` bytes that ends at a character's boundary.
        let room = (0..=max)
            .rev()
            .find(|i| rest.is_char_boundary(*i))
            .unwrap_or(0);
        // Cut after the last space in it, if any; else inside the word.
        let cut = rest
            .get(..room)
            .and_then(|head| head.rfind(' '))
            .map_or(room, |space| space.saturating_add(1));
        let cut = if cut == 0 { room.max(1) } else { cut };
        let (piece, tail) = rest.split_at(cut.min(rest.len()));
        out.push(piece.to_string());
        rest = tail;
    }
    out.push(rest.to_string());
    out
}

/// The heartbeat for `status`.
pub fn heartbeat(status: VehicleStatus) -> MavMessage {
    let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if status.state == BootstrapState::Flying {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        if status.mode == 2 {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED;
        } else if status.mode >= 3 {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
        } else {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED;
        }
    }
    let system_status = match status.state {
        BootstrapState::Idle | BootstrapState::Connected => MavState::MAV_STATE_STANDBY,
        BootstrapState::Connecting | BootstrapState::Starting => MavState::MAV_STATE_BOOT,
        BootstrapState::Flying => MavState::MAV_STATE_ACTIVE,
        BootstrapState::Stopping => MavState::MAV_STATE_POWEROFF,
    };
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: u32::from(status.state as u8)
            | (u32::from(status.mode) << 8)
            | (u32::from(status.phase) << 16)
            | ((status.tested as u32) << 24),
        mavtype: MavType::MAV_TYPE_HELICOPTER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_GENERIC,
        base_mode,
        system_status,
        mavlink_version: 3,
    })
}
