//! The devices as the main control process sees them (thesis ch. 4: every driver has a
//! watchdog): each device's watchdog ([`crate::health`]), the pilot's last uplink, the
//! transmitter loss a silent uplink means, and whether the bootstrap hears a ground.
//!
//! A component: it owns the watchdogs and the pilot's state; the core tells it what was
//! heard, what failed and the time, and it raises every change of a device's state (an F´
//! health event) and the transmitter's loss.

use heli_proto::scb::{Controls, PilotUplink};
use heli_types::Device;

use super::event::CoreEvent;
use super::{Action, Stamped};
use crate::health::{Health, HealthState};

/// The devices' watch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviceWatch {
    /// Every device's watchdog.
    pub(super) health: Health,
    /// The pilot's last uplink packet.
    pub(super) pilot: Option<PilotUplink>,
    /// The servo board's uplink is silent (or its driver failed): transmitter loss.
    pub(super) uplink_lost: bool,
    /// Whether the bootstrap hears a ground, on a vehicle with a link.
    pub(super) ground_link: Option<bool>,
}

impl DeviceWatch {
    /// Arms every device's watchdog at start-up: a device that never speaks is reported
    /// silent after its timeout.
    pub fn start(&mut self, now_us: u64) {
        for device in Device::ALL {
            self.health.monitor_mut(device).arm(now_us);
        }
    }

    /// A device delivered a sample at `now_us`. Its first word after start-up is no news;
    /// any other change of its state is.
    pub fn heard(&mut self, device: Device, now_us: u64, out: &mut Vec<Action>) {
        let before = self.health.state(device);
        if let Some(state) = self.health.monitor_mut(device).sample(now_us) {
            self.changed(device, state, before != HealthState::Waiting, now_us, out);
        }
    }

    /// A driver gave up on its device.
    pub fn failed(&mut self, device: Device, now_us: u64, out: &mut Vec<Action>) {
        if let Some(state) = self.health.monitor_mut(device).fail() {
            self.changed(device, state, true, now_us, out);
        }
    }

    /// Every watchdog judged at `now_us`.
    pub fn check(&mut self, now_us: u64, out: &mut Vec<Action>) {
        for (device, state) in self.health.check(now_us).into_iter().flatten() {
            self.changed(device, state, true, now_us, out);
        }
    }

    /// Raises a device's change of state (when `raise`) and acts on it: the uplink silent
    /// or failed is the transmitter's loss.
    fn changed(
        &mut self,
        device: Device,
        state: HealthState,
        raise: bool,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        if raise {
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::DeviceHealth { device, state },
            )));
        }
        if device == Device::Uplink {
            let lost = matches!(state, HealthState::Silent | HealthState::Failed);
            if lost && !self.uplink_lost {
                out.push(Action::Event(Stamped::new(now_us, CoreEvent::UplinkLost)));
            }
            self.uplink_lost = lost;
        }
    }

    /// The pilot's uplink packet (already heard as a sample of the uplink): the receiver's
    /// loss of the transmitter's signal is raised when it begins.
    pub fn uplink(&mut self, uplink: PilotUplink, now_us: u64, out: &mut Vec<Action>) {
        let was_lost = self.pilot.is_some_and(|p| p.signal_lost());
        if uplink.signal_lost() && !was_lost {
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::PilotSignalLost,
            )));
        }
        self.pilot = Some(uplink);
    }

    /// The bootstrap says whether a ground is heard.
    pub fn ground_link(&mut self, fresh: bool) {
        self.ground_link = Some(fresh);
    }

    /// The pilot's last uplink packet.
    pub fn pilot(&self) -> Option<PilotUplink> {
        self.pilot
    }

    /// The transmitter is lost: the board's line silent, or the receiver without signal.
    pub fn signal_lost(&self) -> bool {
        self.uplink_lost || self.pilot.is_some_and(|p| p.signal_lost())
    }

    /// The uplink silent or failed.
    pub fn uplink_lost(&self) -> bool {
        self.uplink_lost
    }

    /// The pilot's sticks; a silent uplink's last sticks are stale: they count as none.
    pub fn sticks(&self) -> Controls {
        self.pilot
            .filter(|_| !self.uplink_lost)
            .and_then(|p| p.sticks())
            .unwrap_or_default()
    }

    /// The rotor speed the board reports, while its uplink is alive (rpm).
    pub fn rotor_rpm(&self) -> Option<f64> {
        match self.pilot {
            Some(p) if !self.uplink_lost => Some(f64::from(p.rotor_rpm)),
            _ => None,
        }
    }

    /// Whether `device`'s samples arrive on time.
    pub fn ok(&self, device: Device) -> bool {
        self.health.state(device) == HealthState::Ok
    }

    /// Every device's watchdog.
    pub fn health(&self) -> &Health {
        &self.health
    }

    /// Whether the bootstrap hears a ground (`None` on a vehicle without a link).
    pub fn ground_heard(&self) -> Option<bool> {
        self.ground_link
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The events of `out`, in order.
    fn events(out: &[Action]) -> Vec<CoreEvent> {
        out.iter()
            .filter_map(|a| match a {
                Action::Event(e) => Some(e.value),
                _ => None,
            })
            .collect()
    }

    fn uplink(signal_lost: bool) -> PilotUplink {
        let sticks = Controls {
            throttle: 0.8,
            ..Controls::default()
        };
        PilotUplink {
            rotor_rpm: 1600,
            pulses: if signal_lost {
                heli_proto::scb::Pulses::default()
            } else {
                heli_proto::scb::Pulses::from_controls(&sticks)
            },
            receiver_batt_v: 4.9,
            servo_batt_v: 4.9,
            ..PilotUplink::default()
        }
    }

    #[test]
    fn a_first_word_is_no_news_and_every_later_change_is_raised() {
        let mut d = DeviceWatch::default();
        let mut out = Vec::new();
        d.heard(Device::Gps, 500_000, &mut out);
        assert!(events(&out).is_empty(), "the first fix after start-up");
        d.check(2_000_000, &mut out);
        d.heard(Device::Gps, 2_100_000, &mut out);
        // Armed at start-up, a device that never speaks goes silent.
        d.start(2_100_000);
        d.check(3_200_000, &mut out);
        assert_eq!(
            events(&out),
            [
                CoreEvent::DeviceHealth {
                    device: Device::Gps,
                    state: HealthState::Late
                },
                CoreEvent::DeviceHealth {
                    device: Device::Gps,
                    state: HealthState::Ok
                },
                CoreEvent::DeviceHealth {
                    device: Device::Imu,
                    state: HealthState::Silent
                },
                CoreEvent::DeviceHealth {
                    device: Device::Uplink,
                    state: HealthState::Silent
                },
                CoreEvent::UplinkLost,
                CoreEvent::DeviceHealth {
                    device: Device::Compass,
                    state: HealthState::Silent
                },
            ]
        );
        assert!(d.ok(Device::Gps) && !d.ok(Device::Baro));
    }

    #[test]
    fn a_silent_or_failed_uplink_is_the_transmitters_loss_raised_once() {
        let mut d = DeviceWatch::default();
        let mut out = Vec::new();
        d.start(0);
        d.heard(Device::Uplink, 0, &mut out);
        d.uplink(uplink(false), 0, &mut out);
        assert_eq!(d.rotor_rpm(), Some(1600.0));
        d.check(600_000, &mut out);
        assert!(d.uplink_lost() && d.signal_lost());
        assert_eq!(
            d.rotor_rpm(),
            None,
            "a silent uplink's rotor speed is stale"
        );
        assert_eq!(d.sticks(), Controls::default(), "and so are its sticks");
        d.failed(Device::Uplink, 700_000, &mut out);
        let lost = events(&out)
            .iter()
            .filter(|e| **e == CoreEvent::UplinkLost)
            .count();
        assert_eq!(lost, 1);
        d.heard(Device::Uplink, 800_000, &mut out);
        assert!(!d.uplink_lost());
    }

    #[test]
    fn the_receivers_signal_loss_is_raised_when_it_begins() {
        let mut d = DeviceWatch::default();
        let mut out = Vec::new();
        d.uplink(uplink(false), 0, &mut out);
        d.uplink(uplink(true), 20_000, &mut out);
        d.uplink(uplink(true), 40_000, &mut out);
        assert_eq!(events(&out), [CoreEvent::PilotSignalLost]);
        assert!(d.signal_lost() && !d.uplink_lost());
        assert_eq!(d.ground_heard(), None);
        d.ground_link(true);
        assert_eq!(d.ground_heard(), Some(true));
    }
}
