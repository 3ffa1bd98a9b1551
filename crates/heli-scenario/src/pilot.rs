//! The pilot in a scenario: the transmitter's sticks and switches over time, with scripted
//! inputs of the kinds the thesis's flight tests used (steps, doublets, frequency sweeps), and
//! optionally a pilot who hovers the helicopter by hand.
//!
//! The hovering pilot is the same cascade the flight software uses for position hold, fed
//! with the true state (a pilot sees the helicopter) and acting through the sticks; it lets
//! manual-mode scenarios fly frequency sweeps from a hover, as a human pilot would.

use heli_control::{HoverController, HoverGains, Target, YawDamper};
use heli_nav::NavState;
use heli_proto::scb::Controls;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A stick channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// Lateral cyclic.
    Aileron,
    /// Longitudinal cyclic.
    Elevator,
    /// Tail.
    Rudder,
    /// Collective.
    Collective,
}

/// The shape of a scripted input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// Held at the amplitude for the duration.
    Step,
    /// Half the duration at +amplitude, half at −amplitude.
    Doublet,
    /// A sine whose frequency rises linearly from `f0_hz` to `f1_hz` over the duration.
    Sweep,
}

/// One scripted stick input, added to the stick's position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StickInput {
    /// Which stick.
    pub channel: Channel,
    /// What shape.
    pub shape: Shape,
    /// Start (s).
    pub start_s: f64,
    /// Duration (s).
    pub duration_s: f64,
    /// Amplitude (stick units, −1..1).
    pub amplitude: f64,
    /// Sweep start frequency (Hz).
    #[serde(default)]
    pub f0_hz: f64,
    /// Sweep end frequency (Hz).
    #[serde(default)]
    pub f1_hz: f64,
}

impl StickInput {
    /// The input's value at `t_s` (0 outside it).
    pub fn value(&self, t_s: f64) -> f64 {
        let tau = t_s - self.start_s;
        if !(0.0..self.duration_s).contains(&tau) {
            return 0.0;
        }
        match self.shape {
            Shape::Step => self.amplitude,
            Shape::Doublet => {
                if tau < 0.5 * self.duration_s {
                    self.amplitude
                } else {
                    -self.amplitude
                }
            }
            Shape::Sweep => {
                let k = (self.f1_hz - self.f0_hz) / self.duration_s;
                let phase = 2.0 * std::f64::consts::PI * (self.f0_hz * tau + 0.5 * k * tau * tau);
                self.amplitude * phase.sin()
            }
        }
    }
}

/// The pilot's transmitter over the flight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pilot {
    /// Aileron stick, −1..1.
    pub aileron: f64,
    /// Elevator stick, −1..1.
    pub elevator: f64,
    /// Rudder stick, −1..1.
    pub rudder: f64,
    /// Collective stick, −1..1.
    pub collective: f64,
    /// Throttle channel, 0..1 (0.8 governs the rotor at 1600 rpm).
    pub throttle: f64,
    /// Auto switch.
    pub auto: bool,
    /// Intervals [start, end) in seconds with the auto switch flipped from `auto`.
    pub auto_flipped: Vec<[f64; 2]>,
    /// Intervals [start, end) in seconds with the emergency bypass switch engaged.
    pub bypass: Vec<[f64; 2]>,
    /// Scripted inputs added to the sticks.
    pub inputs: Vec<StickInput>,
    /// While the auto switch is off the pilot hovers the helicopter by hand where it was
    /// when the switch went off (the scripted inputs come on top).
    pub hovers_in_manual: bool,
}

impl Default for Pilot {
    fn default() -> Self {
        Self {
            aileron: 0.0,
            elevator: 0.0,
            rudder: 0.0,
            collective: 0.0,
            throttle: 0.8,
            auto: true,
            auto_flipped: Vec::new(),
            bypass: Vec::new(),
            inputs: Vec::new(),
            hovers_in_manual: false,
        }
    }
}

fn within(intervals: &[[f64; 2]], t_s: f64) -> bool {
    intervals
        .iter()
        .any(|[start, end]| t_s >= *start && t_s < *end)
}

impl Pilot {
    /// The auto switch at `t_s`.
    pub fn auto_at(&self, t_s: f64) -> bool {
        self.auto != within(&self.auto_flipped, t_s)
    }

    /// The bypass switch at `t_s`.
    pub fn bypass_at(&self, t_s: f64) -> bool {
        within(&self.bypass, t_s)
    }

    /// The scripted sticks at `t_s`: the set positions plus every input.
    pub fn scripted(&self, t_s: f64) -> Controls {
        let mut c = Controls {
            aileron: self.aileron,
            elevator: self.elevator,
            rudder: self.rudder,
            collective: self.collective,
            throttle: self.throttle,
        };
        for input in &self.inputs {
            let v = input.value(t_s);
            match input.channel {
                Channel::Aileron => c.aileron += v,
                Channel::Elevator => c.elevator += v,
                Channel::Rudder => c.rudder += v,
                Channel::Collective => c.collective += v,
            }
        }
        c.clamped()
    }
}

/// A pilot hovering by hand: watches the true state and moves the sticks.
#[derive(Clone, Debug)]
pub struct HoveringPilot {
    hands: HoverController,
    target: Option<Target>,
    /// The flight computer's yaw damper, which the pilot's rudder trim works through.
    damper: YawDamper,
}

impl Default for HoveringPilot {
    fn default() -> Self {
        Self {
            hands: HoverController::new(HoverGains::default()),
            target: None,
            damper: YawDamper::default(),
        }
    }
}

impl HoveringPilot {
    /// Forgets the spot (the auto switch went back on).
    pub fn release(&mut self) {
        self.target = None;
        self.hands.reset();
    }

    /// The sticks that hold the helicopter over the spot it was at when the pilot took over.
    pub fn sticks(&mut self, truth: &NavState, dt_s: f64) -> Controls {
        let (_, _, yaw) = truth.euler_rad();
        let target = *self
            .target
            .get_or_insert(Target::hold(truth.pos_ned_m, yaw));
        let servo = self.hands.update(truth, &target, dt_s, true);
        // In manual mode the computer adds its trim and damping to the rudder stick; the
        // pilot's rudder is what the servo needs beyond that.
        let rudder = servo.rudder - self.damper.trim + self.damper.gain * truth.rate_body_rps.z;
        Controls { rudder, ..servo }
    }
}

/// The helicopter's true state in the form the pilot's hands read it.
pub fn seen_by_pilot(
    t_us: u64,
    att: nalgebra::UnitQuaternion<f64>,
    vel: Vector3<f64>,
    pos: Vector3<f64>,
    rate: Vector3<f64>,
) -> NavState {
    NavState {
        t_us,
        att,
        vel_ned_mps: vel,
        pos_ned_m: pos,
        rate_body_rps: rate,
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripted_shapes() {
        let step = StickInput {
            channel: Channel::Aileron,
            shape: Shape::Step,
            start_s: 1.0,
            duration_s: 2.0,
            amplitude: 0.3,
            f0_hz: 0.0,
            f1_hz: 0.0,
        };
        assert_eq!(step.value(0.9), 0.0);
        assert_eq!(step.value(1.5), 0.3);
        assert_eq!(step.value(3.0), 0.0);
        let doublet = StickInput {
            shape: Shape::Doublet,
            ..step
        };
        assert_eq!(doublet.value(1.2), 0.3);
        assert_eq!(doublet.value(2.5), -0.3);
        let sweep = StickInput {
            shape: Shape::Sweep,
            f0_hz: 0.5,
            f1_hz: 2.0,
            duration_s: 10.0,
            ..step
        };
        // Zero crossings get closer together as the frequency rises.
        let crossings = |from: f64, to: f64| {
            let mut n = 0;
            let mut t = from;
            while t < to {
                if sweep.value(t).signum() != sweep.value(t + 0.001).signum() {
                    n += 1;
                }
                t += 0.001;
            }
            n
        };
        assert!(crossings(9.0, 10.9) > 2 * crossings(1.1, 3.0));
    }

    #[test]
    fn switches_follow_their_schedules() {
        let p = Pilot {
            auto: true,
            auto_flipped: vec![[10.0, 20.0]],
            bypass: vec![[30.0, 31.0]],
            ..Pilot::default()
        };
        assert!(p.auto_at(5.0) && !p.auto_at(15.0) && p.auto_at(25.0));
        assert!(p.bypass_at(30.5) && !p.bypass_at(31.5));
    }
}
