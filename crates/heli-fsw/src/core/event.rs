//! What the main control process reports: events with an F´-style severity, so the ground
//! and the log can sort the routine from the alarming.

use super::Phase;
use crate::health::HealthState;
use heli_control::safety::Verdict;
use heli_types::{Device, FlightMode};

/// How much an event matters (F´'s event severities).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// Routine, low-rate activity (a phase change, a roll completed).
    ActivityLo,
    /// Notable activity (calibration done, the plan complete).
    ActivityHi,
    /// Something off that the software handles without changing what it does (a late
    /// device, one watchdog fire).
    WarningLo,
    /// Something off that changes what the software does (a silent device, transmitter
    /// loss, a GPS outage).
    WarningHi,
    /// The flight cannot go on as planned (the estimate is invalid).
    Fatal,
}

impl Severity {
    /// Short name for logs and displays.
    pub const fn name(self) -> &'static str {
        match self {
            Severity::ActivityLo => "activity-lo",
            Severity::ActivityHi => "activity-hi",
            Severity::WarningLo => "warning-lo",
            Severity::WarningHi => "warning-hi",
            Severity::Fatal => "fatal",
        }
    }

    /// Every severity, least first.
    pub const ALL: [Severity; 5] = [
        Severity::ActivityLo,
        Severity::ActivityHi,
        Severity::WarningLo,
        Severity::WarningHi,
        Severity::Fatal,
    ];

    /// The severity named `name` (as [`Severity::name`] writes it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// An aid of the filter other than the GPS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aid {
    /// The barometric altimeter.
    Altimeter,
    /// The magnetic compass.
    Compass,
}

impl Aid {
    /// Short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Aid::Altimeter => "altimeter",
            Aid::Compass => "compass",
        }
    }
}

/// A mode the pilot's switch asked for and the rule refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeRefusal {
    /// The mode asked for.
    pub mode: FlightMode,
    /// What failed.
    pub verdict: Verdict,
}

impl ModeRefusal {
    /// What it says on the ground display.
    pub fn text(&self) -> String {
        format!("{} flight refused: {}", self.mode.name(), self.verdict)
    }
}

/// One of the batteries the computer watches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Battery {
    /// The flight battery: the computer, IMU, GPS, altimeter and compass.
    Flight,
    /// The servo board's logic and receiver battery (the uplink's RTXB).
    Receiver,
    /// The servo battery (the uplink's Sbat).
    Servo,
}

impl Battery {
    /// Every battery, in the display's order.
    pub const ALL: [Battery; 3] = [Battery::Flight, Battery::Receiver, Battery::Servo];

    /// Name for messages and displays.
    pub const fn name(self) -> &'static str {
        match self {
            Battery::Flight => "flight battery",
            Battery::Receiver => "receiver battery",
            Battery::Servo => "servo battery",
        }
    }

    pub(crate) const fn index(self) -> usize {
        match self {
            Battery::Flight => 0,
            Battery::Receiver => 1,
            Battery::Servo => 2,
        }
    }
}

/// What is wrong with a battery's reading (its channel, not the pack:
/// [`super::battery_channel`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReadingFault {
    /// The same reading again and again: refused from then on, the charge unknown.
    Stuck {
        /// The reading it is stuck at (V).
        volts: f64,
    },
    /// A reading far from the last good one, refused.
    Garbled {
        /// The reading refused (V).
        volts: f64,
        /// Readings refused so far in the flight.
        refused: u32,
    },
    /// No reading for a while.
    Late {
        /// Since the last reading (s).
        age_s: f64,
    },
    /// Good again: readings on time and used.
    Back,
}

/// Notable things that happened, for the ground's message area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CoreEvent {
    /// The 80 s calibration finished.
    CalibrationDone {
        /// Gyro biases found (rad/s).
        gyro_bias_rps: [f64; 3],
    },
    /// The calibration window saw the helicopter move and started again (a turn of the
    /// fuselage or a rocking that would have been averaged in as bias).
    CalibrationRestarted(heli_nav::calibration::Motion),
    /// A second of the calibration window in which the gyros or accelerometers saw the
    /// helicopter move was left out of the average, and the window made as much longer (the
    /// first second of a run of them).
    CalibrationLeftOut(heli_nav::calibration::LeftOut),
    /// The calibration is held up: the helicopter keeps moving on its skids (every
    /// [`super::calibration::HELD_UP_RESTARTS`] restarts, or
    /// [`super::calibration::HELD_UP_LEFT_OUT_S`] seconds left out of one window). The
    /// operator is told why and what to do.
    CalibrationHeldUp {
        /// Restarts of the window so far.
        restarts: u32,
        /// Seconds left out of the window now open.
        left_out_s: u32,
    },
    /// The compass heading moved while the gyros saw the helicopter still (a magnetic
    /// disturbance, or a creep too slow for them): said, never a restart.
    CalibrationCompassMoved {
        /// How far the heading moved (rad).
        moved_rad: f64,
    },
    /// A battery's reading is wrong: stuck, garbled, late, or good again.
    BatteryReading {
        /// Which battery.
        battery: Battery,
        /// What is wrong.
        fault: ReadingFault,
    },
    /// The phase changed.
    PhaseChanged(Phase),
    /// No GPS fix fused for too long in autonomous flight: the estimate is degraded and
    /// the helicopter lands where it is.
    EstimateDegraded {
        /// Since a fix was last fused (s).
        since_gps_s: f64,
    },
    /// The flight process started again in the air (a brown-out, a crash): it aligns
    /// instead of calibrating, flying the blind failsafe meanwhile.
    RestartedInAir,
    /// The flight process started again in a roll its predecessor recorded: the roll goes on
    /// (`angle_rad`: turned by now, counting the `unseen_s` nobody saw it) and is finished on
    /// the gyros before the alignment; with no angle, unseen for longer than the servo board
    /// holds a command, it was given up and the process aligns at once.
    RestartedInRoll {
        /// The angle turned by now, if it could be reckoned (rad).
        angle_rad: Option<f64>,
        /// Time since the predecessor's last record of the roll (s).
        unseen_s: f64,
    },
    /// A roll under way when the estimate was declared invalid ended without it, and the
    /// cyclic was levelled: `finished` all the way round (open loop while the IMU was
    /// silent), or stopped where it was, less than a quarter of the way round.
    RollEndedBlind {
        /// Turned all the way round, not stopped.
        finished: bool,
    },
    /// The IMU is back after the estimate was declared invalid, in the air: the flight
    /// aligns again as after a restart, flying the blind failsafe (or the pilot) meanwhile.
    ImuBackInAir,
    /// The in-air alignment is done and the estimate runs again (`gps`: with a fix).
    AlignedInAir {
        /// A GPS fix placed the estimate.
        gps: bool,
    },
    /// The watchdog fired: an IMU packet was late or lost and the last one was repeated.
    WatchdogFired,
    /// The pilot's receiver signal was lost (all channels zero): hovering.
    PilotSignalLost,
    /// An aileron roll was completed (the count so far in this flight).
    RollCompleted(u32),
    /// A roll took more than twice its nominal time and was given up.
    RollAbandoned,
    /// No GPS fix has been fused for the outage time: the estimate is coasting on the IMU.
    GpsLost,
    /// GPS fixes are fused again.
    GpsRegained,
    /// The last leg of the flight plan is done.
    PlanComplete,
    /// A device's watchdog changed its verdict.
    DeviceHealth {
        /// Which device.
        device: Device,
        /// Its new state.
        state: HealthState,
    },
    /// The IMU stayed silent for [`crate::health::IMU_FIRES_TO_INVALID`] watchdog periods in a row: the
    /// estimate is invalid for the rest of this flight; the pilot flies, or the blind
    /// failsafe descends.
    EstimateInvalid,
    /// The pilot uplink fell silent: treated as transmitter loss.
    UplinkLost,
    /// A GPS fix was refused before the filter saw it.
    GpsImplausible(super::gps::Implausible),
    /// GPS fixes kept failing the filter's gate after a long coast: position and velocity
    /// were reset to the GPS.
    GpsReset,
    /// The pre-flight checks refused an autonomous take-off.
    TakeoffRefused(super::preflight::Refusal),
    /// An aid's readings arrive but the filter's gate has refused them all for
    /// [`super::aids::AID_REFUSED_AFTER_S`]: the estimate goes on without it.
    AidRefused {
        /// Which aid.
        aid: Aid,
        /// Its last innovation test ratio (above 1: refused).
        test_ratio: f64,
    },
    /// A reading of an aid reported refused was fused again.
    AidAccepted(Aid),
    /// The mode the pilot's switch asked for is refused by the safety rule.
    ModeRefused(ModeRefusal),
    /// The rotor stayed below the engine watch's fraction of its governed speed in the air:
    /// the engine has failed (autorotation when the computer flies).
    EngineFailure {
        /// The rotor speed when it was judged (rpm).
        rotor_rpm: u16,
    },
    /// A battery reached a worse level (`core::power`).
    BatteryLevel {
        /// Which battery.
        battery: Battery,
        /// The level reached.
        level: heli_power::Level,
        /// Its charge left (%).
        percent: u8,
        /// Its time left at the present drain (minutes).
        minutes_left: u16,
    },
    /// A battery drains faster than the flight so far explains: the field rule says to end
    /// the flight test.
    BatteryDrainingAbnormally {
        /// Which battery.
        battery: Battery,
    },
    /// The answer to the operator's Stop (`core::stop`), and the end of a Stop's landing.
    Stop(super::stop::StopAnswer),
    /// The hot-swap changed what powers the avionics.
    PowerSource {
        /// The source now.
        source: heli_power::PowerSource,
        /// Time on the flight batteries so far (s).
        flight_s: f64,
        /// Time on the ground battery so far (s).
        ground_s: f64,
    },
}

impl CoreEvent {
    /// How much this event matters.
    pub fn severity(&self) -> Severity {
        match self {
            CoreEvent::PhaseChanged(_)
            | CoreEvent::RollCompleted(_)
            | CoreEvent::GpsRegained
            | CoreEvent::AidAccepted(_) => Severity::ActivityLo,
            CoreEvent::CalibrationDone { .. }
            | CoreEvent::PlanComplete
            | CoreEvent::PowerSource { .. }
            | CoreEvent::AlignedInAir { .. } => Severity::ActivityHi,
            CoreEvent::BatteryLevel { level, .. } => match level {
                heli_power::Level::Good => Severity::ActivityLo,
                heli_power::Level::Warning => Severity::WarningHi,
                heli_power::Level::Critical => Severity::Fatal,
            },
            CoreEvent::WatchdogFired
            | CoreEvent::RollAbandoned
            | CoreEvent::GpsImplausible(_)
            | CoreEvent::CalibrationRestarted(_)
            | CoreEvent::CalibrationLeftOut(_)
            | CoreEvent::CalibrationCompassMoved { .. } => Severity::WarningLo,
            CoreEvent::PilotSignalLost
            | CoreEvent::GpsLost
            | CoreEvent::UplinkLost
            | CoreEvent::GpsReset
            | CoreEvent::RestartedInAir
            | CoreEvent::RestartedInRoll { .. }
            | CoreEvent::ImuBackInAir
            | CoreEvent::RollEndedBlind { .. }
            | CoreEvent::EstimateDegraded { .. }
            | CoreEvent::AidRefused { .. }
            | CoreEvent::TakeoffRefused(_)
            | CoreEvent::CalibrationHeldUp { .. }
            | CoreEvent::ModeRefused(_)
            | CoreEvent::BatteryDrainingAbnormally { .. } => Severity::WarningHi,
            CoreEvent::DeviceHealth { device, state } => match (device, state) {
                (_, HealthState::Ok | HealthState::Waiting) => Severity::ActivityLo,
                (_, HealthState::Late) => Severity::WarningLo,
                (Device::Imu, HealthState::Silent | HealthState::Failed) => Severity::Fatal,
                (_, HealthState::Silent | HealthState::Failed) => Severity::WarningHi,
            },
            CoreEvent::BatteryReading { fault, .. } => match fault {
                ReadingFault::Stuck { .. } | ReadingFault::Garbled { .. } => Severity::WarningHi,
                ReadingFault::Late { .. } => Severity::WarningLo,
                ReadingFault::Back => Severity::ActivityLo,
            },
            CoreEvent::EstimateInvalid | CoreEvent::EngineFailure { .. } => Severity::Fatal,
            CoreEvent::Stop(answer) => match answer {
                super::stop::StopAnswer::Now | super::stop::StopAnswer::Landing => {
                    Severity::ActivityHi
                }
                super::stop::StopAnswer::Refused(_) | super::stop::StopAnswer::Cancelled(_) => {
                    Severity::WarningHi
                }
            },
        }
    }
}
