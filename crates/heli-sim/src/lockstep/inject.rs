//! The fault catalog at work: device faults on what each device transmits or reads, servo
//! and engine faults on the physics, receiver faults on the pilot's channels
//! ([`heli_scenario::faults`]).

use super::*;
use heli_model::actuators::ServoSpeeds;
use heli_scenario::faults::{Device, DeviceFault, DeviceFaultKind, RcChannel, ServoFaultKind};
use heli_scenario::pilot::Channel as ServoChannel;

/// What the injector remembers between transmissions.
#[derive(Clone)]
pub(super) struct Injector {
    /// Its own random stream, so that faults change no other noise.
    noise: Noise,
    /// The last transmission of each device, repeated while it is stuck.
    last: [Option<Bytes>; 6],
    /// The last ADC reading of the compass and the battery, repeated while stuck.
    last_compass: Option<CompassAdc>,
    last_battery: Option<BatteryAdc>,
    /// Transmissions of each device while it is slow, to let one in `n` out.
    slow_count: [u64; 6],
    /// Receiver channels frozen: the fault's index and the value it froze at.
    frozen: Vec<(usize, f64)>,
}

impl Injector {
    pub(super) fn new(seed: u64) -> Self {
        Self {
            noise: Noise::new(seed, 9),
            last: [None; 6],
            last_compass: None,
            last_battery: None,
            slow_count: [0; 6],
            frozen: Vec::new(),
        }
    }
}

fn index(device: Device) -> usize {
    Device::ALL.iter().position(|d| *d == device).unwrap_or(0)
}

/// The device on the far end of a serial port.
pub(super) fn device_of(port: Port) -> Device {
    match port {
        Port::Imu => Device::Imu,
        Port::Scb => Device::Uplink,
        Port::Gps => Device::Gps,
        Port::Baro => Device::Baro,
    }
}

impl Simulation {
    pub(super) fn t_s(&self) -> f64 {
        self.now_us as f64 * 1e-6
    }

    /// The device faults of `device` acting now.
    fn acting(&self, device: Device) -> impl Iterator<Item = DeviceFault> + '_ {
        let t_s = self.t_s();
        self.scenario
            .faults
            .devices
            .iter()
            .filter(move |f| f.device == device && f.active(t_s))
            .copied()
    }

    /// A reading of `device` after its wrong-reading faults (bias, scale, spikes).
    pub(super) fn wrong_reading(&mut self, device: Device, value: f64) -> f64 {
        let faults: Vec<DeviceFault> = self
            .acting(device)
            .filter(|f| f.kind.is_wrong_reading())
            .collect();
        faults.iter().fold(value, |v, f| match f.kind {
            DeviceFaultKind::Bias => v + f.value,
            DeviceFaultKind::Scale => v * f.value,
            DeviceFaultKind::Spikes if self.injector.noise.uniform() < f.rate => {
                let sign = if self.injector.noise.uniform() < 0.5 {
                    -1.0
                } else {
                    1.0
                };
                v + sign * f.value
            }
            _ => v,
        })
    }

    /// A vector reading (each axis alike) after its wrong-reading faults.
    pub(super) fn wrong_vector(&mut self, device: Device, v: Vector3<f64>) -> Vector3<f64> {
        if !self.acting(device).any(|f| f.kind.is_wrong_reading()) {
            return v;
        }
        Vector3::new(
            self.wrong_reading(device, v.x),
            self.wrong_reading(device, v.y),
            self.wrong_reading(device, v.z),
        )
    }

    /// Whether `device`'s transmission gets out under its `off` and `slow` faults (a slow
    /// device counts its transmissions and lets one in `n` out).
    fn gets_out(&mut self, device: Device) -> bool {
        let (off, slow) = self
            .acting(device)
            .fold((false, 0.0_f64), |(off, slow), f| match f.kind {
                DeviceFaultKind::Off => (true, slow),
                DeviceFaultKind::Slow => (off, slow.max(f.value)),
                _ => (off, slow),
            });
        if off {
            self.metrics.fault_dropped += 1;
            return false;
        }
        if slow >= 2.0 {
            let count = &mut self.injector.slow_count[index(device)];
            *count += 1;
            if *count % slow.round() as u64 != 1 {
                self.metrics.fault_dropped += 1;
                return false;
            }
        }
        true
    }

    /// One transmission of a serial device through its faults: `None` when nothing gets
    /// out, otherwise the bytes that do (stuck, garbled) and how late they arrive (µs).
    pub(super) fn faulted_transmission(
        &mut self,
        device: Device,
        bytes: Bytes,
    ) -> Option<(Bytes, u64)> {
        if !self.gets_out(device) {
            return None;
        }
        let stuck = self
            .acting(device)
            .any(|f| f.kind == DeviceFaultKind::Stuck);
        let last = &mut self.injector.last[index(device)];
        let bytes = match (stuck, *last) {
            (true, Some(previous)) => previous,
            _ => bytes,
        };
        *last = Some(bytes);
        let garbage = self
            .acting(device)
            .filter(|f| f.kind == DeviceFaultKind::Garbage)
            .map(|f| f.rate)
            .fold(0.0, f64::max);
        let bytes = if garbage > 0.0 {
            let noise = &mut self.injector.noise;
            let garbled: Vec<u8> = bytes
                .as_slice()
                .iter()
                .map(|&b| {
                    if noise.uniform() < garbage {
                        (noise.uniform() * 256.0) as u8
                    } else {
                        b
                    }
                })
                .collect();
            Bytes::from_slice(&garbled)
        } else {
            bytes
        };
        let delay_s = self
            .acting(device)
            .filter(|f| f.kind == DeviceFaultKind::Delayed)
            .map(|f| f.value)
            .fold(0.0, f64::max);
        Some((bytes, (delay_s * 1e6) as u64))
    }

    /// The compass reading through its faults, or `None` when it is not read.
    pub(super) fn faulted_compass(&mut self, adc: CompassAdc) -> Option<CompassAdc> {
        if !self.gets_out(Device::Compass) {
            return None;
        }
        let field = Vector3::from(adc.raw_field().field_gauss);
        let field = self.wrong_vector(Device::Compass, field);
        let mut adc = CompassAdc::from_field(&MagField {
            field_gauss: field.into(),
        });
        if self
            .acting(Device::Compass)
            .any(|f| f.kind == DeviceFaultKind::Stuck)
            && let Some(last) = self.injector.last_compass
        {
            adc = last;
        }
        if let Some(rate) = self.garbage_rate(Device::Compass)
            && self.injector.noise.uniform() < rate
        {
            adc.counts = adc.counts.map(|_| self.random_count());
        }
        self.injector.last_compass = Some(adc);
        Some(adc)
    }

    /// The battery voltage reading through its faults, or `None` when it is not read.
    pub(super) fn faulted_battery(&mut self, volts: f64) -> Option<BatteryAdc> {
        if !self.gets_out(Device::Battery) {
            return None;
        }
        let mut adc = BatteryAdc::from_volts(self.wrong_reading(Device::Battery, volts));
        if self
            .acting(Device::Battery)
            .any(|f| f.kind == DeviceFaultKind::Stuck)
            && let Some(last) = self.injector.last_battery
        {
            adc = last;
        }
        if let Some(rate) = self.garbage_rate(Device::Battery)
            && self.injector.noise.uniform() < rate
        {
            adc.counts = self.random_count();
        }
        self.injector.last_battery = Some(adc);
        Some(adc)
    }

    fn garbage_rate(&self, device: Device) -> Option<f64> {
        self.acting(device)
            .filter(|f| f.kind == DeviceFaultKind::Garbage)
            .map(|f| f.rate)
            .reduce(f64::max)
    }

    fn random_count(&mut self) -> u16 {
        (self.injector.noise.uniform() * 4096.0) as u16
    }

    /// How fast each servo responds now (stuck 0, slowed by its factor).
    pub(super) fn servo_speeds(&self) -> ServoSpeeds {
        let t_s = self.t_s();
        let mut speeds = ServoSpeeds::default();
        for f in self
            .scenario
            .faults
            .servos
            .iter()
            .filter(|f| t_s >= f.start_s && t_s < f.end_s)
        {
            let speed = match f.kind {
                ServoFaultKind::Stuck => 0.0,
                ServoFaultKind::Slow => f.factor,
            };
            let slot = match f.channel {
                ServoChannel::Aileron => &mut speeds.aileron,
                ServoChannel::Elevator => &mut speeds.elevator,
                ServoChannel::Rudder => &mut speeds.rudder,
                ServoChannel::Collective => &mut speeds.collective,
            };
            *slot = slot.min(speed);
        }
        speeds
    }

    /// The pilot's command as the receiver reports it: frozen channels hold the value they
    /// froze at; a flickering switch reads the other way half of each period.
    pub(super) fn receiver(&mut self) -> PilotCommand {
        let mut pilot = self.pilot();
        let t_s = self.t_s();
        let faults = &self.scenario.faults;
        if faults.switch_flipped(heli_scenario::faults::Switch::Auto, t_s) {
            pilot.auto_mode = !pilot.auto_mode;
        }
        if faults.switch_flipped(heli_scenario::faults::Switch::Bypass, t_s) {
            pilot.bypass = !pilot.bypass;
        }
        for (i, f) in faults.rc_frozen.iter().enumerate() {
            let frozen = &mut self.injector.frozen;
            if !(t_s >= f.start_s && t_s < f.end_s) {
                frozen.retain(|(k, _)| *k != i);
                continue;
            }
            let slot = match f.channel {
                RcChannel::Aileron => &mut pilot.sticks.aileron,
                RcChannel::Elevator => &mut pilot.sticks.elevator,
                RcChannel::Rudder => &mut pilot.sticks.rudder,
                RcChannel::Collective => &mut pilot.sticks.collective,
                RcChannel::Throttle => &mut pilot.sticks.throttle,
            };
            match frozen.iter().find(|(k, _)| *k == i) {
                Some((_, value)) => *slot = *value,
                None => frozen.push((i, *slot)),
            }
        }
        pilot
    }
}
