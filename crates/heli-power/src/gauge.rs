//! The fuel gauge: a battery's state of charge and time left from its voltage under load,
//! its current where a sensor gives it (otherwise the load it is known to carry), and its
//! temperature (otherwise the day's, as the operator gives it), after the pack type's
//! characterization ([`crate::pack`]).
//!
//! Two estimates of the charge are kept. Counting the charge drawn from a known start
//! (coulomb counting) is smooth but only as good as the capacity and the load assumed; the
//! open-circuit voltage (the terminal voltage plus the drop across the resistance) says
//! where the pack really is, noisily and weakly on the flat of the curve. The gauge follows
//! the count and pulls it toward the voltage's over [`GaugeConfig::correction_s`].
//!
//! The field rule (thesis §4.3, "if the vehicle's flight battery happens to run low for no
//! apparent reason ... the rest of the flight test should be cancelled"): when the voltage's
//! charge falls [`GaugeConfig::drain_margin`] below what the count alone expects for the
//! flight so far, the pack is draining abnormally (a weak or damaged pack, a short, a load
//! that should not be there). Latched for the flight.
//!
//! Sans-I/O: readings with their time in, a state out. Levels only worsen within a flight
//! (a warning is not withdrawn by a reading that bounces back).

use serde::{Deserialize, Serialize};

use crate::pack::PackType;

/// How worried to be about a battery.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// More than the warning level left.
    Good,
    /// At most the warning level left: finish and land (a return-and-land in autonomous
    /// flight).
    Warning,
    /// At most the critical level left: land now.
    Critical,
}

impl Level {
    /// Lower-case name for messages, logs and displays.
    pub const fn name(self) -> &'static str {
        match self {
            Level::Good => "good",
            Level::Warning => "warning",
            Level::Critical => "critical",
        }
    }
}

/// Warning and critical levels, as fractions of the charge left.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Levels {
    /// Warning at or below this (the thesis's meter turned red at a third).
    pub warning: f64,
    /// Critical at or below this.
    pub critical: f64,
}

impl Default for Levels {
    fn default() -> Self {
        Self {
            warning: 1.0 / 3.0,
            critical: 0.15,
        }
    }
}

impl Levels {
    /// The level of a charge fraction.
    pub fn of(&self, soc: f64) -> Level {
        // A charge that is not a number is as bad as none.
        if soc.is_nan() || soc <= self.critical {
            Level::Critical
        } else if soc <= self.warning {
            Level::Warning
        } else {
            Level::Good
        }
    }
}

/// What the gauge knows of its pack and how it weighs its readings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaugeConfig {
    /// The pack type.
    pub pack: PackType,
    /// Charge cycles the pack has had (its capacity fades with them).
    pub cycles: f64,
    /// The current the pack carries when no sensor measures it (A).
    pub nominal_load_a: f64,
    /// The pack's temperature when no sensor measures it (°C): the day's.
    pub temperature_c: f64,
    /// Time constant of the pull toward the voltage's charge (s).
    pub correction_s: f64,
    /// Warning and critical levels.
    pub levels: Levels,
    /// The field rule's margin (charge fraction).
    pub drain_margin: f64,
    /// The field rule waits this long into the flight (s): the first readings settle.
    pub drain_after_s: f64,
}

impl GaugeConfig {
    /// A gauge for `pack` carrying `nominal_load_a`.
    pub fn new(pack: PackType, nominal_load_a: f64) -> Self {
        Self {
            pack,
            cycles: 0.0,
            nominal_load_a,
            temperature_c: crate::pack::REFERENCE_C,
            correction_s: 120.0,
            levels: Levels::default(),
            drain_margin: 0.12,
            drain_after_s: 60.0,
        }
    }

    /// The flight pack (1.8 A for the computer and its sensors).
    pub fn flight() -> Self {
        Self::new(PackType::FLIGHT, 1.8)
    }

    /// The servo board's receiver pack (0.25 A). The uplink reports it in 0.05 V steps,
    /// an eighth of the flat of a four-cell curve: the voltage is trusted more slowly and
    /// the field rule's margin is two steps.
    pub fn receiver() -> Self {
        Self::reported_in_steps(Self::new(PackType::RECEIVER, 0.25))
    }

    /// The servo pack (0.8 A on average for five servos holding a hover), reported as the
    /// receiver pack is.
    pub fn servo() -> Self {
        Self::reported_in_steps(Self::new(PackType::SERVO, 0.8))
    }

    fn reported_in_steps(self) -> Self {
        Self {
            correction_s: 300.0,
            drain_margin: 0.25,
            ..self
        }
    }
}

/// One reading of a battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// When (s, any monotonic origin).
    pub t_s: f64,
    /// Terminal voltage (V).
    pub volts: f64,
    /// Current drawn (A), if a sensor measures it.
    pub current_a: Option<f64>,
    /// Pack temperature (°C), if a sensor measures it.
    pub temp_c: Option<f64>,
}

/// Why a reading was not used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReadingError {
    /// The voltage is not a number, or not above zero.
    Volts(f64),
    /// The current is not a number.
    Current(f64),
    /// The temperature is not a number, or outside −60..100 °C.
    Temperature(f64),
    /// The time is not a number, or earlier than the last reading's.
    Time(f64),
}

impl core::fmt::Display for ReadingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ReadingError::Volts(v) => write!(f, "battery voltage {v} V is not a reading"),
            ReadingError::Current(a) => write!(f, "battery current {a} A is not a reading"),
            ReadingError::Temperature(c) => {
                write!(f, "battery temperature {c} °C is not a reading")
            }
            ReadingError::Time(t) => write!(f, "battery reading at {t} s is out of order"),
        }
    }
}

/// What the gauge says.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaugeState {
    /// The last terminal voltage (V).
    pub volts: f64,
    /// The charge left (fraction of the pack's capacity now).
    pub soc: f64,
    /// Time until empty at the present drain (s): the charge left of the capacity over the
    /// load; for a pack draining abnormally, of the capacity it has shown.
    pub time_left_s: f64,
    /// The level (the worst of this flight).
    pub level: Level,
    /// The field rule: draining faster than the flight so far explains.
    pub draining_abnormally: bool,
    /// The charge the voltage alone says (fraction).
    pub voltage_soc: f64,
    /// The charge the count alone expects (fraction).
    pub expected_soc: f64,
}

/// The fuel gauge of one battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FuelGauge {
    config: GaugeConfig,
    /// Start of the flight's count: (time, charge).
    start: Option<(f64, f64)>,
    last_t_s: f64,
    soc: f64,
    used_ah: f64,
    voltage_soc: f64,
    current_avg_a: f64,
    worst: Level,
    abnormal: bool,
    state: Option<GaugeState>,
}

/// Time constant of the averages of the voltage's charge and of the current (s).
const AVERAGE_S: f64 = 20.0;

impl FuelGauge {
    /// A gauge with no reading yet.
    pub fn new(config: GaugeConfig) -> Self {
        Self {
            config,
            start: None,
            last_t_s: f64::NEG_INFINITY,
            soc: 0.0,
            used_ah: 0.0,
            voltage_soc: 0.0,
            current_avg_a: config.nominal_load_a,
            worst: Level::Good,
            abnormal: false,
            state: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &GaugeConfig {
        &self.config
    }

    /// The last state (`None` before the first reading).
    pub fn state(&self) -> Option<GaugeState> {
        self.state
    }

    /// A new flight (or a pack swapped): the count, the level and the field rule start over
    /// from the next reading.
    pub fn restart(&mut self) {
        *self = Self::new(self.config);
    }

    /// Takes one reading; a reading that is not one is refused (the state is unchanged).
    pub fn update(&mut self, r: Reading) -> Result<GaugeState, ReadingError> {
        if !(r.volts.is_finite() && r.volts > 0.0) {
            return Err(ReadingError::Volts(r.volts));
        }
        if let Some(a) = r.current_a.filter(|a| !a.is_finite()) {
            return Err(ReadingError::Current(a));
        }
        if let Some(c) = r
            .temp_c
            .filter(|c| !(c.is_finite() && (-60.0..=100.0).contains(c)))
        {
            return Err(ReadingError::Temperature(c));
        }
        if !r.t_s.is_finite() || r.t_s < self.last_t_s {
            return Err(ReadingError::Time(r.t_s));
        }
        let cfg = self.config;
        let temp_c = r.temp_c.unwrap_or(cfg.temperature_c);
        let current = r.current_a.unwrap_or(cfg.nominal_load_a);
        let capacity = cfg.pack.capacity_at(temp_c, cfg.cycles);
        let ocv = r.volts + current * cfg.pack.resistance_ohm(temp_c);
        let soc_v = cfg.pack.soc_at_open_circuit(ocv);
        let (t0, soc0) = *self.start.get_or_insert((r.t_s, soc_v));
        if self.state.is_none() {
            self.soc = soc_v;
            self.voltage_soc = soc_v;
            self.current_avg_a = current;
        } else {
            let dt = r.t_s - self.last_t_s;
            let drawn_ah = current * dt / 3600.0;
            self.used_ah += drawn_ah;
            // Once the pack is known to drain abnormally, its count is no guide: the
            // voltage is followed four times as closely.
            let tau = if self.abnormal {
                cfg.correction_s / 4.0
            } else {
                cfg.correction_s
            };
            let pull = (dt / tau.max(1e-3)).min(1.0);
            self.soc -= drawn_ah / capacity;
            self.soc += pull * (soc_v - self.soc);
            let smooth = (dt / AVERAGE_S).min(1.0);
            self.voltage_soc += smooth * (soc_v - self.voltage_soc);
            self.current_avg_a += smooth * (current - self.current_avg_a);
        }
        self.last_t_s = r.t_s;
        self.soc = self.soc.clamp(0.0, 1.0);
        let expected_soc = (soc0 - self.used_ah / capacity).clamp(0.0, 1.0);
        let settled = r.t_s - t0 >= cfg.drain_after_s;
        self.abnormal |= settled && self.voltage_soc < expected_soc - cfg.drain_margin;
        self.worst = self.worst.max(cfg.levels.of(self.soc));
        // A pack draining abnormally has less capacity than its type says: what it has
        // given for the charge it lost is the better figure. (Blending in the drain the
        // voltage shows for every pack was tried: on the flat of the curve it is noisier
        // than the load is uncertain, docs/power.md.)
        let lost = soc0 - self.voltage_soc;
        let usable_ah = if self.abnormal && lost > 0.05 {
            (self.used_ah / lost).min(capacity)
        } else {
            capacity
        };
        let time_left_s = if self.current_avg_a > 1e-6 {
            self.soc * usable_ah * 3600.0 / self.current_avg_a
        } else {
            f64::INFINITY
        };
        let state = GaugeState {
            volts: r.volts,
            soc: self.soc,
            time_left_s,
            level: self.worst,
            draining_abnormally: self.abnormal,
            voltage_soc: self.voltage_soc,
            expected_soc,
        };
        self.state = Some(state);
        Ok(state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The flight pack drained at `load_a` with `capacity_factor` of its capacity, read
    /// once a second for `seconds`, the gauge believing `believed_c` while the pack is at
    /// `temp_c`.
    fn drain(
        gauge: &mut FuelGauge,
        load_a: f64,
        capacity_factor: f64,
        temp_c: f64,
        seconds: u32,
    ) -> GaugeState {
        let p = PackType::FLIGHT;
        let capacity = p.capacity_at(temp_c, 0.0) * capacity_factor;
        let mut soc = 1.0;
        let mut last = None;
        for s in 0..seconds {
            let volts = p.terminal_v(soc, load_a, temp_c);
            last = Some(
                gauge
                    .update(Reading {
                        t_s: f64::from(s),
                        volts,
                        current_a: None,
                        temp_c: None,
                    })
                    .unwrap(),
            );
            soc -= load_a / 3600.0 / capacity;
        }
        last.unwrap()
    }

    #[test]
    fn a_good_pack_at_its_load_is_tracked_and_raises_nothing_early() {
        let mut g = FuelGauge::new(GaugeConfig::flight());
        let s = drain(&mut g, 1.8, 1.0, 20.0, 600);
        // 10 minutes at 1.8 A of 1.7 A h: 17.6 % drawn.
        assert!((s.soc - 0.824).abs() < 0.05, "{s:?}");
        assert!(!s.draining_abnormally, "{s:?}");
        assert_eq!(s.level, Level::Good);
        // Time left: 82 % of 1.7 A h at 1.8 A is 46 minutes.
        assert!((s.time_left_s / 60.0 - 46.7).abs() < 4.0, "{s:?}");
    }

    #[test]
    fn a_weak_pack_drains_abnormally_and_reaches_its_levels() {
        let mut g = FuelGauge::new(GaugeConfig::flight());
        // A third of its capacity: the voltage falls three times as fast as the count says.
        let s = drain(&mut g, 1.8, 0.33, 20.0, 420);
        assert!(s.draining_abnormally, "{s:?}");
        let s = drain(
            &mut FuelGauge::new(GaugeConfig::flight()),
            1.8,
            0.33,
            20.0,
            900,
        );
        assert_eq!(s.level, Level::Warning, "{s:?}");
        // Its time left is judged from what it gave, not what its type promises: about
        // 2.5 minutes at 20 % of 0.56 A h.
        assert!(s.time_left_s < 300.0, "{s:?}");
        let s = drain(
            &mut FuelGauge::new(GaugeConfig::flight()),
            1.8,
            0.33,
            20.0,
            1080,
        );
        assert_eq!(s.level, Level::Critical, "{s:?}");
    }

    #[test]
    fn a_reading_that_is_not_one_is_refused_and_changes_nothing() {
        let mut g = FuelGauge::new(GaugeConfig::flight());
        let ok = Reading {
            t_s: 10.0,
            volts: 12.6,
            current_a: None,
            temp_c: None,
        };
        let s = g.update(ok).unwrap();
        for bad in [
            Reading {
                volts: f64::NAN,
                ..ok
            },
            Reading { volts: -1.0, ..ok },
            Reading {
                current_a: Some(f64::INFINITY),
                ..ok
            },
            Reading {
                temp_c: Some(400.0),
                ..ok
            },
            Reading { t_s: 9.0, ..ok },
        ] {
            assert!(g.update(bad).is_err(), "{bad:?}");
            assert_eq!(g.state(), Some(s));
        }
        assert!(
            ReadingError::Volts(f64::NAN)
                .to_string()
                .contains("voltage")
        );
    }

    #[test]
    fn the_cold_misread_as_a_warm_day_reads_low() {
        // The gauge told 20 °C while the pack is at 0 °C sees the larger sag as less charge.
        let mut told_warm = FuelGauge::new(GaugeConfig::flight());
        let warm = drain(&mut told_warm, 1.8, 1.0, 0.0, 60);
        let mut told_cold = FuelGauge::new(GaugeConfig {
            temperature_c: 0.0,
            ..GaugeConfig::flight()
        });
        let cold = drain(&mut told_cold, 1.8, 1.0, 0.0, 60);
        assert!(warm.soc < cold.soc - 0.05, "{warm:?} {cold:?}");
        assert!((cold.soc - 0.98).abs() < 0.05, "{cold:?}");
    }

    proptest! {
        #[test]
        fn the_state_is_always_a_fraction_and_time_left_not_negative(
            volts in prop::collection::vec(0.1f64..20.0, 1..50)
        ) {
            let mut g = FuelGauge::new(GaugeConfig::flight());
            for (i, v) in volts.iter().enumerate() {
                let s = g.update(Reading { t_s: i as f64, volts: *v, current_a: None, temp_c: None }).unwrap();
                prop_assert!((0.0..=1.0).contains(&s.soc));
                prop_assert!(s.time_left_s >= 0.0);
            }
        }
    }
}
