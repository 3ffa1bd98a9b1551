//! The telemetry rows of thesis Fig. 2-4 — IMU, STATE, UPLINK, SERVO, GPS, BAR, CMPS — with
//! their fields, made from the newest MAVLink message of each kind (docs/link.md has the
//! mapping). A row with nothing yet is `None` ("NOTHING YET" on the display). A row is
//! *stale* when its message is older than [`STALE_AFTER_US`] or when the vehicle's watchdog
//! for its device says the device is not on time (`SYS_STATUS` health bits): the vehicle
//! keeps sending a silent device's last value, so the age of the message alone would not
//! tell.

use std::collections::BTreeMap;

use mavlink::MessageData;
use mavlink::dialects::common::*;
use serde::Serialize;

/// A row older than this (µs) is stale: four and a half telemetry periods at 3 Hz.
pub const STALE_AFTER_US: u64 = 1_500_000;

/// The GPS's last fix older than this (µs) makes its row stale: one fix a second, and a
/// quarter of a second of grace. The vehicle's own watchdog calls it late only at 1.5 s; the
/// ground, knowing the fix's time, says it first.
pub const GPS_FIX_STALE_US: u64 = 1_250_000;

/// How far a fix's time may lead the vehicle's clock as the ground reckons it (µs), the
/// attitude and the fix being sent apart: further ahead, it is from before a restart.
pub const FIX_AHEAD_GRACE_US: u64 = 500_000;

/// One field of a row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cell {
    /// Its label (Fig. 2-4's, with the unit).
    pub label: String,
    /// Its value, formatted.
    pub value: String,
}

/// One row of the display.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// The vehicle's time of the message (s since its link started).
    pub time_s: f64,
    /// The fields.
    pub cells: Vec<Cell>,
    /// Old, or the device is not on time.
    pub stale: bool,
    /// How old it is (s): since the station received it; for the GPS, since its fix (on
    /// the vehicle's clock).
    pub age_s: f64,
}

/// Every row, in Fig. 2-4's order; `None` is "NOTHING YET".
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Rows {
    /// IMU: rates and specific forces.
    pub imu: Option<Row>,
    /// STATE: the estimate.
    pub state: Option<Row>,
    /// UPLINK: the pilot's commands and the board's batteries.
    pub uplink: Option<Row>,
    /// SERVO: the commands to the servos.
    pub servo: Option<Row>,
    /// GPS.
    pub gps: Option<Row>,
    /// BAR: the altimeter.
    pub bar: Option<Row>,
    /// CMPS: the compass.
    pub cmps: Option<Row>,
}

/// The newest message of each id with the time it came (µs), as the link keeps them.
pub type Latest = BTreeMap<u32, (u64, MavMessage)>;

/// What the vehicle's `SYS_STATUS` says of a sensor: `Some(healthy)` when present.
pub fn sensor_health(latest: &Latest, bit: MavSysStatusSensor) -> Option<bool> {
    match latest.get(&SYS_STATUS_DATA::ID) {
        Some((_, MavMessage::SYS_STATUS(s))) if s.onboard_control_sensors_present.contains(bit) => {
            Some(s.onboard_control_sensors_health.contains(bit))
        }
        _ => None,
    }
}

/// Whether a `SYS_STATUS` that came after `since_us` no longer lists the sensor as present:
/// the vehicle has no such device now (its flight process ended, or a new one has not yet
/// heard from it), so a row from before speaks for a device that is not there.
pub fn gone_since(latest: &Latest, bit: MavSysStatusSensor, since_us: u64) -> bool {
    matches!(
        latest.get(&SYS_STATUS_DATA::ID),
        Some((at, MavMessage::SYS_STATUS(s)))
            if *at > since_us && !s.onboard_control_sensors_present.contains(bit)
    )
}

fn cell(label: &str, value: String) -> Cell {
    Cell {
        label: label.to_string(),
        value,
    }
}

fn num(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        "–".into()
    }
}

/// Heading in degrees, 0..360.
fn heading_deg(rad: f64) -> f64 {
    rad.to_degrees().rem_euclid(360.0)
}

/// Pressure altitude (m) in the standard atmosphere.
pub fn pressure_altitude_m(pressure_mbar: f64) -> f64 {
    44_330.0 * (1.0 - (pressure_mbar / 1013.25).powf(0.190_3))
}

/// The compass heading (rad) of a level helicopter from the body-frame field.
pub fn compass_heading_rad(x: f64, y: f64) -> f64 {
    (-y).atan2(x)
}

struct RowMaker<'a> {
    latest: &'a Latest,
    now_us: u64,
}

impl RowMaker<'_> {
    fn get(&self, id: u32) -> Option<(u64, &MavMessage)> {
        self.latest.get(&id).map(|(t, m)| (*t, m))
    }

    fn row(
        &self,
        at_us: u64,
        time_ms: u32,
        cells: Vec<Cell>,
        bit: Option<MavSysStatusSensor>,
    ) -> Row {
        let old = self.now_us.saturating_sub(at_us) > STALE_AFTER_US;
        let unhealthy = bit.is_some_and(|b| {
            sensor_health(self.latest, b) == Some(false) || gone_since(self.latest, b, at_us)
        });
        Row {
            time_s: f64::from(time_ms) / 1000.0,
            cells,
            stale: old || unhealthy,
            age_s: self.now_us.saturating_sub(at_us) as f64 * 1e-6,
        }
    }
}

/// The rows now, from the link's newest messages and battery instances (`uplink_labels`: the
/// five stick labels for the chosen controller).
pub fn rows(latest: &Latest, batteries: &Batteries, now_us: u64, uplink_labels: [&str; 5]) -> Rows {
    let m = RowMaker { latest, now_us };
    let mut out = Rows::default();
    if let Some((at, MavMessage::SCALED_IMU(i))) = m.get(SCALED_IMU_DATA::ID) {
        let g = 9.806_65 / 1000.0;
        let rate = |v: i16| num((f64::from(v) / 1000.0).to_degrees(), 1);
        let acc = |v: i16| num(f64::from(v) * g, 2);
        let cells = vec![
            cell("Wx °/s", rate(i.xgyro)),
            cell("Wy °/s", rate(i.ygyro)),
            cell("Wz °/s", rate(i.zgyro)),
            cell("Ax m/s²", acc(i.xacc)),
            cell("Ay m/s²", acc(i.yacc)),
            cell("Az m/s²", acc(i.zacc)),
        ];
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO;
        out.imu = Some(m.row(at, i.time_boot_ms, cells, Some(bit)));
        let mag = [i.xmag, i.ymag, i.zmag].map(|v| f64::from(v) / 1000.0);
        if mag.iter().any(|v| *v != 0.0) {
            let cells = vec![
                cell("CmpX G", num(mag[0], 3)),
                cell("CmpY G", num(mag[1], 3)),
                cell("CmpZ G", num(mag[2], 3)),
                cell(
                    "Heading °",
                    num(heading_deg(compass_heading_rad(mag[0], mag[1])), 1),
                ),
            ];
            let bit = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
            out.cmps = Some(m.row(at, i.time_boot_ms, cells, Some(bit)));
        }
    }
    if let Some((at, MavMessage::ATTITUDE(a))) = m.get(ATTITUDE_DATA::ID) {
        let yaw = f64::from(a.yaw);
        let (fwd, side, up) = match m.get(LOCAL_POSITION_NED_DATA::ID) {
            Some((_, MavMessage::LOCAL_POSITION_NED(p))) => {
                let (vn, ve) = (f64::from(p.vx), f64::from(p.vy));
                (
                    vn * yaw.cos() + ve * yaw.sin(),
                    -vn * yaw.sin() + ve * yaw.cos(),
                    -f64::from(p.vz),
                )
            }
            _ => (f64::NAN, f64::NAN, f64::NAN),
        };
        let cells = vec![
            cell("Roll °", num(f64::from(a.roll).to_degrees(), 1)),
            cell("Pitch °", num(f64::from(a.pitch).to_degrees(), 1)),
            cell("Heading °", num(heading_deg(yaw), 1)),
            cell("Vfwd m/s", num(fwd, 2)),
            cell("Vside m/s", num(side, 2)),
            cell("Vascend m/s", num(up, 2)),
        ];
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_AHRS;
        out.state = Some(m.row(at, a.time_boot_ms, cells, Some(bit)));
    }
    let rpm = match m.get(RAW_RPM_DATA::ID) {
        Some((_, MavMessage::RAW_RPM(r))) => num(f64::from(r.frequency), 0),
        _ => "–".into(),
    };
    if let Some((at, MavMessage::RC_CHANNELS(rc))) = m.get(RC_CHANNELS_DATA::ID) {
        let board = |id: u8| board_battery_v(batteries, id).map_or("–".into(), |v| num(v, 2));
        let pulses = [
            rc.chan1_raw,
            rc.chan2_raw,
            rc.chan3_raw,
            rc.chan4_raw,
            rc.chan5_raw,
        ];
        let mut cells = vec![cell("RPM", rpm.clone())];
        for (label, p) in uplink_labels.iter().zip(pulses) {
            cells.push(cell(&format!("{label} µs"), p.to_string()));
        }
        cells.push(cell(
            "Auto",
            if rc.chan6_raw > 1500 { "on" } else { "off" }.into(),
        ));
        cells.push(cell(
            "RTXB V",
            board(heli_link::telemetry::RECEIVER_BATTERY_ID),
        ));
        cells.push(cell(
            "Sbat V",
            board(heli_link::telemetry::SERVO_BATTERY_ID),
        ));
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
        out.uplink = Some(m.row(at, rc.time_boot_ms, cells, Some(bit)));
    }
    if let Some((at, MavMessage::SERVO_OUTPUT_RAW(s))) = m.get(SERVO_OUTPUT_RAW_DATA::ID) {
        let cmd = |us: u16| num((f64::from(us) - 1500.0) / 500.0, 2);
        let cells = vec![
            cell("RPM", rpm),
            cell("Aile", cmd(s.servo1_raw)),
            cell("Elev", cmd(s.servo2_raw)),
            cell("Rudd", cmd(s.servo3_raw)),
            cell("Coll", cmd(s.servo4_raw)),
            cell("Thro", cmd(s.servo5_raw)),
        ];
        out.servo = Some(m.row(at, s.time_usec / 1000, cells, None));
    }
    if let Some((at, MavMessage::GPS_RAW_INT(g))) = m.get(GPS_RAW_INT_DATA::ID) {
        let speed = f64::from(g.vel) / 100.0;
        let course = (f64::from(g.cog) / 100.0).to_radians();
        let vd = match m.get(GLOBAL_POSITION_INT_DATA::ID) {
            Some((_, MavMessage::GLOBAL_POSITION_INT(p))) => f64::from(p.vz) / 100.0,
            _ => f64::NAN,
        };
        // The thesis's PosN/PosE: the fix north and east of the estimate's origin (the
        // vehicle's GPS_GLOBAL_ORIGIN), beside the latitude and longitude.
        let (lat, lon, alt) = (
            f64::from(g.lat) / 1e7,
            f64::from(g.lon) / 1e7,
            f64::from(g.alt) / 1000.0,
        );
        let ned = match m.get(GPS_GLOBAL_ORIGIN_DATA::ID) {
            Some((_, MavMessage::GPS_GLOBAL_ORIGIN(o))) => heli_nav::GeoOrigin {
                lat_deg: f64::from(o.latitude) / 1e7,
                lon_deg: f64::from(o.longitude) / 1e7,
                alt_m: f64::from(o.altitude) / 1000.0,
            }
            .to_ned(lat, lon, alt),
            _ => [f64::NAN; 3],
        };
        let cells = vec![
            cell("PosN m", num(ned[0], 1)),
            cell("PosE m", num(ned[1], 1)),
            cell("VelN m/s", num(speed * course.cos(), 2)),
            cell("VelE m/s", num(speed * course.sin(), 2)),
            cell("VelD m/s", num(vd, 2)),
            cell("#SAT", g.satellites_visible.to_string()),
            cell("Lat °", num(lat, 7)),
            cell("Lon °", num(lon, 7)),
            cell("Altitude m", num(alt, 1)),
        ];
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
        let time_ms = u32::try_from(g.time_usec / 1000).unwrap_or(u32::MAX);
        let mut row = m.row(at, time_ms, cells, Some(bit));
        // The fix's age now, on the vehicle's clock: its time against the newest attitude's
        // (sent at the telemetry rate), moved on by the time since that came.
        if let Some((at_att, MavMessage::ATTITUDE(a))) = m.get(ATTITUDE_DATA::ID) {
            let vehicle_now_us =
                (u64::from(a.time_boot_ms) * 1000).saturating_add(now_us.saturating_sub(at_att));
            match vehicle_now_us.checked_sub(g.time_usec) {
                Some(fix_age_us) => {
                    row.age_s = fix_age_us as f64 * 1e-6;
                    row.stale = row.stale || fix_age_us > GPS_FIX_STALE_US;
                }
                // A fix stamped later than the vehicle's now (beyond the two messages'
                // jitter) was taken before its clock began again: the previous flight
                // process's, not this one's (the new process has no fix yet).
                None => {
                    row.stale = row.stale
                        || g.time_usec.saturating_sub(vehicle_now_us) > FIX_AHEAD_GRACE_US;
                }
            }
        }
        out.gps = Some(row);
    }
    if let Some((at, MavMessage::SCALED_PRESSURE(p))) = m.get(SCALED_PRESSURE_DATA::ID) {
        let mbar = f64::from(p.press_abs);
        let cells = vec![
            cell("Pressure mbar", num(mbar, 2)),
            cell("Altitude m", num(pressure_altitude_m(mbar), 1)),
        ];
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE;
        out.bar = Some(m.row(at, p.time_boot_ms, cells, Some(bit)));
    }
    out
}

/// The newest `BATTERY_STATUS` of each battery id, with the time it came (µs).
pub type Batteries = BTreeMap<u8, (u64, BATTERY_STATUS_DATA)>;

/// The voltage of battery `id` (the first cell's reading), if known.
pub fn board_battery_v(batteries: &Batteries, id: u8) -> Option<f64> {
    batteries
        .get(&id)
        .and_then(|(_, b)| b.voltages.first().copied())
        .filter(|mv| *mv != u16::MAX)
        .map(|mv| f64::from(mv) / 1000.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn latest(fix_time_us: u64, attitude_boot_ms: u32) -> Latest {
        let mut m = Latest::new();
        let gps = GPS_RAW_INT_DATA {
            time_usec: fix_time_us,
            fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
            satellites_visible: 8,
            ..Default::default()
        };
        let att = ATTITUDE_DATA {
            time_boot_ms: attitude_boot_ms,
            ..Default::default()
        };
        m.insert(
            GPS_RAW_INT_DATA::ID,
            (10_000_000, MavMessage::GPS_RAW_INT(gps)),
        );
        m.insert(ATTITUDE_DATA::ID, (10_000_000, MavMessage::ATTITUDE(att)));
        m
    }

    fn gps_stale(fix_time_us: u64, attitude_boot_ms: u32) -> bool {
        let rows = rows(
            &latest(fix_time_us, attitude_boot_ms),
            &Batteries::new(),
            10_100_000,
            ["a", "e", "r", "c", "t"],
        );
        rows.gps.is_some_and(|g| g.stale)
    }

    #[test]
    fn a_fix_from_before_the_vehicle_s_clock_began_again_is_stale_at_once() {
        // A fresh fix: 0.3 s old on the vehicle's clock.
        assert!(!gps_stale(100_000_000, 100_200));
        // An old one: 2 s.
        assert!(gps_stale(100_000_000, 101_900));
        // Within the messages' jitter ahead of the clock: fresh.
        assert!(!gps_stale(100_400_000, 100_000));
        // The flight process restarted: its clock at 1.5 s, the last fix the previous
        // process's at 100 s. Before, its age was taken as zero and the lamp stayed green.
        assert!(gps_stale(100_000_000, 1_500));
    }

    fn sys_status(present: MavSysStatusSensor, healthy: MavSysStatusSensor) -> MavMessage {
        MavMessage::SYS_STATUS(SYS_STATUS_DATA {
            onboard_control_sensors_present: present,
            onboard_control_sensors_health: healthy,
            ..Default::default()
        })
    }

    #[test]
    fn a_device_the_vehicle_no_longer_lists_makes_its_older_row_stale() {
        let gps = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
        let none = MavSysStatusSensor::empty();
        let stale_with = |status: Option<(u64, MavMessage)>| {
            let mut m = latest(100_000_000, 100_200);
            if let Some(s) = status {
                m.insert(SYS_STATUS_DATA::ID, s);
            }
            rows(&m, &Batteries::new(), 10_100_000, ["a", "e", "r", "c", "t"])
                .gps
                .is_some_and(|g| g.stale)
        };
        // No status at all, or one that says the GPS is there and healthy: a fresh fix.
        assert!(!stale_with(None));
        assert!(!stale_with(Some((10_050_000, sys_status(gps, gps)))));
        // After the fix (10.0 s), the vehicle says it has no GPS (a flight process ended or
        // has only begun): the fix speaks for a device that is not there.
        assert!(stale_with(Some((10_050_000, sys_status(none, none)))));
        // A status from before the fix says nothing of it.
        assert!(!stale_with(Some((9_950_000, sys_status(none, none)))));
        // Present and unhealthy is stale whenever it came.
        assert!(stale_with(Some((9_950_000, sys_status(gps, none)))));
    }
}
