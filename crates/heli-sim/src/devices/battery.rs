//! A simulated battery pack: the truth a fuel gauge is judged against. It follows the same
//! characterization as the gauge on board ([`heli_power::PackType`]: open-circuit curve,
//! resistance that grows in the cold, capacity that shrinks in the cold and with charge
//! cycles), and a pack of its own may be weaker than its type says (`health`). So, as the
//! thesis found in the field, the voltage is only weakly tied to the time left, and the
//! temperature matters a great deal.

use heli_power::PackType;
use heli_proto::battery::BatteryAdc;

/// One simulated pack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryDevice {
    /// The pack's type.
    pub pack: PackType,
    /// Charge cycles it has had.
    pub cycles: f64,
    /// Its capacity relative to what its type, temperature and cycles say (1: as the type
    /// says; a weak or damaged pack less).
    pub health: f64,
    /// Its temperature (°C).
    pub temperature_c: f64,
    /// Charge left (fraction of its capacity).
    soc: f64,
    /// Time of the last advance (s).
    t_s: f64,
}

impl Default for BatteryDevice {
    /// The flight pack, full, at 15 °C.
    fn default() -> Self {
        Self::new(PackType::FLIGHT, 1.0, 15.0)
    }
}

impl BatteryDevice {
    /// The simulated pack a scenario describes, of type `pack` (its capacity replaced by the
    /// scenario's).
    pub fn of_scenario(battery: &heli_scenario::faults::Battery, pack: PackType) -> Self {
        let mut d = Self::new(
            PackType {
                capacity_ah: battery.capacity_ah,
                ..pack
            },
            battery.charge,
            battery.temperature_c,
        );
        d.cycles = battery.cycles;
        d.health = battery.health;
        d
    }

    /// A new pack of type `pack` charged to `charge` (fraction) at `temperature_c`.
    pub fn new(pack: PackType, charge: f64, temperature_c: f64) -> Self {
        Self {
            pack,
            cycles: 0.0,
            health: 1.0,
            temperature_c,
            soc: charge.clamp(0.0, 1.0),
            t_s: 0.0,
        }
    }

    /// Its true capacity now (A h).
    pub fn capacity_ah(&self) -> f64 {
        self.pack.capacity_at(self.temperature_c, self.cycles) * self.health.clamp(0.01, 2.0)
    }

    /// Charge left (fraction).
    pub fn soc(&self) -> f64 {
        self.soc
    }

    /// Draws `current_a` from the last advance until `t_s`.
    pub fn advance(&mut self, t_s: f64, current_a: f64) {
        if t_s > self.t_s {
            let drawn_ah = current_a.max(0.0) * (t_s - self.t_s) / 3600.0;
            self.soc = (self.soc - drawn_ah / self.capacity_ah()).max(0.0);
            self.t_s = t_s;
        }
    }

    /// Terminal voltage with `current_a` drawn.
    pub fn volts(&self, current_a: f64) -> f64 {
        self.pack
            .terminal_v(self.soc, current_a, self.temperature_c)
            .max(0.0)
    }

    /// The ADC reading of the terminal voltage.
    pub fn read(&self, current_a: f64) -> BatteryAdc {
        BatteryAdc::from_volts(self.volts(current_a))
    }

    /// The true time until empty at `current_a` (s).
    pub fn time_left_s(&self, current_a: f64) -> f64 {
        if current_a > 0.0 {
            self.soc * self.capacity_ah() * 3600.0 / current_a
        } else {
            f64::INFINITY
        }
    }
}
