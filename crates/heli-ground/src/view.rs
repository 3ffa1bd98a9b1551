//! What the display shows, as one value the web page draws: [`View`], made by
//! [`Station::view`] and sent to every page several times a second.

use heli_link::mission::{PlanPoint, plan_points};
use heli_link::telemetry::level_of_percent;
use mavlink::MessageData;
use mavlink::dialects::common::*;
use serde::Serialize;

use crate::checks::{battery_meter, gps_ok};
use crate::display::uplink_labels;
use crate::facts::{SafetyView, Standing, Why, facts, safety_view};
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
    /// Kill is active (a flight process is up).
    pub kill: bool,
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
    /// A refusal of the vehicle that stands until the pilot clears it (a refused take-off,
    /// a refused augmented mode): shown until the phase says it is over.
    pub standing: Option<String>,
    /// Whether it flies what the lab tested, and its statement.
    pub lab: crate::lab::LabView,
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
    /// The reading is older than the telemetry allows (no flight sends it now): the meter is
    /// grey, with its age.
    pub stale: bool,
    /// How long ago the reading came (s).
    pub age_s: f64,
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
    /// The message area's newest [`MESSAGES_IN_VIEW`] changes.
    pub messages: Vec<Message>,
    /// The errors and critical events no operator has acknowledged.
    pub pinned: Vec<Message>,
    /// The last command and what became of it.
    pub command: Option<crate::station::CommandView>,
    /// The parameters of the flight this station started, while it flies.
    pub flight: Option<crate::station::FlightParams>,
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
            Some((at, MavMessage::SYS_STATUS(s))) if s.voltage_battery != u16::MAX => {
                let age_us = now_us.saturating_sub(*at);
                let volts = f64::from(s.voltage_battery) / 1000.0;
                // The vehicle's gauge when it sends one: its charge, and its level's
                // colour (the number judged again only when no level came); bare voltage
                // only otherwise.
                let (percent, green, from) = if s.battery_remaining >= 0 {
                    let p = f64::from(s.battery_remaining);
                    let level = crate::power_view::vehicle_level(&self.link, "FLT_LVL", now_us)
                        .unwrap_or_else(|| level_of_percent(p));
                    (p, level == "good", "gauge")
                } else {
                    let (p, g) = battery_meter(&self.config.curve, volts);
                    (p, g, "voltage")
                };
                let stale = age_us > crate::rows::STALE_AFTER_US;
                Some(BatteryView {
                    volts,
                    percent,
                    green: green && !stale,
                    from,
                    stale,
                    age_s: age_us as f64 * 1e-6,
                })
            }
            _ => None,
        };
        let power =
            crate::power_view::power_view(&self.link, &self.field_rule, &self.packs, now_us);
        // The safety rule's `battery`: the meter green and no pack at its warning level.
        let battery_green = battery.as_ref().is_some_and(|b| b.green)
            && power
                .packs
                .iter()
                .all(|p| matches!(p.state, "good" | "unknown"));
        let flying = status.is_some_and(|s| s.state == heli_link::status::BootstrapState::Flying);
        let facts = facts(latest, &rows, heartbeat_age_us, battery_green, flying);
        let why = self.why(
            &rows,
            battery.as_ref().map(|b| (b.stale, b.age_s)),
            heartbeat_age_us,
            status.and_then(|s| s.phase_name()),
        );
        let standing = self.standing(status);
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
                kill: state.kill_active(),
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
                standing: standing.as_ref().map(|s| s.text.clone()),
                lab: crate::lab::view(
                    status.map(|s| s.tested).unwrap_or_default(),
                    self.lab_statement.as_deref(),
                ),
            },
            uplink_labels: labels,
            rows,
            battery,
            power,
            gps,
            safety: safety_view(facts, &why, standing.as_ref()),
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
            pinned: self.messages.pinned(),
            command: self.command.clone(),
            flight: self.flight_params.clone(),
        }
    }
}

impl Station {
    /// Why each false condition is false, where the ground knows more than the rule's words:
    /// a row never received, a row gone stale (with its age), a battery not read (or not for
    /// long), a vehicle not heard.
    fn why(
        &self,
        rows: &Rows,
        battery: Option<(bool, f64)>,
        heartbeat_age_us: Option<u64>,
        phase: Option<&str>,
    ) -> Why {
        use heli_control::safety::Condition as C;
        let mut why = Vec::new();
        // A stale row is old, or fresh with the vehicle's watchdog saying the device is
        // not on time: the words say which.
        let stale_for = |r: &crate::rows::Row, what: &str| {
            if r.age_s * 1e6 >= crate::rows::STALE_AFTER_US as f64 {
                format!("no {what} telemetry for {:.1} s", r.age_s)
            } else {
                format!("the vehicle's watchdog says the {what} is not on time")
            }
        };
        let mut row = |c: C, r: &Option<crate::rows::Row>, what: &str| match r {
            None => why.push((c, format!("no {what} telemetry yet"))),
            Some(r) if r.stale => {
                why.push((c, format!("{} ({})", c.missing(), stale_for(r, what))))
            }
            Some(_) => {}
        };
        row(C::Imu, &rows.imu, "IMU");
        row(C::Uplink, &rows.uplink, "uplink");
        row(C::Gps, &rows.gps, "GPS");
        row(C::Altimeter, &rows.bar, "altimeter");
        row(C::Compass, &rows.cmps, "compass");
        // Not calibrated yet, the rule's own words say it ("still calibrating": no estimate
        // is sent before); an estimate that stopped coming says so.
        // No estimate coming (none since the flight process began, or stopped since).
        let no_estimate = rows.state.as_ref().is_none_or(|r| r.stale);
        match phase {
            // An estimate lost: the helicopter will not go on this flight process, whatever
            // the calibration did. (The ground failsafe with an estimate running is the skids'
            // answer to a lost transmitter: the transmitter's condition says so.)
            Some("ground-failsafe") if no_estimate => why.push((
                C::Calibrated,
                "the estimate was lost: the vehicle holds its ground failsafe (Stop, then Connect for a new flight process)".into(),
            )),
            Some("blind-descent") => why.push((
                C::Calibrated,
                "the estimate was lost: the vehicle descends blind".into(),
            )),
            // Calibrated once, the estimate has stopped coming (an IMU stall in manual flight
            // on the ground, say): not "still calibrating".
            _ if phase != Some("calibrating") && rows.state.as_ref().is_some_and(|r| r.stale) => {
                if let Some(r) = &rows.state {
                    why.push((
                        C::Calibrated,
                        format!("no estimate running ({})", stale_for(r, "state")),
                    ));
                }
            }
            _ => {}
        }
        match &rows.gps {
            None => why.push((
                C::Satellites,
                "satellites not known: no GPS telemetry yet".into(),
            )),
            Some(r) if r.stale => why.push((
                C::Satellites,
                format!("satellites not known ({})", stale_for(r, "GPS")),
            )),
            Some(_) => {}
        }
        match battery {
            None => why.push((C::Battery, "no battery reading yet".into())),
            Some((true, age_s)) => {
                why.push((C::Battery, format!("no battery reading for {age_s:.1} s")));
            }
            Some(_) => {}
        }
        match heartbeat_age_us {
            None => why.push((C::Link, "the vehicle has not been heard".into())),
            Some(a) if a >= crate::facts::LINK_FRESH_US => why.push((
                C::Link,
                format!("no heartbeat from the vehicle for {:.1} s", a as f64 / 1e6),
            )),
            Some(_) => {}
        }
        Why(why)
    }

    /// The vehicle's refusal that stands now, from its phase and what it said: a refused
    /// take-off (until the auto switch is cycled), or an augmented or automatic mode refused
    /// in the air (the pilot flies manual until the switch is taken off).
    fn standing(&self, status: Option<heli_link::status::VehicleStatus>) -> Option<Standing> {
        use heli_control::safety::{AUGMENTED, AUTOMATIC};
        let status = status?;
        let phase = status.phase_name()?;
        if phase == "takeoff-refused" {
            let said = self
                .refusals
                .takeoff
                .as_deref()
                .unwrap_or("take-off refused");
            return Some(Standing {
                rule: AUTOMATIC,
                text: format!(
                    "the vehicle refused the take-off ({said}): take the auto switch off and on again to retry"
                ),
            });
        }
        let asked = status.flight_mode()?;
        let said = self.refusals.mode.as_deref()?;
        let auto_on = match self.link.latest.get(&RC_CHANNELS_DATA::ID) {
            Some((_, MavMessage::RC_CHANNELS(rc))) => rc.chan6_raw > 1500,
            _ => false,
        };
        if phase != "manual" || asked == heli_types::FlightMode::Manual || !auto_on {
            return None;
        }
        Some(Standing {
            rule: if asked == heli_types::FlightMode::Autonomous {
                AUTOMATIC
            } else {
                AUGMENTED
            },
            text: format!(
                "the vehicle flies manual: {said}; take the auto switch off and on again to retry"
            ),
        })
    }
}

impl Station {
    /// What an autonomous take-off would wait for now, on the telemetry that is there: the
    /// conditions of the automatic rule that fresh data says are false (the calibration,
    /// which Start Logging begins, and data not received yet are left out). `None` for a
    /// controller that does not take off by itself, or with nothing to wait for.
    pub(crate) fn takeoff_wait(&self, mode: heli_types::FlightMode) -> Option<String> {
        if mode != heli_types::FlightMode::Autonomous {
            return None;
        }
        let view = self.view(self.now_us());
        let waits: Vec<String> = view
            .safety
            .conditions
            .iter()
            .filter(|c| c.value != c.wanted && c.name != "calibrated" && c.name != "link")
            .filter(|c| !c.why.as_deref().is_some_and(|w| w.starts_with("no ")))
            .map(|c| {
                let missing = heli_control::safety::Condition::ALL
                    .into_iter()
                    .find(|k| k.name() == c.name)
                    .map_or(c.meaning, |k| k.missing());
                c.why.clone().unwrap_or_else(|| missing.to_string())
            })
            .collect();
        (!waits.is_empty()).then(|| waits.join(", "))
    }
}
