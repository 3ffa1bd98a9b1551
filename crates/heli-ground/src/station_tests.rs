//! The station against the vehicle's link, with no sockets: a small stand-in for the
//! bootstrap answers Connect, Start Logging and Stop as the real one does.

use std::path::PathBuf;

use heli_link::GroundCommand;
use heli_link::logs::MemoryStore;
use heli_link::status::{BootstrapState, VehicleStatus};
use heli_link::telemetry::{
    CompassRow, DeviceHealth, GpsRow, ImuRow, StateRow, Telemetry, UplinkRow,
};
use heli_link::vehicle::{CommandOutcome, LinkEvent, VehicleLink};
use mavlink::dialects::common::MavSeverity;

use crate::checks::BatteryCurve;
use crate::panel::PanelState;
use crate::station::{Output, Station, StationConfig};

const T0: u64 = 1_763_900_000_000_000;

/// The flight's plan, as the flight process reports it.
const PLAN: &str = r#"[{"leg":"takeoff","alt_m":10.0},{"leg":"hold","seconds":5.0},
    {"leg":"fly","north_m":30.0,"east_m":0.0,"alt_m":10.0,"speed_mps":3.0},{"leg":"land"}]"#;

pub(crate) struct Bench {
    pub(crate) vehicle: VehicleLink,
    pub(crate) station: Station,
    pub(crate) state: BootstrapState,
    pub(crate) mode: u8,
    pub(crate) store: MemoryStore,
    pub(crate) t: u64,
    pub(crate) telemetry: Option<Telemetry>,
    pub(crate) fail_start: bool,
    /// The vehicle refuses Start Logging with this reason, staying connected.
    pub(crate) refuse_start: Option<String>,
    pub(crate) commands: Vec<GroundCommand>,
    pub(crate) saved: Vec<(PathBuf, Vec<u8>)>,
    /// The helicopter is in the air under the computer: a Stop lands first (the vehicle
    /// stays stopping until the test lands it).
    pub(crate) land_first: bool,
    /// What the vehicle's heartbeat says of the lab attestation.
    pub(crate) tested: heli_link::status::Tested,
}

pub(crate) fn flying_telemetry(phase: &str) -> Telemetry {
    let ok = |d: &str| DeviceHealth {
        device: d.into(),
        state: "ok".into(),
        lapses: 0,
    };
    Telemetry {
        t_us: 1,
        phase: None,
        imu: Some(ImuRow {
            rate_rps: [0.0; 3],
            accel_mps2: [0.0, 0.0, -9.81],
        }),
        state: Some(StateRow {
            phase: phase.into(),
            ..StateRow::default()
        }),
        uplink: Some(UplinkRow {
            pulses_us: [1500; 5],
            auto_mode: true,
            bypass: false,
            rotor_rpm: 1600,
            receiver_batt_v: 4.8,
            servo_batt_v: 4.9,
        }),
        gps: Some(GpsRow {
            lat_deg: 42.36,
            lon_deg: -71.09,
            alt_m: 10.0,
            vel_ned_mps: [0.0; 3],
            satellites: 8,
            fix_3d: true,
            age_s: 0.25,
        }),
        compass: Some(CompassRow {
            field_gauss: [0.2, 0.0, 0.45],
            heading_rad: Some(0.0),
        }),
        battery_v: Some(12.4),
        health: ["imu", "uplink", "gps", "baro", "compass"]
            .into_iter()
            .map(ok)
            .collect(),
        ..Telemetry::default()
    }
}

use crate::transfer::tests::flight_log;

impl Bench {
    pub(crate) fn new() -> Self {
        let mut b = Self {
            vehicle: VehicleLink::new(None, T0),
            station: Station::new(StationConfig {
                save_root: PathBuf::from("/ground"),
                curve: BatteryCurve::default(),
                key: None,
                link_id: 1,
                packs: crate::pack_log::PackLog::parse(
                    "[[pack]]\nname = \"F1\"\nrole = \"flight\"\n[[pack]]\nname = \"G\"\nrole = \"ground\"\n",
                    None,
                )
                .unwrap(),
                packs_totals: Some(PathBuf::from("/ground/packs.times.json")),
            }),
            state: BootstrapState::Idle,
            mode: 0,
            store: MemoryStore::default(),
            t: T0,
            telemetry: None,
            fail_start: false,
            refuse_start: None,
            commands: Vec::new(),
            saved: Vec::new(),
            land_first: false,
            tested: heli_link::status::Tested::Unknown,
        };
        b.run(1.5);
        b
    }

    fn deliver_up(&mut self, frames: Vec<Vec<u8>>) {
        for f in frames {
            let events = self.vehicle.receive(&f, self.t, &self.store);
            for e in events {
                if let LinkEvent::Command { token, command } = e {
                    self.commands.push(command.clone());
                    let result = match command {
                        GroundCommand::Connect => {
                            self.state = BootstrapState::Connected;
                            CommandOutcome::Accepted("connected".to_string())
                        }
                        GroundCommand::StartLogging(_) if self.refuse_start.is_some() => {
                            // Refused up front: the flight process waits, connected.
                            CommandOutcome::Failed(self.refuse_start.clone().unwrap_or_default())
                        }
                        GroundCommand::StartLogging(_) if self.fail_start => {
                            self.state = BootstrapState::Idle;
                            CommandOutcome::Failed("the flight process exited".to_string())
                        }
                        GroundCommand::StartLogging(p) => {
                            self.state = BootstrapState::Flying;
                            // The flight process creates its log.
                            self.store.logs.push((
                                format!("flight_{}.mcap", p.file_suffix),
                                flight_log(&p.file_suffix),
                            ));
                            let legs = heli_link::mission::parse_plan(PLAN).unwrap();
                            self.vehicle
                                .set_mission(heli_link::mission::mission_items(&legs));
                            // The heartbeat's mode code: 1 + the controller's place in the list.
                            self.mode = heli_types::FlightMode::ALL
                                .iter()
                                .position(|m| *m == p.controller)
                                .map_or(0, |i| i as u8 + 1);
                            self.telemetry = Some(flying_telemetry("calibrating"));
                            CommandOutcome::Accepted("flying".to_string())
                        }
                        GroundCommand::Stop if self.land_first => {
                            self.state = BootstrapState::Stopping;
                            CommandOutcome::Accepted(format!(
                                "{} (t=30.00 s stop in the air: landing where it is first)",
                                heli_link::messages::LANDING_FIRST
                            ))
                        }
                        GroundCommand::Stop | GroundCommand::Kill => {
                            self.state = BootstrapState::Idle;
                            self.telemetry = None;
                            CommandOutcome::Accepted("stopped".to_string())
                        }
                        _ => CommandOutcome::Accepted(String::new()),
                    };
                    self.vehicle.finish(token, result, self.t);
                }
            }
        }
    }

    /// Runs both ends for `seconds` in 10 ms steps.
    pub(crate) fn run(&mut self, seconds: f64) {
        let steps = (seconds * 100.0).round() as u32;
        for _ in 0..steps {
            self.t += 10_000;
            let status = VehicleStatus {
                state: self.state,
                mode: self.mode,
                phase: 0,
                tested: self.tested,
            };
            self.vehicle
                .tick(self.t, status, self.telemetry.as_ref(), &self.store);
            for d in self.vehicle.take_outgoing() {
                self.station.receive(&d, self.t);
            }
            let mut up = Vec::new();
            for out in self.station.tick(self.t) {
                match out {
                    Output::Send(f) => up.push(f),
                    Output::Save(p, bytes) => {
                        self.station.saved(&p, Ok(p.clone()));
                        self.saved.push((p, bytes));
                    }
                    Output::Write(p, bytes) => self.saved.push((p, bytes)),
                }
            }
            self.deliver_up(up);
        }
    }

    pub(crate) fn ask(&mut self, client: u64, json: &str) -> Result<String, String> {
        let r = self.station.request(client, json, self.t);
        let frames = self.station.take_outbox();
        self.deliver_up(frames);
        r.map_err(|e| e.to_string())
    }

    /// A page that took control and connected (its requests 1 and 2).
    pub(crate) fn connected_operator(&mut self) -> u64 {
        let op = self.station.join();
        self.ask(op, r#"{"seq":1,"op":"take"}"#).unwrap();
        self.ask(op, r#"{"seq":2,"op":"connect"}"#).unwrap();
        self.run(1.0);
        op
    }

    /// A page that took control, connected and started flight `suffix` with `controller`
    /// (its requests 1 to 3), a second later.
    pub(crate) fn flying_operator(&mut self, suffix: &str, controller: &str) -> u64 {
        let op = self.connected_operator();
        let start =
            format!(r#"{{"seq":3,"op":"start","suffix":"{suffix}","controller":"{controller}"}}"#);
        self.ask(op, &start).unwrap();
        self.run(1.0);
        op
    }

    pub(crate) fn panel(&self) -> PanelState {
        self.station.view(self.t).panel.state
    }

    pub(crate) fn messages(&self) -> String {
        self.station
            .view(self.t)
            .messages
            .iter()
            .map(|m| m.text.clone())
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[test]
fn connect_start_and_stop_follow_section_2_4_and_the_log_is_saved_by_the_final_parameters() {
    let mut b = Bench::new();
    let op = b.station.join();
    assert_eq!(b.panel(), PanelState::Idle);
    b.ask(op, r#"{"seq":1,"op":"take"}"#).unwrap();
    b.ask(op, r#"{"seq":2,"op":"connect"}"#).unwrap();
    assert_eq!(
        b.panel(),
        PanelState::Connecting,
        "no button while it is on its way"
    );
    b.run(1.0);
    let v = b.station.view(b.t);
    assert_eq!(v.panel.state, PanelState::Connected);
    assert!(v.panel.green && !v.panel.connect && v.panel.start && v.panel.stop);
    assert!(v.rows.imu.is_none(), "NOTHING YET");
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f1","controller":"autonomous","plan":"hover"}"#,
    )
    .unwrap();
    b.run(1.0);
    let v = b.station.view(b.t);
    assert_eq!(v.panel.state, PanelState::Logging);
    assert_eq!(
        (v.panel.connect, v.panel.start, v.panel.stop),
        (false, false, true)
    );
    // Calibrating: the automatic verdict names it.
    assert!(!v.safety.automatic.allowed);
    assert!(
        v.safety.automatic.failing.contains("still calibrating"),
        "{}",
        v.safety.automatic.failing
    );
    b.telemetry = Some(flying_telemetry("hold"));
    let count0 = v.panel.telemetry_count;
    b.run(3.0);
    let v = b.station.view(b.t);
    let rate = (v.panel.telemetry_count - count0) as f64 / 3.0;
    assert!(
        (2.6..=3.4).contains(&rate),
        "{rate} telemetry messages a second"
    );
    assert!(v.rows.imu.is_some() && v.rows.uplink.is_some() && v.rows.gps.is_some());
    // The flight's plan came over the mission protocol, for the track.
    let kinds: Vec<&str> = v.plan.iter().map(|p| p.kind).collect();
    assert_eq!(kinds, ["takeoff", "hold", "waypoint", "land"]);
    assert_eq!(v.plan[2].point, [30.0, 0.0, 10.0]);
    assert!(v.safety.augmented.allowed, "{:?}", v.safety.augmented);
    // The uplink row carries the board's batteries and the rotor speed.
    let uplink = v.rows.uplink.as_ref().unwrap();
    let cell = |l: &str| {
        uplink
            .cells
            .iter()
            .find(|c| c.label == l)
            .unwrap()
            .value
            .clone()
    };
    assert_eq!(cell("RTXB V"), "4.80");
    assert_eq!(cell("RPM"), "1600");
    // Stop with the final parameters: the newest log is saved where they say.
    b.ask(
        op,
        r#"{"seq":4,"op":"stop","base_dir":"day1","suffix":"mine"}"#,
    )
    .unwrap();
    b.run(5.0);
    let v = b.station.view(b.t);
    assert_eq!(
        (v.panel.connect, v.panel.start, v.panel.stop),
        (true, false, false)
    );
    assert_eq!(
        b.saved.len(),
        1,
        "{}\n{:?}",
        b.messages(),
        b.saved.iter().map(|s| &s.0).collect::<Vec<_>>()
    );
    assert_eq!(b.saved[0].0, PathBuf::from("/ground/day1/flight_mine.mcap"));
    assert_eq!(b.saved[0].1, b.store.logs[0].1);
    let said = b.messages();
    assert!(said.contains("log transfer: 100 %"), "{said}");
    assert!(
        said.contains("log saved: /ground/day1/flight_mine.mcap"),
        "{said}"
    );
}

#[test]
fn bad_input_from_a_page_is_refused_visibly_and_sends_nothing() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    let watcher = b.station.join();
    let sent = b.commands.len();
    let cases = [
        (
            op,
            r#"{"seq":3,"op":"start","suffix":"../etc","controller":"manual"}"#,
            "file suffix",
        ),
        (
            op,
            r#"{"seq":4,"op":"start","suffix":"ok","controller":"loop"}"#,
            "unknown controller 'loop'",
        ),
        (
            op,
            r#"{"seq":5,"op":"start","suffix":"ok","controller":"manual","plan":"moon"}"#,
            "unknown flight plan 'moon'",
        ),
        (
            op,
            r#"{"seq":6,"op":"start","suffix":"a_suffix_too_long_for_it","controller":"manual"}"#,
            "must be 1-15 letters",
        ),
        (
            op,
            r#"{"seq":7,"op":"stop","base_dir":"../up","suffix":"x"}"#,
            "must be a relative path",
        ),
        (
            op,
            r#"{"seq":8,"op":"stop","base_dir":"/etc","suffix":"x"}"#,
            "must be a relative path",
        ),
        (op, r#"{"seq":9,"op":"stop","base_dir":"d"}"#, "give both"),
        (
            op,
            r#"{"seq":9,"op":"connect"}"#,
            "replayed request refused",
        ),
        (op, r#"{"seq":10,"op":"fly"}"#, "malformed request"),
        (op, "not json", "malformed request"),
        (
            op,
            r#"{"seq":11,"op":"connect"}"#,
            "Connect is not active now",
        ),
        (
            watcher,
            r#"{"seq":1,"op":"stop"}"#,
            "operator 1 is in control",
        ),
        (
            watcher,
            r#"{"seq":2,"op":"take"}"#,
            "operator 1 is in control",
        ),
        (99, r#"{"seq":1,"op":"take"}"#, "not connected"),
    ];
    for (who, json, why) in cases {
        let r = b.ask(who, json);
        let e = r.expect_err(json);
        assert!(e.contains(why), "{json}: {e}");
    }
    b.run(1.0);
    assert_eq!(b.commands.len(), sent, "nothing reached the vehicle");
    assert_eq!(b.panel(), PanelState::Connected);
    // The page that leaves gives the token back.
    b.station.leave(op);
    b.ask(watcher, r#"{"seq":3,"op":"take"}"#).unwrap();
}

#[test]
fn a_failed_start_leaves_only_stop_which_resets_the_display() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.fail_start = true;
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"manual"}"#,
    )
    .unwrap();
    b.run(2.0);
    let v = b.station.view(b.t);
    assert_eq!(v.panel.state, PanelState::LoggingFailed);
    assert_eq!(
        (v.panel.connect, v.panel.start, v.panel.stop),
        (false, false, true)
    );
    assert!(!v.panel.green);
    assert!(b.messages().contains("logging failed"));
    b.ask(op, r#"{"seq":4,"op":"stop"}"#).unwrap();
    b.run(0.5);
    assert_eq!(b.panel(), PanelState::Idle);
}

#[test]
fn a_silent_device_is_stale_and_a_low_battery_is_red_and_each_fails_its_condition() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"autonomous"}"#,
    )
    .unwrap();
    b.telemetry = Some(flying_telemetry("hold"));
    b.run(2.0);
    let v = b.station.view(b.t);
    assert!(!v.rows.gps.as_ref().unwrap().stale);
    assert!(v.battery.as_ref().unwrap().green);
    assert!(v.safety.automatic.allowed, "{:?}", v.safety.automatic);
    // The GPS falls silent on board (its watchdog), the battery sags below its third.
    let mut t = flying_telemetry("hold");
    if let Some(h) = t.health.iter_mut().find(|h| h.device == "gps") {
        h.state = "silent".into();
    }
    t.battery_v = Some(11.4);
    b.telemetry = Some(t);
    b.run(1.0);
    let v = b.station.view(b.t);
    assert!(v.rows.gps.as_ref().unwrap().stale, "the GPS row is stale");
    // The lamp follows: not green, grey with the fix's age, whatever count it had.
    let gps = v.gps.as_ref().unwrap();
    assert!(!gps.ok && gps.stale && gps.satellites == 8, "{gps:?}");
    assert!(!v.rows.imu.as_ref().unwrap().stale);
    let battery = v.battery.as_ref().unwrap();
    assert!(!battery.green && battery.percent < 33.4, "{battery:?}");
    assert!(!v.safety.automatic.allowed);
    for why in ["GPS not updating", "battery down to a third"] {
        assert!(
            v.safety.automatic.failing.contains(why),
            "{}",
            v.safety.automatic.failing
        );
    }
    // Augmented flight keeps its heading on the compass; the satellites of a silent GPS
    // are not known, and the battery is low.
    assert_eq!(
        v.safety.augmented.failing,
        "satellites not known (the vehicle's watchdog says the GPS is not on time), a battery down to a third of its life"
    );
    // Telemetry that stops coming altogether ages into stale.
    b.telemetry = None;
    b.run(2.0);
    let v = b.station.view(b.t);
    assert!(v.rows.imu.as_ref().unwrap().stale);
    let gps = v.gps.as_ref().unwrap();
    assert!(!gps.ok && gps.stale && gps.age_s > 1.5, "{gps:?}");
    assert!(!v.safety.augmented.allowed);
}

#[test]
fn the_uplink_row_is_relabelled_for_the_chosen_augmentation_system() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    assert_eq!(b.station.view(b.t).uplink_labels[3], "Coll");
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"v","controller":"velocity"}"#,
    )
    .unwrap();
    b.telemetry = Some(flying_telemetry("hold"));
    b.run(1.0);
    let v = b.station.view(b.t);
    assert_eq!(
        v.uplink_labels,
        ["Vright", "Vfwd", "YawRate", "Climb", "Thro"]
    );
    let labels: Vec<&str> = v
        .rows
        .uplink
        .as_ref()
        .unwrap()
        .cells
        .iter()
        .map(|c| c.label.as_str())
        .collect();
    assert!(
        labels.contains(&"Climb µs") && labels.contains(&"Vfwd µs"),
        "{labels:?}"
    );
}

#[test]
fn every_pack_shows_its_gauge_and_the_hot_swap_its_times() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"autonomous"}"#,
    )
    .unwrap();
    let mut t = flying_telemetry("hold");
    let pack = |name: &str, volts: f64, percent: f64, minutes_left: f64| {
        heli_link::telemetry::BatteryRow {
            name: name.into(),
            volts,
            percent,
            minutes_left,
            // The vehicle's gauge's level at its default levels.
            level: heli_link::telemetry::level_of_percent(percent).into(),
            draining_abnormally: false,
        }
    };
    t.battery_remaining = Some(0.25);
    t.power = Some(heli_link::telemetry::PowerRow {
        batteries: vec![
            pack("flight", 12.4, 25.0, 7.0),
            pack("receiver", 4.8, 90.0, 120.0),
            pack("servo", 4.9, 60.0, 50.0),
        ],
        source: Some("flight".into()),
        flight_s: 200.0,
        ground_s: 60.0,
    });
    b.telemetry = Some(t);
    b.run(2.0);
    let v = b.station.view(b.t);
    // The meter follows the gauge (25 %), not the voltage (12.4 V would read 90 %).
    let meter = v.battery.as_ref().unwrap();
    assert_eq!(
        (meter.percent, meter.green, meter.from),
        (25.0, false, "gauge")
    );
    let p = &v.power;
    let names: Vec<_> = p.packs.iter().map(|k| (k.name, k.state)).collect();
    assert_eq!(
        names,
        [
            ("flight battery", "warning"),
            ("receiver battery (RTXB)", "good"),
            ("servo battery (Sbat)", "good")
        ]
    );
    assert_eq!(p.packs[0].minutes_left, Some(7.0));
    assert_eq!(p.source, Some("flight"));
    assert!((p.flight_s.unwrap() - 200.0).abs() < 1.0 && (p.ground_s.unwrap() - 60.0).abs() < 1.0);
    assert!(
        v.safety
            .automatic
            .failing
            .contains("a battery down to a third")
    );
    // The vehicle's good 33.46 % arrives as a whole 33: the meter shows the vehicle's level
    // (green), not the number judged again (red at a third or less).
    let mut t = b.telemetry.take().unwrap();
    if let Some(power) = t.power.as_mut() {
        power.batteries[0] = pack("flight", 11.9, 33.46, 5.0);
        power.batteries[0].level = "good".into();
    }
    t.battery_remaining = Some(0.3346);
    b.telemetry = Some(t);
    b.run(2.0);
    let v = b.station.view(b.t);
    let meter = v.battery.as_ref().unwrap();
    assert_eq!((meter.percent, meter.green), (33.0, true));
    assert_eq!(v.power.packs[0].state, "good");
}

#[test]
fn the_field_rule_blocks_start_logging_until_acknowledged() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"autonomous"}"#,
    )
    .unwrap();
    b.run(1.0);
    b.vehicle.status_text(
        mavlink::dialects::common::MavSeverity::MAV_SEVERITY_ERROR,
        "t=241.00 s flight battery draining abnormally: end the flight test",
        b.t,
    );
    b.run(2.0);
    assert!(b.station.view(b.t).power.field_rule.is_some());
    b.ask(op, r#"{"seq":4,"op":"stop"}"#).unwrap();
    b.run(1.0);
    b.ask(op, r#"{"seq":5,"op":"connect"}"#).unwrap();
    b.run(1.0);
    let refused = b
        .ask(
            op,
            r#"{"seq":6,"op":"start","suffix":"g","controller":"autonomous"}"#,
        )
        .unwrap_err();
    assert!(
        refused.contains("field rule") && refused.contains("acknowledge"),
        "{refused}"
    );
    // Only the operator in control acknowledges.
    let watcher = b.station.join();
    assert!(b.ask(watcher, r#"{"seq":1,"op":"acknowledge"}"#).is_err());
    b.ask(op, r#"{"seq":7,"op":"acknowledge"}"#).unwrap();
    assert!(b.station.view(b.t).power.field_rule.is_none());
    assert!(b.ask(op, r#"{"seq":8,"op":"acknowledge"}"#).is_err());
    b.ask(
        op,
        r#"{"seq":9,"op":"start","suffix":"g","controller":"autonomous"}"#,
    )
    .unwrap();
}

#[test]
fn the_flight_pack_named_at_start_logging_gets_the_flights_time() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    let refused = b
        .ask(
            op,
            r#"{"seq":3,"op":"start","suffix":"f","controller":"autonomous","pack":"F9"}"#,
        )
        .unwrap_err();
    assert!(
        refused.contains("unknown flight pack 'F9'") && refused.contains("F1"),
        "{refused}"
    );
    b.ask(
        op,
        r#"{"seq":4,"op":"start","suffix":"f","controller":"autonomous","pack":"F1"}"#,
    )
    .unwrap();
    b.run(1.0);
    let mut t = flying_telemetry("hold");
    t.power = Some(heli_link::telemetry::PowerRow {
        batteries: Vec::new(),
        source: Some("flight".into()),
        flight_s: 420.0,
        ground_s: 75.0,
    });
    b.telemetry = Some(t);
    b.run(2.0);
    assert!(b.station.view(b.t).power.logbook[0].in_use);
    b.ask(op, r#"{"seq":5,"op":"stop"}"#).unwrap();
    b.run(1.0);
    assert!(
        b.messages().contains("pack times: F1 +420 s, G +75 s"),
        "{}",
        b.messages()
    );
    let (path, bytes) = b
        .saved
        .iter()
        .find(|(p, _)| p.ends_with("packs.times.json"))
        .unwrap();
    assert_eq!(path, &PathBuf::from("/ground/packs.times.json"));
    let totals: serde_json::Value = serde_json::from_slice(bytes).unwrap();
    assert_eq!(totals["F1"]["flights"], 1);
    assert_eq!(totals["G"]["seconds"], 75.0);
    let logbook = b.station.view(b.t).power.logbook;
    assert!(!logbook[0].in_use && (logbook[0].hours - 420.0 / 3600.0).abs() < 1e-3);
}

#[test]
fn three_flights_stopped_and_saved_in_one_session_are_three_files_equal_to_the_vehicles_logs() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    let mut seq = 3;
    // A base written with `.` parts is saved, and said, without them.
    for (flight, saved_as, base) in [
        ("a1", "g1", "./day/."),
        ("a2", "g2", "day"),
        ("a3", "g3", "day"),
    ] {
        if flight != "a1" {
            b.ask(op, &format!(r#"{{"seq":{seq},"op":"connect"}}"#))
                .unwrap();
            seq += 1;
            b.run(1.0);
        }
        b.ask(
            op,
            &format!(r#"{{"seq":{seq},"op":"start","suffix":"{flight}","controller":"manual"}}"#),
        )
        .unwrap();
        seq += 1;
        b.run(2.0);
        b.ask(
            op,
            &format!(r#"{{"seq":{seq},"op":"stop","base_dir":"{base}","suffix":"{saved_as}"}}"#),
        )
        .unwrap();
        seq += 1;
        b.run(5.0);
    }
    assert_eq!(b.saved.len(), 3, "{}", b.messages());
    for (k, (path, bytes)) in b.saved.iter().enumerate() {
        assert_eq!(
            path,
            &PathBuf::from(format!("/ground/day/flight_g{}.mcap", k + 1))
        );
        assert_eq!(
            bytes, &b.store.logs[k].1,
            "save {k} is not flight {k}'s log"
        );
    }
    assert!(
        b.messages().contains("checked: flight 'a3'"),
        "{}",
        b.messages()
    );
}

#[test]
fn a_log_that_is_not_the_flight_just_stopped_is_not_said_saved() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"mine","controller":"manual"}"#,
    )
    .unwrap();
    b.run(2.0);
    // Another flight's log is the newest on the vehicle (written behind this one's back).
    b.store
        .logs
        .push(("flight_other.mcap".into(), flight_log("other")));
    b.ask(op, r#"{"seq":4,"op":"stop","base_dir":"day","suffix":"s"}"#)
        .unwrap();
    b.run(5.0);
    assert!(
        b.saved.is_empty(),
        "saved {:?}",
        b.saved.iter().map(|s| &s.0).collect::<Vec<_>>()
    );
    let said = b.messages();
    assert!(
        said.contains("it is the log of flight 'other', not of the flight just stopped ('mine')"),
        "{said}"
    );
    assert!(!said.contains("log saved"), "{said}");
}

#[test]
fn the_gps_lamp_is_not_green_within_one_and_a_half_seconds_of_the_gps_falling_silent() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"manual"}"#,
    )
    .unwrap();
    b.telemetry = Some(flying_telemetry("hold"));
    b.run(2.0);
    assert!(b.station.view(b.t).gps.unwrap().ok);
    // The GPS messages stop (the vehicle's link sends none): the last fix said 8 satellites.
    let mut t = flying_telemetry("hold");
    t.gps = None;
    b.telemetry = Some(t);
    let silent_at = b.t;
    while b.station.view(b.t).gps.unwrap().ok {
        b.run(0.1);
        assert!(
            b.t - silent_at <= 1_500_000,
            "still green 1.5 s after the GPS fell silent"
        );
    }
    let gps = b.station.view(b.t).gps.unwrap();
    assert!(gps.stale && gps.satellites == 8, "{gps:?}");
}

#[test]
fn the_header_shows_the_phase_flown_not_only_the_mode_asked() {
    let mut b = Bench::new();
    let op = b.connected_operator();
    b.ask(
        op,
        r#"{"seq":3,"op":"start","suffix":"f","controller":"autonomous","plan":"hover"}"#,
    )
    .unwrap();
    b.telemetry = Some(flying_telemetry("takeoff-refused"));
    b.run(2.0);
    let v = b.station.view(b.t).vehicle;
    assert_eq!(
        (v.state, v.mode, v.phase),
        (Some("flying"), Some("autonomous"), Some("takeoff-refused"))
    );
    b.telemetry = Some(flying_telemetry("hold"));
    b.run(2.0);
    assert_eq!(b.station.view(b.t).vehicle.phase, Some("hold"));
    // The estimate lost (in calibration, say): the flight core's phase, no estimate, and the
    // verdict says why the helicopter will not go, not "still calibrating".
    b.telemetry = Some(Telemetry {
        phase: Some("ground-failsafe".into()),
        state: None,
        ..flying_telemetry("hold")
    });
    b.run(3.0);
    let v = b.station.view(b.t);
    assert_eq!(v.vehicle.phase, Some("ground-failsafe"));
    assert!(
        v.safety.automatic.failing.contains("the estimate was lost")
            && !v.safety.automatic.failing.contains("still calibrating"),
        "{}",
        v.safety.automatic.failing
    );
    // No flight process: no phase.
    b.telemetry = None;
    b.run(2.0);
    assert_eq!(b.station.view(b.t).vehicle.phase, None);
}

#[test]
fn an_untested_configuration_is_shown_and_an_autonomous_start_needs_the_override() {
    use heli_link::status::Tested;
    let mut b = Bench::new();
    b.tested = Tested::NotTested;
    let op = b.connected_operator();
    b.vehicle.status_text(
        MavSeverity::MAV_SEVERITY_WARNING,
        "bootstrap: NOT lab-tested: parameters changed since the lab's tests: HOV_VEL_P 1.6 (tested 1.4)",
        b.t,
    );
    b.run(1.0);
    let lab = b.station.view(b.t).vehicle.lab;
    assert_eq!(lab.tested, "NOT lab-tested");
    assert_eq!(
        lab.statement.as_deref(),
        Some(
            "NOT lab-tested: parameters changed since the lab's tests: HOV_VEL_P 1.6 (tested 1.4)"
        )
    );
    // Autonomous without the override: refused on the ground with the statement, nothing sent.
    let start = r#"{"seq":3,"op":"start","suffix":"u1","controller":"autonomous","plan":"hover"}"#;
    let refused = b.ask(op, start).unwrap_err();
    assert!(
        refused.contains("HOV_VEL_P 1.6 (tested 1.4): autonomous flight needs your override"),
        "{refused}"
    );
    assert!(
        !b.commands
            .iter()
            .any(|c| matches!(c, GroundCommand::StartLogging(_)))
    );
    // With it: sent, and the vehicle hears the override.
    let start = r#"{"seq":4,"op":"start","suffix":"u1","controller":"autonomous","plan":"hover","override_untested":true}"#;
    b.ask(op, start).unwrap();
    b.run(1.0);
    let sent = b.commands.iter().find_map(|c| match c {
        GroundCommand::StartLogging(p) => Some(p.clone()),
        _ => None,
    });
    assert!(sent.is_some_and(|p| p.override_untested));
    // Lab-tested: the statement of the other kind is not shown.
    b.tested = Tested::LabTested;
    b.run(1.5);
    let lab = b.station.view(b.t).vehicle.lab;
    assert_eq!((lab.tested, lab.statement), ("lab-tested", None));
}
