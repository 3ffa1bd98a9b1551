//! The flight software's stream records as log messages: one channel per stream, SI units
//! named in the field names, plus the Foxglove views of the state and GPS streams.
//!
//! Shared by every owner of a log — the simulator's logger and the vehicle runtime — so that
//! a flight logged on the helicopter and one logged in simulation read the same.

use heli_fsw::streams::Record;
use serde_json::{Value, json};

use crate::{FlightLog, LogError, LogFile, foxglove};

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
                    "pos_ned_m": [nav.pos_ned_m.x, nav.pos_ned_m.y, nav.pos_ned_m.z],
                    "vel_ned_mps": [nav.vel_ned_mps.x, nav.vel_ned_mps.y, nav.vel_ned_mps.z],
                    "rate_body_rps": [nav.rate_body_rps.x, nav.rate_body_rps.y, nav.rate_body_rps.z],
                    "gyro_bias_rps": [nav.gyro_bias_rps.x, nav.gyro_bias_rps.y, nav.gyro_bias_rps.z],
                    "accel_bias_mps2": [nav.accel_bias_mps2.x, nav.accel_bias_mps2.y, nav.accel_bias_mps2.z],
                    "target_ned_m": r.value.target.map(|t| [t.pos_ned_m.x, t.pos_ned_m.y, t.pos_ned_m.z]),
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

/// The vehicle time of a record (µs).
pub fn record_time(record: &Record) -> u64 {
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

/// The Foxglove views of a record: a `foxglove.FrameTransform` for a state estimate, a
/// `foxglove.LocationFix` for a GPS solution with a fix; nothing for the other streams.
pub fn foxglove_views(record: &Record) -> Option<(&'static str, Value)> {
    match record {
        Record::State(r) => {
            let nav = &r.value.nav;
            let p = &nav.pos_ned_m;
            let q = nav.att.into_inner();
            let tf = foxglove::frame_transform(r.t_us, [p.x, p.y, p.z], [q.w, q.i, q.j, q.k]);
            Some((foxglove::TF_TOPIC, tf))
        }
        // 2D and 3D fixes only.
        Record::Gps(r) if matches!(r.value.fix.to_u8(), 2 | 3) => {
            let g = &r.value;
            let fix = foxglove::location_fix(r.t_us, g.lat_deg, g.lon_deg, g.alt_m);
            Some((foxglove::FIX_TOPIC, fix))
        }
        _ => None,
    }
}

impl<F: LogFile> FlightLog<F> {
    /// Appends a stream record to its channel, with the next sequence number of the channel,
    /// and its Foxglove view if it has one.
    pub fn write_record(&mut self, record: &Record) -> Result<(), LogError> {
        let (topic, t_us, value) = record_json(record);
        self.write(topic, t_us, &value)?;
        self.write_views(record)
    }

    /// Appends a stream record with its stream's own sequence number (its position in the
    /// stream since power-on, as `Stream::read_since` counts), so that records the logger
    /// missed show as a gap in the channel's numbers; and its Foxglove view.
    pub fn write_record_sequenced(
        &mut self,
        record: &Record,
        sequence: u64,
    ) -> Result<(), LogError> {
        let (topic, t_us, value) = record_json(record);
        // MCAP sequence numbers are 32 bits: they wrap after 4.3e9 records (500 days of IMU).
        self.write_sequenced(topic, sequence as u32, t_us, &value)?;
        self.write_views(record)
    }

    fn write_views(&mut self, record: &Record) -> Result<(), LogError> {
        let t_us = record_time(record);
        if let Some((topic, value)) = foxglove_views(record) {
            self.write(topic, t_us, &value)?;
        }
        // The helicopter's shape with its first pose, and again now and then.
        if matches!(record, Record::State(_)) && self.scene_due(t_us) {
            self.write(
                crate::scene::SCENE_TOPIC,
                t_us,
                &crate::scene::scene_update(t_us),
            )?;
        }
        Ok(())
    }

    /// Appends a flight-core event to `events`, and to `foxglove/log` for Foxglove's log
    /// panel.
    pub fn write_event(
        &mut self,
        t_us: u64,
        event: &heli_fsw::core::CoreEvent,
    ) -> Result<(), LogError> {
        let message = crate::events::event_json(t_us, event);
        self.write_event_message(t_us, &message)
    }

    /// Appends an event known only by the text [`crate::events::event_text`] made (its
    /// level is recovered from the text) to `events` and `foxglove/log`. A text that does
    /// not begin with its time is stamped `fallback_t_us`.
    pub fn write_event_text(&mut self, text: &str, fallback_t_us: u64) -> Result<(), LogError> {
        let (t_us, message) = crate::events::event_json_from_text(text).unwrap_or_else(|| {
            let message = crate::events::text_event_json(text, crate::EventLevel::Unknown);
            (fallback_t_us, message)
        });
        self.write_event_message(t_us, &message)
    }

    fn write_event_message(&mut self, t_us: u64, message: &Value) -> Result<(), LogError> {
        self.write("events", t_us, message)?;
        let level = crate::events::level_of(message);
        let text = message["text"].as_str().unwrap_or_default();
        self.write(foxglove::LOG_TOPIC, t_us, &foxglove::log(t_us, level, text))
    }
}

#[cfg(test)]
mod tests;
