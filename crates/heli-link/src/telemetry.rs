//! Telemetry: the freshest value of each of the thesis's seven streams, the battery and the
//! devices' health ([`Telemetry`], sent by the flight process to the bootstrap as JSON), and
//! its translation into the standard MAVLink messages a ground station shows
//! ([`messages`]). Each message has its own interval, 3 Hz by default as the thesis's
//! telemetry request was, settable with `MAV_CMD_SET_MESSAGE_INTERVAL`.

use mavlink::dialects::common::*;
use serde::{Deserialize, Serialize};

/// The thesis's telemetry period (3 Hz).
pub const DEFAULT_INTERVAL_US: u64 = 333_333;

/// The IMU row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ImuRow {
    /// Angular rate (rad/s, body).
    pub rate_rps: [f64; 3],
    /// Specific force (m/s², body).
    pub accel_mps2: [f64; 3],
}

/// The state-estimate row.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateRow {
    /// The flight phase's name.
    pub phase: String,
    /// Roll, pitch, yaw (rad).
    pub euler_rad: [f64; 3],
    /// Body rates (rad/s).
    pub rate_rps: [f64; 3],
    /// Position north, east, down from the origin (m).
    pub pos_ned_m: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub vel_ned_mps: [f64; 3],
}

/// The pilot uplink row (the servo controller board's report).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UplinkRow {
    /// Receiver pulses: aileron, elevator, rudder, collective, throttle (µs).
    pub pulses_us: [u16; 5],
    /// The auto switch.
    pub auto_mode: bool,
    /// The emergency bypass switch.
    pub bypass: bool,
    /// Rotor speed (rpm).
    pub rotor_rpm: u16,
    /// The receiver battery (V): the thesis's RTXB.
    #[serde(default)]
    pub receiver_batt_v: f64,
    /// The servo battery (V): the thesis's Sbat.
    #[serde(default)]
    pub servo_batt_v: f64,
}

/// The servo command row (normalised commands, −1..1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ServoRow {
    /// Aileron, elevator, rudder, collective, throttle.
    pub commands: [f64; 5],
}

/// The GPS row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GpsRow {
    /// Latitude (deg).
    pub lat_deg: f64,
    /// Longitude (deg).
    pub lon_deg: f64,
    /// Height above the ellipsoid (m).
    pub alt_m: f64,
    /// Velocity north, east, down (m/s).
    pub vel_ned_mps: [f64; 3],
    /// Satellites used.
    pub satellites: u8,
    /// A 3-D fix.
    pub fix_3d: bool,
    /// How old the fix was when the snapshot was taken (s): the GPS message carries the
    /// fix's own time, so that the ground sees a silent GPS by the age of its last fix.
    #[serde(default)]
    pub age_s: f64,
}

/// The altimeter row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BaroRow {
    /// Pressure (mbar = hPa).
    pub pressure_mbar: f64,
    /// Altitude (m), once the altimeter has a reference.
    pub alt_m: Option<f64>,
}

/// The compass row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompassRow {
    /// Field (gauss, body).
    pub field_gauss: [f64; 3],
    /// Heading (rad), once calibrated.
    pub heading_rad: Option<f64>,
}

/// One device's health for the ground: name and verdict (`waiting`, `ok`, `late`, `silent`,
/// `failed`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DeviceHealth {
    /// Device name (`imu`, `uplink`, `gps`, `baro`, `compass`, `battery`).
    pub device: String,
    /// Verdict.
    pub state: String,
    /// Times its watchdog has found it late, silent or failed since the flight process
    /// began: a lapse shorter than the interval between two reports shows as a rise here
    /// though both reports say `ok`.
    #[serde(default)]
    pub lapses: u32,
}

/// One battery as the flight software's gauge sees it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BatteryRow {
    /// `flight`, `receiver` or `servo`.
    pub name: String,
    /// Terminal voltage (V).
    pub volts: f64,
    /// Charge left (%).
    pub percent: f64,
    /// Time left at the present drain (minutes).
    pub minutes_left: f64,
    /// `good`, `warning` or `critical`.
    pub level: String,
    /// The field rule: draining abnormally.
    pub draining_abnormally: bool,
}

/// The batteries and the hot-swap.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PowerRow {
    /// Each battery read so far.
    pub batteries: Vec<BatteryRow>,
    /// What powers the avionics (`flight`, `ground`), if the hot-swap's line is read.
    pub source: Option<String>,
    /// Time on the flight batteries this flight (s).
    pub flight_s: f64,
    /// Time on the ground battery this flight (s).
    pub ground_s: f64,
}

/// The freshest value of each stream (`None`: nothing yet), at `t_us` of the flight clock.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// When the snapshot was taken (µs of the flight clock).
    pub t_us: u64,
    /// The flight phase now, as the flight core has it after its latest input — whether or
    /// not an estimate is current (`calibrating` before the first, `blind-descent` or
    /// `ground-failsafe` after one was lost). `None`: no flight core has spoken yet; the
    /// state row's phase is then the one to go by.
    #[serde(default)]
    pub phase: Option<String>,
    /// IMU.
    pub imu: Option<ImuRow>,
    /// State estimate: only while it is current (`None` before the first, and once it has
    /// stopped coming: a lost estimate is never sent on as if it were new).
    pub state: Option<StateRow>,
    /// Pilot uplink.
    pub uplink: Option<UplinkRow>,
    /// Servo commands.
    pub servo: Option<ServoRow>,
    /// GPS.
    pub gps: Option<GpsRow>,
    /// Altimeter.
    pub baro: Option<BaroRow>,
    /// Compass.
    pub compass: Option<CompassRow>,
    /// Flight battery (V).
    pub battery_v: Option<f64>,
    /// Battery charge left (0..1), when known.
    pub battery_remaining: Option<f64>,
    /// Device health.
    pub health: Vec<DeviceHealth>,
    /// The batteries' gauges and the hot-swap.
    #[serde(default)]
    pub power: Option<PowerRow>,
    /// The estimate's origin (latitude and longitude in degrees, altitude in metres), once
    /// the navigation has one: the frame of the positions north and east.
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
}

/// The flight phase now: the flight core's, or without it the current estimate's.
pub fn phase_now(t: &Telemetry) -> Option<&str> {
    t.phase
        .as_deref()
        .or_else(|| t.state.as_ref().map(|s| s.phase.as_str()))
}

/// The messages of the telemetry, in the order they are offered, by message id.
pub const TELEMETRY_MESSAGES: [u32; 13] = [
    ATTITUDE_DATA::ID,
    LOCAL_POSITION_NED_DATA::ID,
    GLOBAL_POSITION_INT_DATA::ID,
    SCALED_IMU_DATA::ID,
    RC_CHANNELS_DATA::ID,
    SERVO_OUTPUT_RAW_DATA::ID,
    GPS_RAW_INT_DATA::ID,
    SCALED_PRESSURE_DATA::ID,
    SYS_STATUS_DATA::ID,
    BATTERY_STATUS_DATA::ID,
    HEARTBEAT_DATA::ID,
    RAW_RPM_DATA::ID,
    GPS_GLOBAL_ORIGIN_DATA::ID,
];

/// `BATTERY_STATUS.id` of the flight computer's battery.
pub const FLIGHT_BATTERY_ID: u8 = 0;
/// `BATTERY_STATUS.id` of the servo board's receiver battery (the thesis's RTXB).
pub const RECEIVER_BATTERY_ID: u8 = 1;
/// `BATTERY_STATUS.id` of the servo battery (the thesis's Sbat).
pub const SERVO_BATTERY_ID: u8 = 2;

use mavlink::MessageData;

fn f(x: f64) -> f32 {
    x as f32
}

fn scaled_i16(x: f64, per_unit: f64) -> i16 {
    (x * per_unit)
        .round()
        .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

fn scaled_i32(x: f64, per_unit: f64) -> i32 {
    (x * per_unit)
        .round()
        .clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

/// A servo command (−1..1) as a PWM width (µs): 1500 ± 500.
fn pwm(command: f64) -> u16 {
    (1500.0 + 500.0 * command.clamp(-1.0, 1.0)).round() as u16
}

/// Which of SYS_STATUS's sensor bits each device is.
fn sensor_bit(device: &str) -> MavSysStatusSensor {
    match device {
        "imu" => {
            MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
        }
        "gps" => MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS,
        "baro" => MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
        "compass" => MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG,
        "uplink" => MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER,
        "battery" => MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY,
        _ => MavSysStatusSensor::empty(),
    }
}

/// The telemetry message with id `id` for `t`, `time_boot_ms` after the link started;
/// `None` while its stream has nothing yet (or for an id that is not telemetry).
pub fn message(id: u32, t: &Telemetry, time_boot_ms: u32) -> Option<MavMessage> {
    let msg = match id {
        ATTITUDE_DATA::ID => {
            let s = t.state.as_ref()?;
            MavMessage::ATTITUDE(ATTITUDE_DATA {
                time_boot_ms,
                roll: f(s.euler_rad[0]),
                pitch: f(s.euler_rad[1]),
                yaw: f(s.euler_rad[2]),
                rollspeed: f(s.rate_rps[0]),
                pitchspeed: f(s.rate_rps[1]),
                yawspeed: f(s.rate_rps[2]),
            })
        }
        LOCAL_POSITION_NED_DATA::ID => {
            let s = t.state.as_ref()?;
            MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                time_boot_ms,
                x: f(s.pos_ned_m[0]),
                y: f(s.pos_ned_m[1]),
                z: f(s.pos_ned_m[2]),
                vx: f(s.vel_ned_mps[0]),
                vy: f(s.vel_ned_mps[1]),
                vz: f(s.vel_ned_mps[2]),
            })
        }
        GLOBAL_POSITION_INT_DATA::ID => {
            // Latitude and longitude are the GPS's; height and velocity the estimate's.
            let g = t.gps.as_ref()?;
            let s = t.state.as_ref()?;
            let yaw_cdeg = s.euler_rad[2].to_degrees().rem_euclid(360.0) * 100.0;
            MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms,
                lat: scaled_i32(g.lat_deg, 1e7),
                lon: scaled_i32(g.lon_deg, 1e7),
                alt: scaled_i32(g.alt_m, 1e3),
                relative_alt: scaled_i32(-s.pos_ned_m[2], 1e3),
                vx: scaled_i16(s.vel_ned_mps[0], 100.0),
                vy: scaled_i16(s.vel_ned_mps[1], 100.0),
                vz: scaled_i16(s.vel_ned_mps[2], 100.0),
                hdg: yaw_cdeg.round().clamp(0.0, 35_999.0) as u16,
            })
        }
        SCALED_IMU_DATA::ID => {
            let i = t.imu.as_ref()?;
            let mag = t.compass.map(|c| c.field_gauss).unwrap_or([0.0; 3]);
            // Accelerations in milli-g, rates in mrad/s, field in milligauss.
            let mg = 1000.0 / 9.80665;
            MavMessage::SCALED_IMU(SCALED_IMU_DATA {
                time_boot_ms,
                xacc: scaled_i16(i.accel_mps2[0], mg),
                yacc: scaled_i16(i.accel_mps2[1], mg),
                zacc: scaled_i16(i.accel_mps2[2], mg),
                xgyro: scaled_i16(i.rate_rps[0], 1000.0),
                ygyro: scaled_i16(i.rate_rps[1], 1000.0),
                zgyro: scaled_i16(i.rate_rps[2], 1000.0),
                xmag: scaled_i16(mag[0], 1000.0),
                ymag: scaled_i16(mag[1], 1000.0),
                zmag: scaled_i16(mag[2], 1000.0),
            })
        }
        RC_CHANNELS_DATA::ID => {
            let u = t.uplink.as_ref()?;
            let switch = |on: bool| if on { 2000 } else { 1000 };
            MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
                time_boot_ms,
                chan1_raw: u.pulses_us[0],
                chan2_raw: u.pulses_us[1],
                chan3_raw: u.pulses_us[2],
                chan4_raw: u.pulses_us[3],
                chan5_raw: u.pulses_us[4],
                chan6_raw: switch(u.auto_mode),
                chan7_raw: switch(u.bypass),
                chancount: 7,
                rssi: u8::MAX,
                ..Default::default()
            })
        }
        SERVO_OUTPUT_RAW_DATA::ID => {
            let s = t.servo.as_ref()?;
            let [a, e, r, c, th] = s.commands;
            MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
                time_usec: (u64::from(time_boot_ms) * 1000) as u32,
                servo1_raw: pwm(a),
                servo2_raw: pwm(e),
                servo3_raw: pwm(r),
                servo4_raw: pwm(c),
                servo5_raw: pwm(th),
                ..Default::default()
            })
        }
        GPS_GLOBAL_ORIGIN_DATA::ID => {
            let [lat, lon, alt] = t.origin?;
            MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
                latitude: scaled_i32(lat, 1e7),
                longitude: scaled_i32(lon, 1e7),
                altitude: scaled_i32(alt, 1e3),
            })
        }
        GPS_RAW_INT_DATA::ID => {
            let g = t.gps.as_ref()?;
            let [vn, ve, _] = g.vel_ned_mps;
            let speed = vn.hypot(ve);
            // The fix's own time (MAVLink's time_usec is the fix's), on the link's clock.
            let age_us = (g.age_s.max(0.0) * 1e6) as u64;
            MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                time_usec: (u64::from(time_boot_ms) * 1000).saturating_sub(age_us),
                lat: scaled_i32(g.lat_deg, 1e7),
                lon: scaled_i32(g.lon_deg, 1e7),
                alt: scaled_i32(g.alt_m, 1e3),
                eph: u16::MAX,
                epv: u16::MAX,
                vel: (speed * 100.0).round().clamp(0.0, 65_534.0) as u16,
                cog: (ve.atan2(vn).to_degrees().rem_euclid(360.0) * 100.0)
                    .round()
                    .clamp(0.0, 35_999.0) as u16,
                fix_type: if g.fix_3d {
                    GpsFixType::GPS_FIX_TYPE_3D_FIX
                } else {
                    GpsFixType::GPS_FIX_TYPE_NO_FIX
                },
                satellites_visible: g.satellites,
            })
        }
        SCALED_PRESSURE_DATA::ID => {
            let b = t.baro.as_ref()?;
            MavMessage::SCALED_PRESSURE(SCALED_PRESSURE_DATA {
                time_boot_ms,
                press_abs: f(b.pressure_mbar),
                press_diff: 0.0,
                temperature: 0,
            })
        }
        SYS_STATUS_DATA::ID => {
            let mut present = MavSysStatusSensor::empty();
            let mut healthy = MavSysStatusSensor::empty();
            for h in &t.health {
                present |= sensor_bit(&h.device);
                if h.state == "ok" {
                    healthy |= sensor_bit(&h.device);
                }
            }
            // The estimate (AHRS): present with the IMU, healthy once the calibration is
            // done and the estimate runs.
            let ahrs = MavSysStatusSensor::MAV_SYS_STATUS_AHRS;
            if t.imu.is_some() || t.state.is_some() {
                present |= ahrs;
            }
            // Healthy once calibrated and while the estimate is current (a lost one is not
            // sent on), and not in the blind failsafe of a lost estimate. (The ground failsafe
            // is also the skids' answer to a lost transmitter, with the estimate running.)
            if t.state.is_some() && !matches!(phase_now(t), Some("calibrating" | "blind-descent")) {
                healthy |= ahrs;
            }
            MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                onboard_control_sensors_present: present,
                onboard_control_sensors_enabled: present,
                onboard_control_sensors_health: healthy,
                voltage_battery: t.battery_v.map_or(u16::MAX, millivolts),
                current_battery: -1,
                battery_remaining: flight_percent(t),
                ..Default::default()
            })
        }
        BATTERY_STATUS_DATA::ID => battery_status(
            FLIGHT_BATTERY_ID,
            t.battery_v?,
            MavBatteryFunction::MAV_BATTERY_FUNCTION_AVIONICS,
            flight_percent(t),
        ),
        RAW_RPM_DATA::ID => {
            let u = t.uplink.as_ref()?;
            MavMessage::RAW_RPM(RAW_RPM_DATA {
                frequency: f32::from(u.rotor_rpm),
                index: 0,
            })
        }
        _ => return None,
    };
    Some(msg)
}

/// The servo board's two batteries as `BATTERY_STATUS` instances
/// ([`RECEIVER_BATTERY_ID`], [`SERVO_BATTERY_ID`]), sent with the flight battery's.
pub fn board_batteries(t: &Telemetry) -> Vec<MavMessage> {
    let Some(u) = t.uplink.as_ref() else {
        return Vec::new();
    };
    [
        (RECEIVER_BATTERY_ID, u.receiver_batt_v, "receiver"),
        (SERVO_BATTERY_ID, u.servo_batt_v, "servo"),
    ]
    .into_iter()
    .filter(|(_, v, _)| v.is_finite() && *v > 0.0)
    .map(|(id, v, name)| {
        let remaining = gauge(t, name).map_or(-1, |b| whole_percent(b.percent));
        battery_status(
            id,
            v,
            MavBatteryFunction::MAV_BATTERY_FUNCTION_UNKNOWN,
            remaining,
        )
    })
    .collect()
}

/// The gauge of battery `name`, if the telemetry has it.
fn gauge<'a>(t: &'a Telemetry, name: &str) -> Option<&'a BatteryRow> {
    t.power.as_ref()?.batteries.iter().find(|b| b.name == name)
}

/// Names of the power values sent as `NAMED_VALUE_FLOAT` with the batteries (ten
/// characters at most): minutes left on the flight, receiver and servo packs, the hot-swap's
/// source (1 flight, 0 ground) and the seconds on each, and each pack's level as the
/// vehicle's gauge judges it ([`level_code`]).
pub const POWER_VALUES: [&str; 9] = [
    "FLT_MIN",
    "RTXB_MIN",
    "SBAT_MIN",
    "PWR_FLIGHT",
    "PWR_FLT_S",
    "PWR_GND_S",
    "FLT_LVL",
    "RTXB_LVL",
    "SBAT_LVL",
];

/// The power values as `NAMED_VALUE_FLOAT`s ([`POWER_VALUES`]), sent with the batteries: what
/// `BATTERY_STATUS` of this dialect version has no field for.
pub fn power_values(t: &Telemetry, time_boot_ms: u32) -> Vec<MavMessage> {
    let Some(p) = t.power.as_ref() else {
        return Vec::new();
    };
    let minutes = |name: &str| gauge(t, name).map(|b| b.minutes_left);
    let level = |name: &str| gauge(t, name).and_then(|b| level_code(&b.level));
    let source = p
        .source
        .as_deref()
        .map(|s| if s == "flight" { 1.0 } else { 0.0 });
    let values = [
        minutes("flight"),
        minutes("receiver"),
        minutes("servo"),
        source,
        source.map(|_| p.flight_s),
        source.map(|_| p.ground_s),
        level("flight"),
        level("receiver"),
        level("servo"),
    ];
    POWER_VALUES
        .iter()
        .zip(values)
        .filter_map(|(name, v)| {
            let v = v.filter(|v| v.is_finite())?;
            Some(MavMessage::NAMED_VALUE_FLOAT(NAMED_VALUE_FLOAT_DATA {
                time_boot_ms,
                value: v as f32,
                name: mavlink::types::CharArray::from(*name),
            }))
        })
        .collect()
}

/// A gauge's level as the number sent for it (`FLT_LVL`, …): 0 good, 1 warning, 2
/// critical; `None` for a word that is none of them.
pub fn level_code(level: &str) -> Option<f64> {
    match level {
        "good" => Some(0.0),
        "warning" => Some(1.0),
        "critical" => Some(2.0),
        _ => None,
    }
}

/// The level a number sent by [`level_code`] stands for; `None` for any other number.
pub fn level_of_code(code: f64) -> Option<&'static str> {
    ["good", "warning", "critical"]
        .into_iter()
        .find(|&l| level_code(l) == Some(code))
}

/// A pack's voltage (V) as millivolts, `u16::MAX` when not known.
fn millivolts(v: f64) -> u16 {
    if v.is_finite() {
        (v * 1000.0).round().clamp(0.0, 65_534.0) as u16
    } else {
        u16::MAX
    }
}

/// `BATTERY_STATUS` of battery `id`: one cell's worth of voltage (the pack's), the rest not
/// measured.
fn battery_status(id: u8, volts: f64, function: MavBatteryFunction, remaining: i8) -> MavMessage {
    let mut voltages = [u16::MAX; 10];
    voltages[0] = millivolts(volts);
    MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
        voltages,
        current_battery: -1,
        current_consumed: -1,
        energy_consumed: -1,
        temperature: i16::MAX,
        id,
        battery_function: function,
        mavtype: MavBatteryType::MAV_BATTERY_TYPE_NIMH,
        battery_remaining: remaining,
    })
}

/// A pack's charge at or below this (%) is at its warning level at the gauge's default
/// levels (the thesis's meter turned red with a third of the life left).
pub const WARNING_PERCENT: f64 = 100.0 / 3.0;
/// A pack's charge at or below this (%) is critical at the gauge's default levels.
pub const CRITICAL_PERCENT: f64 = 15.0;

/// The level (`good`, `warning`, `critical`) of a charge (%) at the gauge's default levels:
/// what a ground can tell from `battery_remaining` alone, for a vehicle that sends no level
/// of its own ([`level_code`]).
pub fn level_of_percent(percent: f64) -> &'static str {
    if percent <= CRITICAL_PERCENT {
        "critical"
    } else if percent <= WARNING_PERCENT {
        "warning"
    } else {
        "good"
    }
}

/// The flight battery's `battery_remaining`: its gauge's, or the bare charge when the
/// telemetry has no gauge row (-1: not known).
fn flight_percent(t: &Telemetry) -> i8 {
    match gauge(t, "flight") {
        Some(row) => whole_percent(row.percent),
        None => t.battery_remaining.map_or(-1, |r| whole_percent(100.0 * r)),
    }
}

/// A percentage rounded to a whole one in 0–100 (a charge that is not a number casts to
/// none: 0).
fn whole_percent(percent: f64) -> i8 {
    percent.round().clamp(0.0, 100.0) as i8
}

#[cfg(test)]
mod tests;
