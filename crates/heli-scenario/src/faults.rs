//! The fault catalog: what a scenario can break, when, and for how long (docs/scenarios.md
//! lists every kind with its PX4 `failure` and ArduPilot `SIM_*` equivalents).
//!
//! Faults act where the real failure would: in the bytes and readings a device puts on its
//! wire, in the servos and the engine, in the pilot's receiver, in the flight computer's
//! power. The flight software only ever sees their effects.

use serde::{Deserialize, Serialize};

/// Faults injected into the run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Faults {
    /// The phase of the flight software (its name, as the state records and the heartbeat
    /// give it: `accelerate` for the roll manoeuvre's run-up, `hold`, `land`, …) from whose
    /// first moment every fault time below counts; before it, no timed fault acts. None:
    /// from the start of the run (`crate::fault_timing`).
    pub timed_from: Option<String>,
    /// Probability that an IMU packet is lost (0..1).
    pub imu_drop_rate: f64,
    /// Intervals [start, end) in seconds during which the GPS sends nothing.
    pub gps_outages: Vec<[f64; 2]>,
    /// Intervals [start, end) in seconds during which the pilot's transmitter is lost (the
    /// receiver then commands every channel to zero).
    pub transmitter_lost: Vec<[f64; 2]>,
    /// Intervals during which the servo board's uplink line is silent (the board sends
    /// nothing at all, unlike a lost transmitter).
    pub uplink_silent: Vec<[f64; 2]>,
    /// Intervals during which the IMU sends nothing.
    pub imu_silent: Vec<[f64; 2]>,
    /// Intervals during which the altimeter neither answers nor sends (from 0: its handshake
    /// fails).
    pub baro_silent: Vec<[f64; 2]>,
    /// Intervals during which the compass channels are not read.
    pub compass_silent: Vec<[f64; 2]>,
    /// Intervals during which the IMU is stuck: it repeats its last packet, byte for byte.
    pub imu_stuck: Vec<[f64; 2]>,
    /// GPS glitches: the reported position jumps by an offset for a while.
    pub gps_glitches: Vec<GpsGlitch>,
    /// The GPS reports a forced satellite count for a while.
    pub gps_satellites: Vec<ForcedSatellites>,
    /// Serial bytes lost on their way to the flight computer.
    pub byte_loss: Vec<ByteLoss>,
    /// Device faults: off, stuck, garbage, wrong (bias, scale, spikes), slow, delayed; each
    /// at a time, for a duration, optionally intermittent.
    pub devices: Vec<DeviceFault>,
    /// Servo faults: a servo stuck where it is, or slowed.
    pub servos: Vec<ServoFault>,
    /// Engine faults: the power it can give falls to a fraction (0: the engine quits).
    pub engine: Vec<EngineFault>,
    /// Extra drains on a battery.
    pub battery_drains: Vec<BatteryDrain>,
    /// Brown-outs of the flight computer: no power from start to end, then it boots again
    /// and the flight process restarts in the air.
    pub brownouts: Vec<[f64; 2]>,
    /// The pilot's receiver reports one channel frozen at its value when the fault begins.
    pub rc_frozen: Vec<FrozenChannel>,
    /// A flickering switch on the transmitter: the auto or bypass switch toggles every half
    /// period.
    pub switch_flicker: Vec<SwitchFlicker>,
}

/// A GPS glitch: the reported position is offset from `start_s` to `end_s`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GpsGlitch {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Offset north (m).
    pub north_m: f64,
    /// Offset east (m).
    pub east_m: f64,
}

/// A forced GPS satellite count from `start_s` to `end_s`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForcedSatellites {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Satellites reported.
    pub satellites: u8,
}

/// Bytes of one port lost at random, each with probability `rate`, from `start_s` to `end_s`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ByteLoss {
    /// The port: `imu`, `scb`, `gps` or `baro`.
    pub port: String,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Probability that a byte is lost (0..1).
    pub rate: f64,
}

impl Faults {
    /// True when `t_s` falls in one of `windows`.
    pub fn active(windows: &[[f64; 2]], t_s: f64) -> bool {
        windows
            .iter()
            .any(|[start, end]| t_s >= *start && t_s < *end)
    }
}

/// One battery pack of a scenario: how big, how full, how loaded, how warm, how worn. The
/// flight pack's voltage reaches the battery ADC channel; the receiver and servo packs'
/// reach the servo board's uplink (RTXB, Sbat).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Battery {
    /// Capacity of its type, new, at 20 °C (A h).
    pub capacity_ah: f64,
    /// Charge at power-on, fraction of the capacity (0..1).
    pub charge: f64,
    /// Current drawn from it (A).
    pub load_a: f64,
    /// Its temperature (°C).
    pub temperature_c: f64,
    /// Charge cycles it has had (its capacity fades with them).
    pub cycles: f64,
    /// Its capacity against what its type says (1; a weak pack less).
    pub health: f64,
}

impl Default for Battery {
    /// The flight pack: 1.7 A h, full, 1.8 A.
    fn default() -> Self {
        Self::of(heli_power::PackType::FLIGHT, 1.8)
    }
}

impl Battery {
    /// A new, full pack of `pack`'s capacity carrying `load_a` at 15 °C.
    pub fn of(pack: heli_power::PackType, load_a: f64) -> Self {
        Self {
            capacity_ah: pack.capacity_ah,
            charge: 1.0,
            load_a,
            temperature_c: 15.0,
            cycles: 0.0,
            health: 1.0,
        }
    }

    /// The receiver pack: 0.6 A h, 0.25 A.
    pub fn receiver() -> Self {
        Self::of(heli_power::PackType::RECEIVER, 0.25)
    }

    /// The servo pack: 1.1 A h, 0.8 A.
    pub fn servo() -> Self {
        Self::of(heli_power::PackType::SERVO, 0.8)
    }
}

/// The servo board's two packs and the hot-swap.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Power {
    /// The hot-swap: the ground battery powers the avionics until this time (s), then the
    /// flight batteries (0: on the flight batteries from the start).
    pub ground_until_s: f64,
    /// The servo board's logic and receiver pack (RTXB).
    pub receiver: Battery,
    /// The servo pack (Sbat).
    pub servo: Battery,
    /// The temperature the operator tells the flight software (°C); unset: the flight
    /// pack's, as if measured.
    pub told_temperature_c: Option<f64>,
}

impl Default for Power {
    fn default() -> Self {
        Self {
            ground_until_s: 0.0,
            receiver: Battery::receiver(),
            servo: Battery::servo(),
            told_temperature_c: None,
        }
    }
}

/// Which pack a drain acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PackName {
    /// The flight pack.
    Flight,
    /// The receiver pack.
    Receiver,
    /// The servo pack.
    Servo,
}

/// A drain no one planned (a short, a heater left on, a stalled servo): `extra_a` more
/// from `start_s` to `end_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatteryDrain {
    /// Which pack.
    pub battery: PackName,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// The extra current (A).
    pub extra_a: f64,
}

/// A device a fault can act on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Device {
    /// The IMU (serial).
    Imu,
    /// The GPS receiver (serial).
    Gps,
    /// The barometric altimeter (serial).
    Baro,
    /// The compass (three ADC channels).
    Compass,
    /// The servo board's uplink to the computer (serial).
    Uplink,
    /// The flight battery's voltage (ADC).
    Battery,
}

impl Device {
    /// Every device, in the order of the docs.
    pub const ALL: [Device; 6] = [
        Device::Imu,
        Device::Gps,
        Device::Baro,
        Device::Compass,
        Device::Uplink,
        Device::Battery,
    ];

    /// The name used in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            Device::Imu => "imu",
            Device::Gps => "gps",
            Device::Baro => "baro",
            Device::Compass => "compass",
            Device::Uplink => "uplink",
            Device::Battery => "battery",
        }
    }

    /// What a wrong reading of the device is wrong in, and its unit (for `bias` and
    /// `spikes` values).
    pub fn reading(self) -> &'static str {
        match self {
            Device::Imu => "angular rate, each axis (rad/s)",
            Device::Gps => "position north and east (m)",
            Device::Baro => "altitude (m)",
            Device::Compass => "magnetic field, each axis (gauss)",
            Device::Uplink => "rotor speed (rpm)",
            Device::Battery => "voltage (V)",
        }
    }
}

/// What goes wrong with a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeviceFaultKind {
    /// Sends nothing (an unplugged cable, a dead device).
    Off,
    /// Repeats its last transmission or reading, byte for byte.
    Stuck,
    /// Bytes replaced by random ones, each with probability `rate` (ADC devices: a random
    /// reading with that probability).
    Garbage,
    /// Its reading offset by `value` (unit: [`Device::reading`]).
    Bias,
    /// Its reading multiplied by `value`.
    Scale,
    /// Spikes of ±`value` on its reading, each sample with probability `rate`.
    Spikes,
    /// A lower rate: only one transmission in `value` (an integer from 2) gets out.
    Slow,
    /// Everything it sends arrives `value` seconds late.
    Delayed,
}

impl DeviceFaultKind {
    /// The name used in scenario files.
    pub fn name(self) -> &'static str {
        match self {
            DeviceFaultKind::Off => "off",
            DeviceFaultKind::Stuck => "stuck",
            DeviceFaultKind::Garbage => "garbage",
            DeviceFaultKind::Bias => "bias",
            DeviceFaultKind::Scale => "scale",
            DeviceFaultKind::Spikes => "spikes",
            DeviceFaultKind::Slow => "slow",
            DeviceFaultKind::Delayed => "delayed",
        }
    }

    /// The kinds that change the reading itself.
    pub fn is_wrong_reading(self) -> bool {
        matches!(
            self,
            DeviceFaultKind::Bias | DeviceFaultKind::Scale | DeviceFaultKind::Spikes
        )
    }
}

fn full_duty() -> f64 {
    1.0
}

/// One device fault on a schedule: from `start_s` to `end_s`; with `period_s` > 0 it is
/// intermittent, on for the first `duty` fraction of every period.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceFault {
    /// Which device.
    pub device: Device,
    /// What goes wrong.
    pub kind: DeviceFaultKind,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// The amount: bias, scale factor, spike size, rate divisor or delay (s), by kind.
    #[serde(default)]
    pub value: f64,
    /// A probability for `garbage` (per byte or reading) and `spikes` (per sample).
    #[serde(default)]
    pub rate: f64,
    /// Intermittent: the period of the on/off cycle (s); 0 for a fault that stays on.
    #[serde(default)]
    pub period_s: f64,
    /// Intermittent: the fraction of each period the fault is on (0..1].
    #[serde(default = "full_duty")]
    pub duty: f64,
}

impl DeviceFault {
    /// Whether the fault acts at `t_s`.
    pub fn active(&self, t_s: f64) -> bool {
        in_schedule(t_s, self.start_s, self.end_s, self.period_s, self.duty)
    }
}

/// True when `t_s` is in [start, end) and, for a cycle of `period_s` > 0, in the first
/// `duty` fraction of its period.
pub fn in_schedule(t_s: f64, start_s: f64, end_s: f64, period_s: f64, duty: f64) -> bool {
    if !(t_s >= start_s && t_s < end_s) {
        return false;
    }
    if period_s <= 0.0 {
        return true;
    }
    let phase = (t_s - start_s).rem_euclid(period_s);
    phase < duty * period_s
}

/// What goes wrong with a servo.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ServoFaultKind {
    /// Stays where it is, whatever it is told (a stripped gear, a jammed linkage).
    Stuck,
    /// Responds `factor` times as fast (a weak servo, low servo battery).
    Slow,
}

/// A servo fault from `start_s` to `end_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoFault {
    /// Which servo (the stick channel it moves).
    pub channel: crate::pilot::Channel,
    /// What goes wrong.
    pub kind: ServoFaultKind,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// For `slow`: bandwidth factor (0..1).
    #[serde(default)]
    pub factor: f64,
}

/// The engine gives at most `power` (a fraction of its full power; 0: it quits) from
/// `start_s` to `end_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EngineFault {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Fraction of full power available (0..1).
    pub power: f64,
}

/// A receiver channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RcChannel {
    /// Lateral cyclic stick.
    Aileron,
    /// Longitudinal cyclic stick.
    Elevator,
    /// Rudder stick.
    Rudder,
    /// Collective stick.
    Collective,
    /// Throttle.
    Throttle,
}

/// One receiver channel frozen at its value when the fault begins.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrozenChannel {
    /// Which channel.
    pub channel: RcChannel,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
}

/// A transmitter switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Switch {
    /// The auto switch.
    Auto,
    /// The emergency bypass switch.
    Bypass,
}

/// A switch that flickers: from `start_s` to `end_s` it reads the opposite of its position
/// for the first half of every `period_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwitchFlicker {
    /// Which switch.
    pub switch: Switch,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Period of the flicker (s).
    pub period_s: f64,
}

/// How a wind change goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WindShape {
    /// A gust: the change is there from `start_s` to `end_s`, then gone.
    Gust,
    /// A step: the change comes at `start_s` and stays (`end_s` is ignored).
    Step,
    /// A ramp: the change grows linearly from `start_s` to `end_s`, then stays.
    Ramp,
}

/// A change of the wind over time, added to the steady wind.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindChange {
    /// Its shape.
    pub shape: WindShape,
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// The change, NED (m/s).
    pub wind_ned_mps: [f64; 3],
}

impl WindChange {
    /// How much of the change there is at `t_s` (0..1).
    pub fn fraction(&self, t_s: f64) -> f64 {
        if t_s < self.start_s {
            return 0.0;
        }
        match self.shape {
            WindShape::Gust => f64::from(u8::from(t_s < self.end_s)),
            WindShape::Step => 1.0,
            WindShape::Ramp if t_s >= self.end_s => 1.0,
            WindShape::Ramp => (t_s - self.start_s) / (self.end_s - self.start_s),
        }
    }
}

impl Faults {
    /// Whether the flight computer is without power at `t_s`.
    pub fn browned_out(&self, t_s: f64) -> bool {
        Self::active(&self.brownouts, t_s)
    }

    /// The fraction of its power the engine can give at `t_s`.
    pub fn engine_power(&self, t_s: f64) -> f64 {
        self.engine
            .iter()
            .filter(|e| t_s >= e.start_s && t_s < e.end_s)
            .map(|e| e.power)
            .fold(1.0, f64::min)
    }

    /// Whether `switch` reads the opposite of its position at `t_s`.
    pub fn switch_flipped(&self, switch: Switch, t_s: f64) -> bool {
        self.switch_flicker
            .iter()
            .filter(|f| f.switch == switch)
            .any(|f| in_schedule(t_s, f.start_s, f.end_s, f.period_s, 0.5))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_intermittent_fault_is_on_for_its_duty() {
        let f = DeviceFault {
            device: Device::Gps,
            kind: DeviceFaultKind::Off,
            start_s: 10.0,
            end_s: 20.0,
            value: 0.0,
            rate: 0.0,
            period_s: 2.0,
            duty: 0.25,
        };
        let on: Vec<bool> = [9.9, 10.0, 10.4, 10.6, 12.1, 12.6, 19.9, 20.0]
            .iter()
            .map(|t| f.active(*t))
            .collect();
        assert_eq!(on, [false, true, true, false, true, false, false, false]);
    }

    #[test]
    fn wind_changes_over_time_and_with_height() {
        let mut s = crate::hover();
        s.wind_ned_mps = [2.0, 0.0, 0.0];
        s.wind_shear_mps_per_m = [0.1, 0.0, 0.0];
        s.wind_changes = vec![
            WindChange {
                shape: WindShape::Gust,
                start_s: 10.0,
                end_s: 12.0,
                wind_ned_mps: [0.0, 5.0, 0.0],
            },
            WindChange {
                shape: WindShape::Ramp,
                start_s: 20.0,
                end_s: 30.0,
                wind_ned_mps: [0.0, 0.0, 1.0],
            },
            WindChange {
                shape: WindShape::Step,
                start_s: 40.0,
                end_s: 0.0,
                wind_ned_mps: [-1.0, 0.0, 0.0],
            },
        ];
        let w = |t, h| s.wind_at(t, h);
        assert_eq!(w(0.0, 0.0).x, 2.0);
        assert_eq!(w(0.0, 10.0).x, 3.0, "shear: 0.1 (m/s)/m");
        assert_eq!(w(11.0, 0.0).y, 5.0, "gust");
        assert_eq!(w(12.0, 0.0).y, 0.0, "gust over");
        assert_eq!(w(25.0, 0.0).z, 0.5, "half-way up the ramp");
        assert_eq!(w(35.0, 0.0).z, 1.0, "ramp done");
        assert_eq!(w(50.0, 0.0).x, 1.0, "step stays");
    }
}
