//! The simulator's truth at one instant, for a view of the helicopter (`heli hilsim --view`):
//! where it is, how it is turned, how its rotor disk is tilted, the wind it flies in. Never
//! shown to the flight software.

use serde::Serialize;

use super::Simulation;

/// The truth at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TruthFrame {
    /// Simulated time (s).
    pub t_s: f64,
    /// Position, NED from the take-off point's origin (m).
    pub pos_ned_m: [f64; 3],
    /// Velocity, NED (m/s).
    pub vel_ned_mps: [f64; 3],
    /// Roll, pitch, yaw (rad).
    pub euler_rad: [f64; 3],
    /// The main rotor's flapping: longitudinal a1 (positive: the disk tilted back) and
    /// lateral b1 (positive: tilted right), rad.
    pub flap_rad: [f64; 2],
    /// Rotor speed (rpm).
    pub rotor_rpm: f64,
    /// The wind at the helicopter, gusts included, NED (m/s).
    pub wind_ned_mps: [f64; 3],
    /// Skid ends touching the ground.
    pub contact_points: u32,
    /// What the pilot's transmitter sends: aileron, elevator, rudder, collective, throttle.
    pub sticks: [f64; 5],
    /// The transmitter's auto switch.
    pub auto_switch: bool,
    /// The emergency bypass switch.
    pub bypass_switch: bool,
    /// The transmitter's signal is lost.
    pub signal_lost: bool,
    /// A person holds the transmitter (`heli hilsim --pilot`), not the scenario's script.
    pub live_pilot: bool,
    /// Where the servos are: aileron, elevator, rudder, collective, throttle.
    pub servos: [f64; 5],
}

fn channels(c: &heli_proto::scb::Controls) -> [f64; 5] {
    [c.aileron, c.elevator, c.rudder, c.collective, c.throttle]
}

impl Simulation {
    /// The truth now.
    pub fn truth_frame(&self) -> TruthFrame {
        let s = &self.heli.state;
        let (roll, pitch, yaw) = s.att.euler_angles();
        let v = s.vel_ned_mps();
        let w = self.env.wind_ned_mps;
        let tx = self.pilot();
        TruthFrame {
            t_s: self.now_us as f64 * 1e-6,
            pos_ned_m: [s.pos_ned_m.x, s.pos_ned_m.y, s.pos_ned_m.z],
            vel_ned_mps: [v.x, v.y, v.z],
            euler_rad: [roll, pitch, yaw],
            flap_rad: [s.flap_lon_rad, s.flap_lat_rad],
            rotor_rpm: s.rotor_rps * 30.0 / std::f64::consts::PI,
            wind_ned_mps: [w.x, w.y, w.z],
            contact_points: self.heli.outputs.contact_points,
            sticks: channels(&tx.sticks),
            auto_switch: tx.auto_mode,
            bypass_switch: tx.bypass,
            signal_lost: tx.signal_lost,
            live_pilot: self.live_pilot.is_some(),
            servos: channels(&self.servo_positions()),
        }
    }
}
