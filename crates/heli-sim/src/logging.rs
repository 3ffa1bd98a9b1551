//! The flight software's stream records as JSON messages for the flight log (one channel per
//! stream, SI units named in the field names).

use heli_fsw::streams::Record;
use serde_json::{Value, json};

fn xyz(v: &nalgebra::Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The channel, time and content of a record.
pub fn record_json(record: &Record) -> (&'static str, u64, Value) {
    match record {
        Record::Imu(r) => (
            "imu",
            r.t_us,
            json!({
                "rate_rps": r.value.imu.rate_rps,
                "accel_mps2": r.value.imu.accel_mps2,
                "temp_c": r.value.imu.temp_c,
                "repeated": r.value.repeated,
            }),
        ),
        Record::State(r) => {
            let nav = &r.value.nav;
            let (roll, pitch, yaw) = nav.euler_rad();
            (
                "state",
                r.t_us,
                json!({
                    "phase": r.value.phase.name(),
                    "roll_rad": roll,
                    "pitch_rad": pitch,
                    "yaw_rad": yaw,
                    "pos_ned_m": xyz(&nav.pos_ned_m),
                    "vel_ned_mps": xyz(&nav.vel_ned_mps),
                    "rate_body_rps": xyz(&nav.rate_body_rps),
                    "gyro_bias_rps": xyz(&nav.gyro_bias_rps),
                    "accel_bias_mps2": xyz(&nav.accel_bias_mps2),
                    "target_ned_m": r.value.target.map(|t| xyz(&t.pos_ned_m)),
                }),
            )
        }
        Record::Servo(r) => {
            let c = &r.value.controls;
            (
                "servo",
                r.t_us,
                json!({
                    "aileron": c.aileron, "elevator": c.elevator, "rudder": c.rudder,
                    "collective": c.collective, "throttle": c.throttle, "rotor_rpm": r.value.rotor_rpm,
                }),
            )
        }
        Record::Uplink(r) => {
            let u = &r.value;
            let p = &u.pulses;
            (
                "uplink",
                r.t_us,
                json!({
                    "rotor_rpm": u.rotor_rpm,
                    "aileron_us": p.aileron_us, "elevator_us": p.elevator_us, "rudder_us": p.rudder_us,
                    "collective_us": p.collective_us, "throttle_us": p.throttle_us,
                    "auto": u.auto_mode, "bypass": u.bypass,
                    "receiver_batt_v": u.receiver_batt_v, "servo_batt_v": u.servo_batt_v,
                }),
            )
        }
        Record::Gps(r) => {
            let g = &r.value;
            (
                "gps",
                r.t_us,
                json!({
                    "tow_ms": g.tow_ms, "lat_deg": g.lat_deg, "lon_deg": g.lon_deg, "alt_m": g.alt_m,
                    "vel_ned_mps": g.vel_ned_mps, "satellites": g.satellites, "fix": format!("{:?}", g.fix),
                }),
            )
        }
        Record::Baro(r) => (
            "baro",
            r.t_us,
            json!({"pressure_mbar": r.value.pressure_mbar, "alt_m": r.value.alt_m}),
        ),
        Record::Compass(r) => (
            "compass",
            r.t_us,
            json!({
                "counts": r.value.adc.counts,
                "field_gauss": r.value.field.field_gauss,
                "heading_rad": r.value.heading_rad,
            }),
        ),
    }
}

/// The flight logger: an observer of the seven streams and the event list that appends what
/// is new to a [`heli_log::FlightLog`]. It only reads; it can fall behind by as much as the
/// streams keep (10 s here) before it misses anything, and counts what it missed.
pub struct StreamLogger<W: std::io::Write + std::io::Seek> {
    log: heli_log::FlightLog<W>,
    cursors: [u64; 7],
    events: usize,
    /// Records the streams had overwritten before the logger read them.
    pub missed: u64,
}

impl<W: std::io::Write + std::io::Seek> StreamLogger<W> {
    /// A logger writing to `log`.
    pub fn new(log: heli_log::FlightLog<W>) -> Self {
        Self {
            log,
            cursors: [0; 7],
            events: 0,
            missed: 0,
        }
    }

    /// Appends everything published since the last call.
    pub fn drain(&mut self, sim: &crate::Simulation) -> Result<(), heli_log::LogError> {
        let streams = sim.streams();
        let mut records: Vec<Record> = Vec::new();
        macro_rules! take {
            ($i:expr, $stream:expr, $variant:path) => {{
                let (new, next, missed) = $stream.read_since(self.cursors[$i]);
                self.cursors[$i] = next;
                self.missed += missed;
                records.extend(new.into_iter().map($variant));
            }};
        }
        take!(0, streams.imu, Record::Imu);
        take!(1, streams.state, Record::State);
        take!(2, streams.servo, Record::Servo);
        take!(3, streams.uplink, Record::Uplink);
        take!(4, streams.gps, Record::Gps);
        take!(5, streams.baro, Record::Baro);
        take!(6, streams.compass, Record::Compass);
        // Written in time order across streams, as a flight recorder would.
        records.sort_by_key(record_time);
        for record in &records {
            let (topic, t_us, value) = record_json(record);
            self.log.write(topic, t_us, &value)?;
        }
        for text in sim.events().iter().skip(self.events) {
            let t_us = text
                .strip_prefix("t=")
                .and_then(|rest| rest.split(' ').next())
                .and_then(|t| t.parse::<f64>().ok())
                .map_or(sim.now_us(), |t| (t * 1e6) as u64);
            self.log.write("events", t_us, &json!({ "text": text }))?;
        }
        self.events = sim.events().len();
        Ok(())
    }

    /// Messages written.
    pub fn messages(&self) -> u64 {
        self.log.messages()
    }

    /// Closes the log.
    pub fn finish(self) -> Result<W, heli_log::LogError> {
        self.log.finish()
    }
}

fn record_time(record: &Record) -> u64 {
    match record {
        Record::Imu(r) => r.t_us,
        Record::State(r) => r.t_us,
        Record::Servo(r) => r.t_us,
        Record::Uplink(r) => r.t_us,
        Record::Gps(r) => r.t_us,
        Record::Baro(r) => r.t_us,
        Record::Compass(r) => r.t_us,
    }
}
