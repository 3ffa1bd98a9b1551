//! What the display shows, as one value the web page draws: [`View`], made by
//! [`Station::view`] and sent to every page several times a second.

use heli_link::mission::{PlanPoint, plan_points};
use mavlink::MessageData;
use mavlink::dialects::common::*;
use serde::Serialize;

use crate::checks::{battery_meter, gps_ok};
use crate::display::uplink_labels;
use crate::facts::{SafetyView, facts, safety_view};
use crate::messages::Message;
use crate::operators::ClientId;
use crate::panel::PanelState;
use crate::rows::{Rows, rows};
use crate::station::Station;

/// Lines of the message area sent with each view (ten a second): a page opened late
/// starts with these.
pub const MESSAGES_IN_VIEW: usize = 80;

/// The panel of §2.4.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PanelView {
    /// Its state.
    pub state: PanelState,
    /// Connect is active.
    pub connect: bool,
    /// Start Logging is active.
    pub start: bool,
    /// Stop is active.
    pub stop: bool,
    /// The large indicator is green.
    pub green: bool,
    /// Telemetry messages received (the counter; the indicator flashes as it rises).
    pub telemetry_count: u64,
}

/// The vehicle as its heartbeat tells.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VehicleView {
    /// Heard in the last few seconds.
    pub heard: bool,
    /// Seconds since its last heartbeat.
    pub heartbeat_age_s: Option<f64>,
    /// The bootstrap's state.
    pub state: Option<&'static str>,
    /// The flight's controller, as asked at Start Logging.
    pub mode: Option<&'static str>,
    /// The phase the flight software is flying (the heartbeat's): what the helicopter
    /// actually does, which a refusal or a failsafe can make differ from the mode asked.
    pub phase: Option<&'static str>,
    /// Frames refused by the ground (bad, or wrongly signed).
    pub bad_frames: u64,
}

/// The battery meter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BatteryView {
    /// Volts.
    pub volts: f64,
    /// Percent of a full charge.
    pub percent: f64,
    /// Green: more than a third of its life left.
    pub green: bool,
    /// Where the percent comes from: `gauge` (the vehicle's fuel gauge) or `voltage` (the
    /// discharge curve, from a vehicle that sends no gauge).
    pub from: &'static str,
}

/// The GPS indicator: it follows the freshest fix, not the last count seen.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GpsView {
    /// Satellites of the last fix.
    pub satellites: u8,
    /// Green: five or more, in a fix that is fresh.
    pub ok: bool,
    /// The fix is old, or the vehicle says its GPS is not on time: the lamp is grey.
    pub stale: bool,
    /// How long ago the fix came (s).
    pub age_s: f64,
}

/// What the instruments draw (attitude indicator, track, plots, 3D view): the estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Instruments {
    /// The vehicle's time of the estimate (s).
    pub time_s: f64,
    /// Roll, pitch, yaw (rad).
    pub euler_rad: [f64; 3],
    /// Body rates (rad/s).
    pub rate_rps: [f64; 3],
    /// Position north, east, down from home (m).
    pub pos_ned_m: Option<[f64; 3]>,
    /// Servo commands (−1..1): aileron, elevator, rudder, collective, throttle.
    pub servo: Option<[f64; 5]>,
}

/// The operators.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OperatorsView {
    /// Pages open.
    pub pages: usize,
    /// Who holds the control token.
    pub holder: Option<ClientId>,
}

/// The log transfer under way.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TransferView {
    /// Where it goes.
    pub dest: String,
    /// Bytes received.
    pub received: u64,
    /// The log's size, once known.
    pub size: Option<u32>,
}

/// Everything the display shows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct View {
    /// The panel.
    pub panel: PanelView,
    /// The vehicle.
    pub vehicle: VehicleView,
    /// The uplink row's stick labels for the chosen controller.
    pub uplink_labels: [&'static str; 5],
    /// The rows of Fig. 2-4.
    pub rows: Rows,
    /// The battery meter, once a voltage came.
    pub battery: Option<BatteryView>,
    /// Every pack, the hot-swap's times and the field rule.
    pub power: crate::power_view::PowerView,
    /// The GPS indicator, once a fix came.
    pub gps: Option<GpsView>,
    /// The safety checks.
    pub safety: SafetyView,
    /// The instruments, once an estimate came.
    pub instruments: Option<Instruments>,
    /// The flight plan's points, once fetched from the vehicle.
    pub plan: Vec<PlanPoint>,
    /// The operators.
    pub operators: OperatorsView,
    /// The log transfer under way.
    pub transfer: Option<TransferView>,
    /// The message area's newest [`MESSAGES_IN_VIEW`] lines.
    pub messages: Vec<Message>,
}

impl Station {
    /// What the display shows at `now_us`.
    pub fn view(&self, now_us: u64) -> View {
        let status = self.vehicle_status(now_us);
        let mode = status
            .and_then(|s| s.flight_mode())
            .filter(|_| status.is_some_and(|s| s.state != heli_link::status::BootstrapState::Idle))
            .unwrap_or(self.chosen);
        let labels = uplink_labels(mode);
        let latest = &self.link.latest;
        let rows: Rows = rows(latest, &self.link.batteries, now_us, labels);
        let heartbeat_age_us = self
            .link
            .heartbeat
            .as_ref()
            .map(|(t, _)| now_us.saturating_sub(*t));
        let state = self.panel.state();
        let (connect, start, stop) = state.buttons();
        let battery = match latest.get(&SYS_STATUS_DATA::ID) {
            Some((_, MavMessage::SYS_STATUS(s))) if s.voltage_battery != u16::MAX => {
                let volts = f64::from(s.voltage_battery) / 1000.0;
                // The vehicle's gauge when it sends one; bare voltage only otherwise.
                let (percent, green, from) = if s.battery_remaining >= 0 {
                    let p = f64::from(s.battery_remaining);
                    (p, p > 100.0 / 3.0, "gauge")
                } else {
                    let (p, g) = battery_meter(&self.config.curve, volts);
                    (p, g, "voltage")
                };
                Some(BatteryView {
                    volts,
                    percent,
                    green,
                    from,
                })
            }
            _ => None,
        };
        let power = crate::power_view::power_view(&self.link, &self.field_rule, &self.packs);
        // The safety rule's `battery`: the meter green and no pack at its warning level.
        let battery_green = battery.as_ref().is_some_and(|b| b.green)
            && power
                .packs
                .iter()
                .all(|p| matches!(p.state, "good" | "unknown"));
        let facts = facts(latest, &rows, heartbeat_age_us, battery_green);
        let gps = match (latest.get(&GPS_RAW_INT_DATA::ID), rows.gps.as_ref()) {
            (Some((_, MavMessage::GPS_RAW_INT(g))), Some(row)) => Some(GpsView {
                satellites: g.satellites_visible,
                ok: gps_ok(g.satellites_visible) && !row.stale,
                stale: row.stale,
                age_s: row.age_s,
            }),
            _ => None,
        };
        let instruments = match latest.get(&ATTITUDE_DATA::ID) {
            Some((_, MavMessage::ATTITUDE(a))) => Some(Instruments {
                time_s: f64::from(a.time_boot_ms) / 1000.0,
                euler_rad: [a.roll, a.pitch, a.yaw].map(f64::from),
                rate_rps: [a.rollspeed, a.pitchspeed, a.yawspeed].map(f64::from),
                pos_ned_m: match latest.get(&LOCAL_POSITION_NED_DATA::ID) {
                    Some((_, MavMessage::LOCAL_POSITION_NED(p))) => {
                        Some([p.x, p.y, p.z].map(f64::from))
                    }
                    _ => None,
                },
                servo: match latest.get(&SERVO_OUTPUT_RAW_DATA::ID) {
                    Some((_, MavMessage::SERVO_OUTPUT_RAW(s))) => Some(
                        [
                            s.servo1_raw,
                            s.servo2_raw,
                            s.servo3_raw,
                            s.servo4_raw,
                            s.servo5_raw,
                        ]
                        .map(|us| (f64::from(us) - 1500.0) / 500.0),
                    ),
                    _ => None,
                },
            }),
            _ => None,
        };
        View {
            panel: PanelView {
                state,
                connect,
                start,
                stop,
                green: state.green(),
                telemetry_count: self
                    .link
                    .counts
                    .get(&SCALED_IMU_DATA::ID)
                    .copied()
                    .unwrap_or(0),
            },
            vehicle: VehicleView {
                heard: status.is_some(),
                heartbeat_age_s: heartbeat_age_us.map(|a| a as f64 / 1e6),
                state: status.map(|s| s.state.name()),
                mode: status.and_then(|s| s.flight_mode()).map(|m| m.name()),
                phase: status.and_then(|s| s.phase_name()),
                bad_frames: self.link.bad_frames,
            },
            uplink_labels: labels,
            rows,
            battery,
            power,
            gps,
            safety: safety_view(facts),
            instruments,
            plan: self
                .link
                .mission
                .plan()
                .map(plan_points)
                .unwrap_or_default(),
            operators: OperatorsView {
                pages: self.operators.count(),
                holder: self.operators.holder(),
            },
            transfer: self.transfer.as_ref().map(|t| {
                let p = t.progress(&self.link);
                TransferView {
                    dest: t.dest().display().to_string(),
                    received: p.map_or(0, |(r, _)| r),
                    size: p.map(|(_, s)| s),
                }
            }),
            // The newest lines only: a page keeps what it has seen (by sequence number).
            messages: self.messages.newest(MESSAGES_IN_VIEW),
        }
    }
}
