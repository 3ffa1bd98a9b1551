//! The simulated batteries and the hot-swap: the flight pack on the battery ADC channel,
//! the receiver and servo packs in the servo board's uplink, the hot-swap's digital input;
//! and what the flight software's gauges are judged against.

use super::*;
use crate::devices::battery::BatteryDevice;
use heli_fsw::core::power::Battery;
use heli_power::PackType;
use heli_scenario::faults::PackName;

/// The gauge's time left is judged once it has had this long (s) ...
const JUDGE_AFTER_S: f64 = 120.0;
/// ... and while the truth has at least this long left (s): near empty a few seconds of
/// error is a large fraction of nothing.
const JUDGE_ABOVE_S: f64 = 300.0;

/// The three packs and the hot-swap.
#[derive(Clone, Debug)]
pub(super) struct SimPower {
    pub(super) flight: BatteryDevice,
    pub(super) receiver: BatteryDevice,
    pub(super) servo: BatteryDevice,
    /// The hot-swap's line as last sent to the computer.
    line_sent: Option<bool>,
}

/// What was measured of the batteries.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PowerMetrics {
    /// Least true charge of the flight pack.
    pub(super) flight_soc_min: Option<f64>,
    /// Largest error of the gauge's time left against the truth (%).
    pub(super) time_left_err_max_pct: Option<f64>,
    /// The last such error (%).
    pub(super) time_left_err_end_pct: Option<f64>,
}

impl SimPower {
    pub(super) fn new(s: &Scenario) -> Self {
        Self {
            flight: BatteryDevice::of_scenario(&s.battery, PackType::FLIGHT),
            receiver: BatteryDevice::of_scenario(&s.power.receiver, PackType::RECEIVER),
            servo: BatteryDevice::of_scenario(&s.power.servo, PackType::SERVO),
            line_sent: None,
        }
    }
}

impl Simulation {
    /// The current drawn from a pack at `t_s`: its load, and any drain no one planned; the
    /// flight pack carries nothing while the ground battery powers the avionics.
    pub(super) fn pack_current_a(&self, pack: PackName, t_s: f64) -> f64 {
        let s = &self.scenario;
        let load = match pack {
            PackName::Flight if t_s < s.power.ground_until_s => return 0.0,
            PackName::Flight => s.battery.load_a,
            PackName::Receiver => s.power.receiver.load_a,
            PackName::Servo => s.power.servo.load_a,
        };
        let extra: f64 = s
            .faults
            .battery_drains
            .iter()
            .filter(|d| d.battery == pack && t_s >= d.start_s && t_s < d.end_s)
            .map(|d| d.extra_a)
            .sum();
        load + extra
    }

    /// Every pack drawn down to now.
    pub(super) fn advance_packs(&mut self) {
        let t_s = self.now_us as f64 * 1e-6;
        let (f, r, s) = (
            self.pack_current_a(PackName::Flight, t_s),
            self.pack_current_a(PackName::Receiver, t_s),
            self.pack_current_a(PackName::Servo, t_s),
        );
        self.power.flight.advance(t_s, f);
        self.power.receiver.advance(t_s, r);
        self.power.servo.advance(t_s, s);
    }

    /// The once-a-second battery read: the hot-swap's line when it changed, then the flight
    /// pack's voltage (the bus's: the ground battery's, at its rest, while it powers the
    /// avionics), and the gauge judged against the truth.
    pub(super) fn read_power(&mut self) {
        self.advance_packs();
        let t_s = self.now_us as f64 * 1e-6;
        let high = t_s >= self.scenario.power.ground_until_s;
        if self.power.line_sent != Some(high) {
            self.power.line_sent = Some(high);
            match self.hil.as_mut() {
                Some(hil) => hil.outbox.push((self.now_us, HilOut::PowerLine(high))),
                None => self.deliver(DeviceInput::PowerLine { high }),
            }
        }
        let current = self.pack_current_a(PackName::Flight, t_s);
        let volts = if high {
            self.power.flight.volts(current)
        } else {
            // The ground battery: a big pack, full, lightly loaded.
            PackType::FLIGHT.terminal_v(0.9, self.scenario.battery.load_a, 20.0)
        };
        if let Some(battery) = self.faulted_battery(volts) {
            self.read_battery(battery);
        }
        self.measure_power(t_s, current);
    }

    /// The servo board's packs, as its uplink reports them.
    pub(super) fn uplink_packs(&mut self) {
        self.advance_packs();
        let t_s = self.now_us as f64 * 1e-6;
        let r = self.pack_current_a(PackName::Receiver, t_s);
        let s = self.pack_current_a(PackName::Servo, t_s);
        self.scb.receiver_batt_v = self.power.receiver.volts(r);
        self.scb.servo_batt_v = self.power.servo.volts(s);
    }

    fn measure_power(&mut self, t_s: f64, current_a: f64) {
        let soc = self.power.flight.soc();
        let m = &mut self.metrics.power;
        m.flight_soc_min = Some(m.flight_soc_min.map_or(soc, |x| x.min(soc)));
        let truth_s = self.power.flight.time_left_s(current_a);
        let gauge = self.computer.core().power().state(Battery::Flight);
        let judged_since = self.scenario.power.ground_until_s.max(0.0) + JUDGE_AFTER_S;
        if let Some(g) = gauge
            && t_s >= judged_since
            && truth_s >= JUDGE_ABOVE_S
            && truth_s.is_finite()
        {
            let err = 100.0 * (g.time_left_s - truth_s).abs() / truth_s;
            m.time_left_err_max_pct = Some(m.time_left_err_max_pct.map_or(err, |x| x.max(err)));
            m.time_left_err_end_pct = Some(err);
        }
    }

    /// The batteries at the end of the run.
    pub(super) fn power_summary(&self) -> crate::summary::PowerSummary {
        let t_s = self.now_us as f64 * 1e-6;
        let core = self.computer.core().power();
        let gauge = core.state(Battery::Flight);
        let (flight_s, ground_s) = core.times(self.now_us);
        let m = self.metrics.power;
        crate::summary::PowerSummary {
            flight_soc_end: self.power.flight.soc(),
            flight_soc_min: m.flight_soc_min,
            gauge_soc_end: gauge.map(|g| g.soc),
            gauge_time_left_s: gauge.map(|g| g.time_left_s),
            true_time_left_s: self
                .power
                .flight
                .time_left_s(self.pack_current_a(PackName::Flight, t_s)),
            time_left_err_max_pct: m.time_left_err_max_pct,
            time_left_err_end_pct: m.time_left_err_end_pct,
            receiver_soc_end: self.power.receiver.soc(),
            servo_soc_end: self.power.servo.soc(),
            flight_s,
            ground_s,
        }
    }
}
