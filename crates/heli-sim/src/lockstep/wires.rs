//! The wires between the simulated devices and the flight computer: scheduling, bytes at
//! their baud rate through the fault catalog, and what each device does when its event
//! comes (a sample, a transmission, bytes reaching it).

use super::*;

impl Simulation {
    pub(super) fn schedule(&mut self, t_us: u64, kind: Kind) {
        self.seq += 1;
        self.queue.push(Reverse(Event {
            t_us,
            class: kind.class(),
            seq: self.seq,
            kind,
        }));
    }

    pub(super) fn baud(port: Port) -> u32 {
        match port {
            Port::Imu => heli_proto::imu::BAUD,
            Port::Scb => heli_proto::scb::BAUD,
            Port::Gps => heli_proto::gps::BAUD,
            Port::Baro => heli_proto::baro::BAUD,
        }
    }

    pub(super) fn send_to_device(&mut self, port: Port, bytes: Bytes, now_us: u64) {
        let at = now_us + transmit_time_us(bytes.as_slice().len(), Self::baud(port));
        self.schedule(at, Kind::ToDevice(port, bytes));
    }

    pub(super) fn send_to_computer(&mut self, port: Port, bytes: Bytes, sent_us: u64) {
        let Some((bytes, delay_us)) = self.faulted_transmission(inject::device_of(port), bytes)
        else {
            return;
        };
        let at = sent_us + delay_us + transmit_time_us(bytes.as_slice().len(), Self::baud(port));
        let bytes = self.lose_bytes(port, bytes);
        self.schedule(at, Kind::ToComputer(port, bytes));
    }

    /// Serial bytes lost on the way (the scenario's `byte_loss`), each at random.
    pub(super) fn lose_bytes(&mut self, port: Port, bytes: Bytes) -> Bytes {
        let t_s = self.now_us as f64 * 1e-6;
        let rate = self
            .scenario
            .faults
            .byte_loss
            .iter()
            .filter(|b| b.port == port.name() && t_s >= b.start_s && t_s < b.end_s)
            .map(|b| b.rate)
            .fold(0.0, f64::max);
        if rate <= 0.0 {
            return bytes;
        }
        let kept: Vec<u8> = bytes
            .as_slice()
            .iter()
            .copied()
            .filter(|_| self.loss_noise.uniform() >= rate)
            .collect();
        self.metrics.bytes_lost += (bytes.as_slice().len() - kept.len()) as u64;
        Bytes::from_slice(&kept)
    }

    /// True while the scenario's fault `windows` are active.
    pub(super) fn fault(&self, windows: impl Fn(&heli_scenario::Faults) -> &Vec<[f64; 2]>) -> bool {
        heli_scenario::Faults::active(windows(&self.scenario.faults), self.now_us as f64 * 1e-6)
    }

    pub(super) fn dispatch(&mut self, kind: Kind) {
        let now = self.now_us;
        match kind {
            Kind::Physics => {
                self.physics_step();
                if self.hil.is_some() {
                    self.measure_hil_truth();
                }
                self.schedule(now + PHYSICS_STEP_US, Kind::Physics);
            }
            Kind::ImuSample => {
                let s = self.heli.state;
                let f = self.heli.outputs.specific_force_body_mps2;
                let rate_rps =
                    self.wrong_vector(heli_scenario::faults::Device::Imu, s.rate_body_rps);
                let rotor = RotorPhase {
                    azimuth_rad: self.rotor_azimuth_rad,
                    speed_ratio: s.rotor_rps / self.heli.airframe.omega_nom_rps,
                };
                let bytes = self.imu.packet(
                    now as f64 * 1e-6,
                    &rate_rps,
                    &f,
                    rotor,
                    self.env.atmosphere.temperature_c,
                );
                // A stuck IMU repeats its last packet, byte for byte.
                let bytes = match (self.fault(|f| &f.imu_stuck), self.last_imu_bytes) {
                    (true, Some(last)) => last,
                    _ => bytes,
                };
                self.last_imu_bytes = Some(bytes);
                // A silent IMU sends nothing (and draws no random drop).
                if self.fault(|f| &f.imu_silent)
                    || self.drop_noise.uniform() < self.scenario.faults.imu_drop_rate
                {
                    self.metrics.imu_dropped += 1;
                } else {
                    self.send_to_computer(Port::Imu, bytes, now);
                }
                self.schedule(now + IMU_PERIOD_US, Kind::ImuSample);
            }
            Kind::UplinkSample => {
                self.move_hands();
                self.uplink_packs();
                let bytes = self.uplink_packet();
                if !self.fault(|f| &f.uplink_silent) {
                    self.send_to_computer(Port::Scb, bytes, now);
                }
                self.schedule(now + UPLINK_PERIOD_US, Kind::UplinkSample);
            }
            Kind::GpsEpoch => {
                let t_s = now as f64 * 1e-6;
                let in_outage = self
                    .scenario
                    .faults
                    .gps_outages
                    .iter()
                    .any(|[start, end]| t_s >= *start && t_s < *end);
                let s = self.heli.state;
                let faults = &self.scenario.faults;
                let glitch = faults
                    .gps_glitches
                    .iter()
                    .filter(|g| t_s >= g.start_s && t_s < g.end_s)
                    .fold(Vector3::zeros(), |acc, g| {
                        acc + Vector3::new(g.north_m, g.east_m, 0.0)
                    });
                self.gps.glitch_ned_m = glitch;
                self.gps.forced_satellites = faults
                    .gps_satellites
                    .iter()
                    .find(|g| t_s >= g.start_s && t_s < g.end_s)
                    .map(|g| g.satellites);
                let gps = heli_scenario::faults::Device::Gps;
                let pos_ned_m = Vector3::new(
                    self.wrong_reading(gps, s.pos_ned_m.x),
                    self.wrong_reading(gps, s.pos_ned_m.y),
                    s.pos_ned_m.z,
                );
                let bytes = self.gps.packet(now, &pos_ned_m, &s.vel_ned_mps());
                // The packet's last byte arrives `latency` after the epoch.
                let tx = transmit_time_us(bytes.as_slice().len(), heli_proto::gps::BAUD);
                let latency_us = (self.gps.errors.latency_s * 1e6) as u64;
                if in_outage {
                    self.metrics.gps_lost += 1;
                } else {
                    self.send_to_computer(Port::Gps, bytes, now + latency_us.saturating_sub(tx));
                }
                self.schedule(now + GPS_PERIOD_US, Kind::GpsEpoch);
            }
            Kind::BaroTransmit => {
                let alt_m = -self.heli.state.pos_ned_m.z + FIELD_ORIGIN.alt_m;
                let p0 = self.env.atmosphere.ground_pressure_mbar;
                let p = pressure_at_altitude_mbar(alt_m, p0);
                let mbar_per_m = p - pressure_at_altitude_mbar(alt_m + 1.0, p0);
                let seen_alt_m = alt_m - self.baro_ground_effect_mbar() / mbar_per_m;
                let seen_alt_m =
                    self.wrong_reading(heli_scenario::faults::Device::Baro, seen_alt_m);
                if let Some(bytes) = self.baro.transmit(now, seen_alt_m, p0)
                    && !self.fault(|f| &f.baro_silent)
                {
                    self.send_to_computer(Port::Baro, bytes, now);
                }
                self.reschedule_baro_device();
            }
            Kind::CompassRead => {
                let adc = self.compass.read(&self.heli.state.att);
                let silent = self.fault(|f| &f.compass_silent);
                let adc = self.faulted_compass(adc);
                match (self.hil.as_mut(), adc) {
                    _ if silent => {}
                    (_, None) => {}
                    (Some(hil), Some(adc)) => {
                        for (channel, counts) in (0u8..).zip(adc.counts) {
                            hil.outbox.push((now, HilOut::Adc { channel, counts }));
                        }
                    }
                    (None, Some(adc)) => self.deliver(DeviceInput::Compass(adc)),
                }
                self.schedule(now + COMPASS_PERIOD_US, Kind::CompassRead);
            }
            Kind::BatteryRead => {
                self.read_power();
                self.schedule(now + BATTERY_PERIOD_US, Kind::BatteryRead);
            }
            Kind::ToDevice(port, bytes) => self.reach_device(port, bytes),
            Kind::ToComputer(port, bytes) => match self.hil.as_mut() {
                Some(hil) => hil.outbox.push((now, HilOut::Bytes(port, bytes))),
                None => self.deliver(DeviceInput::Bytes {
                    port,
                    bytes: bytes.as_slice(),
                }),
            },
            Kind::Tick => {
                // Only the latest scheduled deadline is live; earlier ones were superseded.
                if self.tick_at == Some(now) {
                    self.tick_at = None;
                    self.deliver(DeviceInput::Tick);
                }
            }
        }
    }

    /// The servo board's uplink packet now: the pilot's command as the receiver reports it,
    /// and the rotor speed.
    pub(super) fn uplink_packet(&mut self) -> Bytes {
        let rpm = self.heli.state.rotor_rps * 30.0 / std::f64::consts::PI;
        let rpm = self.wrong_reading(heli_scenario::faults::Device::Uplink, rpm);
        let pilot = self.receiver();
        self.scb.uplink(&pilot, rpm)
    }

    /// A battery reading: the lowest is kept; hardware in the loop gets it on its ADC.
    pub(super) fn read_battery(&mut self, battery: BatteryAdc) {
        let now = self.now_us;
        self.metrics.battery_min_v = self.metrics.battery_min_v.min(battery.volts());
        match self.hil.as_mut() {
            Some(hil) => hil.outbox.push((
                now,
                HilOut::Adc {
                    channel: HIL_BATTERY_CHANNEL,
                    counts: battery.counts,
                },
            )),
            // The flight software reads it once a second, as the vehicle's battery server.
            None => self.deliver(DeviceInput::Battery(battery)),
        }
    }

    /// Bytes from the flight computer reach a device.
    pub(super) fn reach_device(&mut self, port: Port, bytes: Bytes) {
        let now = self.now_us;
        match port {
            Port::Scb => {
                self.scb.receive(bytes.as_slice(), now);
                if self.scb.take_check() {
                    // The board answers the computer's start-up check with an uplink now.
                    let bytes = self.uplink_packet();
                    self.send_to_computer(Port::Scb, bytes, now);
                }
            }
            // A dead altimeter hears nothing either.
            Port::Baro if self.fault(|f| &f.baro_silent) => {}
            Port::Baro => {
                self.baro.receive(bytes.as_slice(), now);
                self.reschedule_baro_device();
            }
            Port::Imu | Port::Gps => {}
        }
    }

    pub(super) fn reschedule_baro_device(&mut self) {
        // The device's next transmission is scheduled once; a stale event just finds nothing due.
        if let Some(at) = self.baro.next_at() {
            let at = at.max(self.now_us);
            if !self
                .queue
                .iter()
                .any(|e| matches!(e.0.kind, Kind::BaroTransmit) && e.0.t_us == at)
            {
                self.schedule(at, Kind::BaroTransmit);
            }
        }
    }

    pub(super) fn reschedule_tick(&mut self) {
        if let Some(at) = self.computer.poll_at()
            && self.tick_at != Some(at)
        {
            self.tick_at = Some(at);
            self.schedule(at.max(self.now_us), Kind::Tick);
        }
    }
}
