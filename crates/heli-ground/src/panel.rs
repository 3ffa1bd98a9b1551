//! The operator's panel of thesis §2.4: the Connect, Start Logging and Stop buttons and the
//! large indicator between them.
//!
//! - At first only Connect is active and the indicator is red.
//! - When the flight process has started and registered (the vehicle's heartbeat says
//!   *connected*), the indicator turns green, Connect becomes inactive, and Start Logging and
//!   Stop become active.
//! - After Start Logging succeeds, Stop is the only active button.
//! - If the flight process fails to start logging, the display says logging failed and Stop
//!   is the only active button: the operator resets the display with it.
//! - If the bootstrap fails to start the flight process (or it dies while starting), the
//!   indicator stays red and Connect is the only active button.
//! - While a command is on its way, no button is active.
//!
//! The vehicle's heartbeat is the truth: a display that joins a flight under way shows it as
//! under way.

use heli_link::status::BootstrapState;
use serde::Serialize;

/// What the panel shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PanelState {
    /// No flight process: Connect.
    Idle,
    /// Connect sent, or the flight process starting.
    Connecting,
    /// The flight process registered: Start Logging or Stop.
    Connected,
    /// Start Logging sent: waiting for the flight process.
    Starting,
    /// Flying and logging: Stop.
    Logging,
    /// Start Logging failed: Stop resets the display.
    LoggingFailed,
    /// Stop sent: waiting for the vehicle.
    Stopping,
}

impl PanelState {
    /// Its name, as the page receives it.
    pub const fn name(self) -> &'static str {
        match self {
            PanelState::Idle => "idle",
            PanelState::Connecting => "connecting",
            PanelState::Connected => "connected",
            PanelState::Starting => "starting",
            PanelState::Logging => "logging",
            PanelState::LoggingFailed => "logging-failed",
            PanelState::Stopping => "stopping",
        }
    }

    /// The state the vehicle's bootstrap state implies.
    pub fn from_vehicle(state: BootstrapState) -> Self {
        match state {
            BootstrapState::Idle => PanelState::Idle,
            BootstrapState::Connecting => PanelState::Connecting,
            BootstrapState::Connected => PanelState::Connected,
            BootstrapState::Starting => PanelState::Starting,
            BootstrapState::Flying => PanelState::Logging,
            BootstrapState::Stopping => PanelState::Stopping,
        }
    }

    /// Which buttons are active: (Connect, Start Logging, Stop).
    pub fn buttons(self) -> (bool, bool, bool) {
        match self {
            PanelState::Idle => (true, false, false),
            PanelState::Connected => (false, true, true),
            PanelState::Logging | PanelState::LoggingFailed => (false, false, true),
            PanelState::Connecting | PanelState::Starting | PanelState::Stopping => {
                (false, false, false)
            }
        }
    }

    /// Kill is active: a flight process is up (connected, flying, stopping or landing).
    pub fn kill_active(self) -> bool {
        !matches!(self, PanelState::Idle | PanelState::Connecting)
    }

    /// The large indicator is green: the flight process has registered with the ground.
    pub fn green(self) -> bool {
        matches!(
            self,
            PanelState::Connected | PanelState::Starting | PanelState::Logging
        )
    }
}

/// The panel: the vehicle's state, overridden while a command of ours is under way and after
/// a failed Start Logging.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    vehicle: Option<BootstrapState>,
    /// A command of ours is on its way (its panel state meanwhile).
    pending: Option<PanelState>,
    logging_failed: bool,
}

impl Panel {
    /// The vehicle's heartbeat said `state` (`None`: no heartbeat for too long).
    pub fn vehicle(&mut self, state: Option<BootstrapState>) {
        self.vehicle = state;
    }

    /// A command was sent; the panel shows `meanwhile` until it is answered.
    pub fn sent(&mut self, meanwhile: PanelState) {
        self.pending = Some(meanwhile);
    }

    /// The command under way was answered (or given up).
    pub fn answered(&mut self) {
        self.pending = None;
    }

    /// Start Logging failed: the display says so until Stop.
    pub fn logging_failed(&mut self) {
        self.logging_failed = true;
    }

    /// Stop was pressed: the failed state is reset.
    pub fn reset(&mut self) {
        self.logging_failed = false;
    }

    /// What the panel shows now.
    pub fn state(&self) -> PanelState {
        if let Some(p) = self.pending {
            return p;
        }
        if self.logging_failed {
            return PanelState::LoggingFailed;
        }
        self.vehicle
            .map_or(PanelState::Idle, PanelState::from_vehicle)
    }
}

impl Serialize for PanelState {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_buttons_follow_section_2_4() {
        let mut p = Panel::default();
        assert_eq!(p.state().buttons(), (true, false, false));
        assert!(!p.state().green());
        p.sent(PanelState::Connecting);
        assert_eq!(p.state().buttons(), (false, false, false));
        p.answered();
        p.vehicle(Some(BootstrapState::Connected));
        assert_eq!(p.state().buttons(), (false, true, true));
        assert!(p.state().green());
        p.vehicle(Some(BootstrapState::Flying));
        assert_eq!(p.state().buttons(), (false, false, true));
        // A failed start: Stop only, until Stop resets it.
        p.vehicle(Some(BootstrapState::Idle));
        p.logging_failed();
        assert_eq!(p.state(), PanelState::LoggingFailed);
        assert_eq!(p.state().buttons(), (false, false, true));
        assert!(!p.state().green());
        p.reset();
        assert_eq!(p.state().buttons(), (true, false, false));
        // The bootstrap could not start the process: red, Connect only.
        p.vehicle(Some(BootstrapState::Idle));
        assert_eq!(p.state().buttons(), (true, false, false));
    }
}
