//! The flight plan over MAVLink's mission protocol, so that a ground station can draw it: the
//! vehicle serves the plan of the flight under way (download only), and the ground fetches
//! it item by item.
//!
//! The plan is the one chosen at Start Logging, as legs (docs/scenarios.md). Each leg becomes
//! one or two `MISSION_ITEM_INT`s in `MAV_FRAME_LOCAL_NED`, relative to the take-off point
//! (x north and y east in 1/10 000 m, z down in m):
//!
//! | leg | mission items |
//! |---|---|
//! | takeoff | `NAV_TAKEOFF_LOCAL` at the height |
//! | hold | `NAV_LOITER_TIME` (param1: seconds), or `NAV_LOITER_UNLIM` for a hold without end |
//! | fly | `DO_CHANGE_SPEED` (param2: the path speed), then `NAV_WAYPOINT` at the point |
//! | rolls | `MAV_CMD_USER_4` (param1: how many, param2: the trim speed), where the rolls begin |
//! | land | `NAV_LAND_LOCAL` below the last point |
//!
//! A plan cannot be uploaded: the vehicle flies only plans it knows by name; an upload is
//! answered `MAV_MISSION_UNSUPPORTED`.

use heli_types::Leg;
use mavlink::dialects::common::*;
use serde::Serialize;

/// The mission command for aileron rolls (no standard command exists).
pub const CMD_ROLLS: MavCmd = MavCmd::MAV_CMD_USER_4;

/// The legs of a plan from the flight process's JSON.
pub fn parse_plan(json: &str) -> Result<Vec<Leg>, serde_json::Error> {
    serde_json::from_str(json)
}

fn local(m: f64) -> i32 {
    let v = (m * 1e4).round();
    if v.is_finite() {
        v.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
    } else {
        0
    }
}

/// The mission items of `legs` (`seq` from 0).
pub fn mission_items(legs: &[Leg]) -> Vec<MISSION_ITEM_INT_DATA> {
    let mut items = Vec::new();
    let (mut north, mut east, mut alt) = (0.0, 0.0, 0.0);
    let mut push = |command: MavCmd, params: [f32; 4], at: (f64, f64, f64)| {
        let seq = u16::try_from(items.len()).unwrap_or(u16::MAX);
        items.push(MISSION_ITEM_INT_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            x: local(at.0),
            y: local(at.1),
            z: -(at.2 as f32),
            seq,
            command,
            target_system: crate::frame::GROUND.system,
            target_component: crate::frame::GROUND.component,
            frame: MavFrame::MAV_FRAME_LOCAL_NED,
            current: u8::from(seq == 0),
            autocontinue: 1,
        });
    };
    for leg in legs {
        match *leg {
            Leg::Takeoff { alt_m } => {
                alt = alt_m;
                push(
                    MavCmd::MAV_CMD_NAV_TAKEOFF_LOCAL,
                    [0.0; 4],
                    (north, east, alt),
                );
            }
            Leg::Hold { seconds } if seconds.is_finite() => push(
                MavCmd::MAV_CMD_NAV_LOITER_TIME,
                [seconds as f32, 0.0, 0.0, 0.0],
                (north, east, alt),
            ),
            Leg::Hold { .. } => push(
                MavCmd::MAV_CMD_NAV_LOITER_UNLIM,
                [0.0; 4],
                (north, east, alt),
            ),
            Leg::Fly {
                north_m,
                east_m,
                alt_m,
                speed_mps,
            } => {
                push(
                    MavCmd::MAV_CMD_DO_CHANGE_SPEED,
                    [1.0, speed_mps as f32, -1.0, 0.0],
                    (north, east, alt),
                );
                (north, east, alt) = (north_m, east_m, alt_m);
                push(MavCmd::MAV_CMD_NAV_WAYPOINT, [0.0; 4], (north, east, alt));
            }
            Leg::Rolls { count, speed_mps } => push(
                CMD_ROLLS,
                [count as f32, speed_mps as f32, 0.0, 0.0],
                (north, east, alt),
            ),
            Leg::Land => {
                alt = 0.0;
                push(MavCmd::MAV_CMD_NAV_LAND_LOCAL, [0.0; 4], (north, east, alt));
            }
        }
    }
    items
}

/// A mission item's point: north, east (m) and height (m) above the take-off point.
pub fn item_point(item: &MISSION_ITEM_INT_DATA) -> [f64; 3] {
    [
        f64::from(item.x) / 1e4,
        f64::from(item.y) / 1e4,
        -f64::from(item.z),
    ]
}

/// A point of the flight plan, for the track and the 3D view.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanPoint {
    /// takeoff, hold, waypoint, rolls or land.
    pub kind: &'static str,
    /// North, east (m) and height (m) above the take-off point.
    pub point: [f64; 3],
}

/// The plan's points from its mission items (speed changes are not points).
pub fn plan_points(items: &[MISSION_ITEM_INT_DATA]) -> Vec<PlanPoint> {
    items
        .iter()
        .filter_map(|i| {
            let kind = match i.command {
                MavCmd::MAV_CMD_NAV_TAKEOFF_LOCAL => "takeoff",
                MavCmd::MAV_CMD_NAV_LOITER_TIME | MavCmd::MAV_CMD_NAV_LOITER_UNLIM => "hold",
                MavCmd::MAV_CMD_NAV_WAYPOINT => "waypoint",
                MavCmd::MAV_CMD_NAV_LAND_LOCAL => "land",
                c if c == CMD_ROLLS => "rolls",
                _ => return None,
            };
            Some(PlanPoint {
                kind,
                point: item_point(i),
            })
        })
        .collect()
}

/// The vehicle's side: the items of the flight under way, served on request.
#[derive(Clone, Debug, Default)]
pub struct MissionServer {
    items: Vec<MISSION_ITEM_INT_DATA>,
}

impl MissionServer {
    /// The plan of the flight under way (empty: none).
    pub fn set(&mut self, items: Vec<MISSION_ITEM_INT_DATA>) {
        self.items = items;
    }

    /// The items served.
    pub fn items(&self) -> &[MISSION_ITEM_INT_DATA] {
        &self.items
    }

    /// The answer to a mission message from the ground, if it is one. The deprecated
    /// `MISSION_REQUEST` is answered with `MISSION_ITEM_INT`, as the specification asks, and
    /// the deprecated `MISSION_ITEM` upload is refused like any upload.
    #[allow(deprecated)]
    pub fn answer(&self, message: &MavMessage) -> Option<MavMessage> {
        let ack = |mavtype| {
            MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: crate::frame::GROUND.system,
                target_component: crate::frame::GROUND.component,
                mavtype,
            })
        };
        let item = |seq: u16| match self.items.get(usize::from(seq)) {
            Some(i) => MavMessage::MISSION_ITEM_INT(i.clone()),
            None => ack(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE),
        };
        match message {
            MavMessage::MISSION_REQUEST_LIST(_) => {
                Some(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                    count: u16::try_from(self.items.len()).unwrap_or(u16::MAX),
                    target_system: crate::frame::GROUND.system,
                    target_component: crate::frame::GROUND.component,
                }))
            }
            MavMessage::MISSION_REQUEST_INT(r) => Some(item(r.seq)),
            MavMessage::MISSION_REQUEST(r) => Some(item(r.seq)),
            MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_CLEAR_ALL(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_ITEM(_) => Some(ack(MavMissionResult::MAV_MISSION_UNSUPPORTED)),
            _ => None,
        }
    }
}

/// The ground's side: fetches the vehicle's plan, one item at a time, asking again for what
/// does not come.
#[derive(Clone, Debug, Default)]
pub struct MissionClient {
    count: Option<u16>,
    items: Vec<MISSION_ITEM_INT_DATA>,
    asked_us: Option<u64>,
    done: bool,
    /// The vehicle said it has no plan (yet): asked again every [`MISSION_EMPTY_RETRY_US`].
    empty: bool,
}

/// A mission request with no answer for this long (µs) is sent again.
pub const MISSION_RETRY_US: u64 = 500_000;

/// How often a vehicle that said it has no plan is asked again (µs): a flight process
/// reports its plan a moment after the heartbeat says it flies, and a ground that asked in
/// that moment would otherwise show no plan for the whole flight.
pub const MISSION_EMPTY_RETRY_US: u64 = 2_000_000;

impl MissionClient {
    /// Starts again from nothing (a new flight's plan).
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// The whole plan, once every item has come (empty while the vehicle says it has none).
    pub fn plan(&self) -> Option<&[MISSION_ITEM_INT_DATA]> {
        (self.done || self.empty).then_some(self.items.as_slice())
    }

    /// Takes a message from the vehicle.
    pub fn receive(&mut self, message: &MavMessage) {
        match message {
            MavMessage::MISSION_COUNT(c) if self.count.is_none() && !self.done => {
                if c.count == 0 {
                    // None yet: asked again in a while (the request's time is kept).
                    self.empty = true;
                } else {
                    self.empty = false;
                    self.count = Some(c.count);
                    self.asked_us = None;
                }
            }
            MavMessage::MISSION_ITEM_INT(i)
                if !self.done && usize::from(i.seq) == self.items.len() =>
            {
                self.items.push(i.clone());
                self.asked_us = None;
                self.done = self
                    .count
                    .is_some_and(|n| self.items.len() >= usize::from(n));
            }
            _ => {}
        }
    }

    /// The next request to send, if one is due.
    pub fn request(&mut self, now_us: u64) -> Option<MavMessage> {
        let wait_us = if self.empty {
            MISSION_EMPTY_RETRY_US
        } else {
            MISSION_RETRY_US
        };
        if self.done
            || self
                .asked_us
                .is_some_and(|t| now_us.saturating_sub(t) < wait_us)
        {
            return None;
        }
        self.asked_us = Some(now_us);
        let target_system = crate::frame::VEHICLE.system;
        let target_component = crate::frame::VEHICLE.component;
        Some(match self.count {
            None => MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
                target_system,
                target_component,
            }),
            Some(_) => MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq: u16::try_from(self.items.len()).unwrap_or(u16::MAX),
                target_system,
                target_component,
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEMO: &str = r#"[{"leg":"takeoff","alt_m":10.0},{"leg":"hold","seconds":5.0},
        {"leg":"fly","north_m":50.0,"east_m":-20.0,"alt_m":20.0,"speed_mps":4.0},
        {"leg":"rolls","count":3,"speed_mps":8.0},{"leg":"hold","seconds":null},{"leg":"land"}]"#;

    #[test]
    fn a_plan_becomes_local_mission_items_with_its_points() {
        let legs = parse_plan(DEMO).unwrap();
        let items = mission_items(&legs);
        let commands: Vec<MavCmd> = items.iter().map(|i| i.command).collect();
        assert_eq!(
            commands,
            [
                MavCmd::MAV_CMD_NAV_TAKEOFF_LOCAL,
                MavCmd::MAV_CMD_NAV_LOITER_TIME,
                MavCmd::MAV_CMD_DO_CHANGE_SPEED,
                MavCmd::MAV_CMD_NAV_WAYPOINT,
                CMD_ROLLS,
                MavCmd::MAV_CMD_NAV_LOITER_UNLIM,
                MavCmd::MAV_CMD_NAV_LAND_LOCAL,
            ]
        );
        assert_eq!(item_point(&items[0]), [0.0, 0.0, 10.0]);
        assert_eq!(item_point(&items[3]), [50.0, -20.0, 20.0]);
        assert_eq!(items[3].frame, MavFrame::MAV_FRAME_LOCAL_NED);
        assert_eq!(items[4].param1, 3.0);
        assert_eq!(item_point(&items[6]), [50.0, -20.0, 0.0]);
        assert!(
            items
                .iter()
                .enumerate()
                .all(|(k, i)| usize::from(i.seq) == k)
        );
        assert!(parse_plan("[{\"leg\":\"loop\"}]").is_err());
    }

    #[test]
    fn the_ground_fetches_the_plan_item_by_item_through_losses() {
        let mut server = MissionServer::default();
        server.set(mission_items(&parse_plan(DEMO).unwrap()));
        let mut client = MissionClient::default();
        let mut t = 0;
        let mut lost = 0;
        while client.plan().is_none() && t < 20_000_000 {
            t += 100_000;
            if let Some(req) = client.request(t) {
                // Every third exchange is lost.
                lost += 1;
                if lost % 3 == 0 {
                    continue;
                }
                if let Some(answer) = server.answer(&req) {
                    client.receive(&answer);
                }
            }
        }
        assert_eq!(client.plan().map(<[_]>::len), Some(7));
        assert_eq!(client.plan().unwrap(), server.items());
        // An upload is refused; a request past the end is an invalid sequence.
        let upload = MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: 1,
            target_system: 1,
            target_component: 1,
        });
        assert!(matches!(
            server.answer(&upload),
            Some(MavMessage::MISSION_ACK(a)) if a.mavtype == MavMissionResult::MAV_MISSION_UNSUPPORTED
        ));
        let past = MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: 99,
            target_system: 1,
            target_component: 1,
        });
        assert!(matches!(
            server.answer(&past),
            Some(MavMessage::MISSION_ACK(a)) if a.mavtype == MavMissionResult::MAV_MISSION_INVALID_SEQUENCE
        ));
    }

    #[test]
    fn a_plan_the_vehicle_has_not_yet_is_asked_for_again_until_it_comes() {
        let mut server = MissionServer::default();
        let mut client = MissionClient::default();
        let exchange = |client: &mut MissionClient, server: &MissionServer, t: u64| {
            let req = client.request(t);
            if let Some(answer) = req.as_ref().and_then(|r| server.answer(r)) {
                client.receive(&answer);
            }
            req.is_some()
        };
        // Asked as the flight begins, before the flight process has told its plan.
        assert!(exchange(&mut client, &server, 0));
        assert_eq!(client.plan().map(<[_]>::len), Some(0), "none yet");
        assert!(!exchange(&mut client, &server, MISSION_RETRY_US));
        assert!(!exchange(&mut client, &server, MISSION_EMPTY_RETRY_US - 1));
        server.set(mission_items(&parse_plan(DEMO).unwrap()));
        let mut t = MISSION_EMPTY_RETRY_US;
        while client.plan().map(<[_]>::len) != Some(7) && t < 10_000_000 {
            exchange(&mut client, &server, t);
            t += 100_000;
        }
        assert_eq!(client.plan().unwrap(), server.items());
        // Fetched: not asked again.
        assert!(!exchange(&mut client, &server, t + 60_000_000));
    }
}
