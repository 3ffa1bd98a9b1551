//! From the servo controller board's outputs to what the rotor sees (H15 §15.5):
//! command limits, quantisation (about 150 steps rail to rail), the swashplate servos'
//! transfer function (Futaba S9402: a lead-lag times a second-order lag) and the digital tail
//! servo (Futaba S9450, second order at 7 Hz). The throttle channel goes to the electronic
//! governor, which has no servo.

use heli_proto::scb::Controls;
use serde::{Deserialize, Serialize};

use crate::model::ControlInputs;
use crate::params::Airframe;

/// Servo dynamics and resolution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServoParams {
    /// Steps from one end of a servo's travel to the other.
    pub quantisation_steps: f64,
    /// Swashplate servo natural frequency (rad/s).
    pub swash_wn_rps: f64,
    /// Swashplate servo damping ratio.
    pub swash_zeta: f64,
    /// Swashplate servo lead-lag zero (rad/s; H15 prints "T_z = 104 s").
    pub swash_zero_rps: f64,
    /// Swashplate servo lead-lag pole (rad/s; H15 prints "T_p = 33 s").
    pub swash_pole_rps: f64,
    /// Tail servo natural frequency (rad/s): 7 Hz.
    pub tail_wn_rps: f64,
    /// Tail servo damping ratio.
    pub tail_zeta: f64,
}

impl Default for ServoParams {
    fn default() -> Self {
        Self {
            quantisation_steps: 150.0,
            swash_wn_rps: 36.0,
            swash_zeta: 0.5,
            swash_zero_rps: 104.0,
            swash_pole_rps: 33.0,
            tail_wn_rps: 7.0 * 2.0 * std::f64::consts::PI,
            tail_zeta: 0.6,
        }
    }
}

/// A normalised command rounded to the servo's resolution.
pub fn quantise(command: f64, steps: f64) -> f64 {
    if steps <= 0.0 {
        return command;
    }
    let step = 2.0 / steps;
    (command / step).round() * step
}

/// One servo: an optional lead-lag (zero `z`, pole `p`) in series with a second-order lag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Servo {
    wn: f64,
    zeta: f64,
    lead_lag: Option<(f64, f64)>,
    /// Lead-lag state, position, rate.
    x: [f64; 3],
}

impl Servo {
    fn new(wn: f64, zeta: f64, lead_lag: Option<(f64, f64)>, position: f64) -> Self {
        let w = lead_lag.map_or(0.0, |(_, p)| position / p);
        Self {
            wn,
            zeta,
            lead_lag,
            x: [w, position, 0.0],
        }
    }

    fn derivative(&self, x: &[f64; 3], command: f64) -> [f64; 3] {
        let (w_dot, input) = match self.lead_lag {
            Some((z, p)) => (-p * x[0] + command, p / z * (command + (z - p) * x[0])),
            None => (0.0, command),
        };
        [
            w_dot,
            x[2],
            self.wn * self.wn * (input - x[1]) - 2.0 * self.zeta * self.wn * x[2],
        ]
    }

    /// Advances `dt_s` with the command held (RK4).
    pub fn step(&mut self, dt_s: f64, command: f64) {
        let x0 = self.x;
        let add = |k: &[f64; 3], h: f64| [x0[0] + h * k[0], x0[1] + h * k[1], x0[2] + h * k[2]];
        let k1 = self.derivative(&x0, command);
        let k2 = self.derivative(&add(&k1, 0.5 * dt_s), command);
        let k3 = self.derivative(&add(&k2, 0.5 * dt_s), command);
        let k4 = self.derivative(&add(&k3, dt_s), command);
        for i in 0..3 {
            self.x[i] += dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }

    /// Output position (normalised).
    pub fn position(&self) -> f64 {
        self.x[1]
    }
}

/// The four servos.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuators {
    params: ServoParams,
    lat: Servo,
    lon: Servo,
    col: Servo,
    tail: Servo,
    throttle: f64,
}

impl Actuators {
    /// Servos at rest at `command`.
    pub fn settled(params: ServoParams, command: &Controls) -> Self {
        let c = command.clamped();
        let swash = |x| {
            Servo::new(
                params.swash_wn_rps,
                params.swash_zeta,
                Some((params.swash_zero_rps, params.swash_pole_rps)),
                x,
            )
        };
        Self {
            params,
            lat: swash(c.aileron),
            lon: swash(c.elevator),
            col: swash(c.collective),
            tail: Servo::new(params.tail_wn_rps, params.tail_zeta, None, c.rudder),
            throttle: c.throttle,
        }
    }

    /// Moves the servos for `dt_s` toward `command` (limited and quantised).
    pub fn step(&mut self, dt_s: f64, command: &Controls) {
        self.step_at_speed(dt_s, command, ServoSpeeds::default());
    }

    /// Moves the servos like [`Actuators::step`], each at its own speed: 1 for a healthy
    /// servo, 0 for one that is stuck, in between for one that is slowed (its whole
    /// response runs that many times slower).
    pub fn step_at_speed(&mut self, dt_s: f64, command: &Controls, speeds: ServoSpeeds) {
        let c = command.clamped();
        let q = |u| quantise(u, self.params.quantisation_steps);
        let dt = |speed: f64| dt_s * speed.clamp(0.0, 1.0);
        self.lat.step(dt(speeds.aileron), q(c.aileron));
        self.lon.step(dt(speeds.elevator), q(c.elevator));
        self.col.step(dt(speeds.collective), q(c.collective));
        self.tail.step(dt(speeds.rudder), q(c.rudder));
        self.throttle = c.throttle;
    }

    /// Where the servos are (normalised).
    pub fn positions(&self) -> Controls {
        Controls {
            aileron: self.lat.position(),
            elevator: self.lon.position(),
            rudder: self.tail.position(),
            collective: self.col.position(),
            throttle: self.throttle,
        }
    }
}

/// How fast each servo responds (1 healthy, 0 stuck).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoSpeeds {
    /// Lateral cyclic servo.
    pub aileron: f64,
    /// Longitudinal cyclic servo.
    pub elevator: f64,
    /// Tail servo.
    pub rudder: f64,
    /// Collective servo.
    pub collective: f64,
}

impl Default for ServoSpeeds {
    fn default() -> Self {
        Self {
            aileron: 1.0,
            elevator: 1.0,
            rudder: 1.0,
            collective: 1.0,
        }
    }
}

/// Blade pitch and governor set point for normalised servo positions.
pub fn control_inputs(airframe: &Airframe, servo: &Controls) -> ControlInputs {
    ControlInputs {
        lat_rad: servo.aileron * airframe.cyclic_max_rad,
        lon_rad: servo.elevator * airframe.cyclic_max_rad,
        col_rad: servo.collective * airframe.collective_max_rad,
        tail_rad: servo.rudder * airframe.tail_max_rad,
        governor_setpoint_rps: servo.throttle.clamp(0.0, 1.0)
            * airframe.governor_full_scale_rpm
            * std::f64::consts::PI
            / 30.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn governed_throttle_is_1600_rpm_and_full_stick_is_the_published_limit() {
        let a = Airframe::default();
        let act = Actuators::settled(
            ServoParams::default(),
            &Controls {
                aileron: 1.0,
                elevator: -2.0,
                rudder: 0.0,
                collective: 0.5,
                throttle: 0.8,
            },
        );
        let u = control_inputs(&a, &act.positions());
        assert!((u.governor_setpoint_rps - 1600.0 * std::f64::consts::PI / 30.0).abs() < 1e-9);
        assert!((u.lat_rad - 0.096).abs() < 1e-12);
        assert!((u.lon_rad + 0.096).abs() < 1e-12, "clamped to the limit");
        assert!((u.col_rad - 0.0915).abs() < 1e-12);
    }

    #[test]
    fn quantisation_has_about_150_steps_rail_to_rail() {
        let steps: std::collections::BTreeSet<i64> = (0..=10_000)
            .map(|i| (quantise(-1.0 + 2.0 * f64::from(i) / 10_000.0, 150.0) * 1e6).round() as i64)
            .collect();
        assert_eq!(steps.len(), 151);
    }

    /// Gain and phase of a servo at `w` rad/s, measured by driving it with a sine.
    fn response(mut servo: Servo, w: f64) -> (f64, f64) {
        let dt = 1e-4;
        let periods = 20.0;
        let n = (periods * 2.0 * std::f64::consts::PI / w / dt) as usize;
        let (mut s, mut c) = (0.0, 0.0);
        let mut count = 0.0;
        for k in 0..n {
            let t = k as f64 * dt;
            servo.step(dt, (w * t).sin());
            if k > n / 2 {
                let tt = t + dt;
                s += servo.position() * (w * tt).sin();
                c += servo.position() * (w * tt).cos();
                count += 1.0;
            }
        }
        let (s, c) = (2.0 * s / count, 2.0 * c / count);
        ((s * s + c * c).sqrt(), c.atan2(s).to_degrees())
    }

    #[test]
    fn swashplate_servo_matches_the_published_frequency_response() {
        // heli-model.md §7: |H| = 0.998 / 0.868 and phase −28° / −96° at 10 / 30 rad/s
        // (the "90° phase lag at roughly 30 rad/s" of H15).
        let p = ServoParams::default();
        let servo = Servo::new(
            p.swash_wn_rps,
            p.swash_zeta,
            Some((p.swash_zero_rps, p.swash_pole_rps)),
            0.0,
        );
        let (g10, ph10) = response(servo, 10.0);
        let (g30, ph30) = response(servo, 30.0);
        assert!(
            (g10 - 0.998).abs() < 0.02 && (ph10 + 28.0).abs() < 2.0,
            "{g10} {ph10}"
        );
        assert!(
            (g30 - 0.868).abs() < 0.02 && (ph30 + 96.0).abs() < 2.0,
            "{g30} {ph30}"
        );
    }

    #[test]
    fn a_slowed_servo_lags_and_a_stuck_one_stays() {
        let start = Controls {
            throttle: 0.8,
            ..Controls::default()
        };
        let step = Controls {
            aileron: 0.5,
            ..start
        };
        let after = |speed: f64, seconds: f64| {
            let mut a = Actuators::settled(ServoParams::default(), &start);
            let speeds = ServoSpeeds {
                aileron: speed,
                ..ServoSpeeds::default()
            };
            for _ in 0..(seconds / 0.002) as usize {
                a.step_at_speed(0.002, &step, speeds);
            }
            a.positions().aileron
        };
        // Half as fast: in 40 ms it gets where the healthy one was at 20 ms.
        assert!((after(0.5, 0.04) - after(1.0, 0.02)).abs() < 1e-3);
        assert!(after(0.5, 0.02) < 0.8 * after(1.0, 0.02));
        assert!(after(1.0, 0.2) > 0.49);
        assert_eq!(after(0.0, 1.0), 0.0, "stuck");
    }

    #[test]
    fn tail_servo_is_a_7_hz_second_order_lag() {
        let p = ServoParams::default();
        let servo = Servo::new(p.tail_wn_rps, p.tail_zeta, None, 0.0);
        let (gain, phase) = response(servo, p.tail_wn_rps);
        // At the natural frequency a second-order lag has phase −90° and gain 1/(2ζ).
        assert!((phase + 90.0).abs() < 2.0, "{phase}");
        assert!((gain - 1.0 / (2.0 * p.tail_zeta)).abs() < 0.03, "{gain}");
    }
}
