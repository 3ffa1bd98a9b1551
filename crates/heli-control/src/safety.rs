//! The automated safety checks of thesis §4.3: the conditions the ground operator used to
//! verify by eye before any control augmentation system was flown, written as named truth
//! values and combined with AND, OR and NOT into two verdicts, "safe for augmented flight"
//! and "safe for automatic flight".
//!
//! One rule, two judges. The ground display evaluates it on telemetry and shows the failing
//! conditions by name; the flight core evaluates the same rule on what it observes itself and
//! refuses to enter a mode the rule does not allow. A judge that does not observe a condition
//! (the flight core does not hear the ground link) passes it as *not judged here*, and says
//! so: a fact nobody can see is never silently taken as true by the ground, which observes
//! every condition.
//!
//! Pure and allocation-free: facts in, a verdict out.

use core::fmt;

/// One named truth value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Condition {
    /// The bias calibration is done and the estimate runs.
    Calibrated,
    /// The IMU is updating at its rate.
    Imu,
    /// The servo board's pilot uplink is updating at its rate.
    Uplink,
    /// The GPS is updating at its rate.
    Gps,
    /// The GPS receives from at least five satellites (thesis §2.4).
    Satellites,
    /// The altimeter is updating at its rate.
    Altimeter,
    /// The compass is updating at its rate.
    Compass,
    /// Every battery read has more than its warning level left (a third of its life, the
    /// thesis's red meter, §2.4).
    Battery,
    /// The ground link is fresh: the vehicle's heartbeat heard recently.
    Link,
    /// The pilot's emergency bypass switch is on (the board gives the servos to the pilot).
    Bypass,
}

impl Condition {
    /// Every condition, in the order the display lists them.
    pub const ALL: [Condition; 10] = [
        Condition::Calibrated,
        Condition::Imu,
        Condition::Uplink,
        Condition::Gps,
        Condition::Satellites,
        Condition::Altimeter,
        Condition::Compass,
        Condition::Battery,
        Condition::Link,
        Condition::Bypass,
    ];

    /// Short name, as written in rules and on the display.
    pub const fn name(self) -> &'static str {
        match self {
            Condition::Calibrated => "calibrated",
            Condition::Imu => "imu",
            Condition::Uplink => "uplink",
            Condition::Gps => "gps",
            Condition::Satellites => "satellites",
            Condition::Altimeter => "altimeter",
            Condition::Compass => "compass",
            Condition::Battery => "battery",
            Condition::Link => "link",
            Condition::Bypass => "bypass",
        }
    }

    /// What the condition means, for the display and the vehicle's refusals.
    pub const fn meaning(self) -> &'static str {
        match self {
            Condition::Calibrated => "calibration done",
            Condition::Imu => "IMU updating at 100 Hz",
            Condition::Uplink => "servo board uplink updating at 50 Hz",
            Condition::Gps => "GPS updating at 1 Hz",
            Condition::Satellites => "at least 5 satellites",
            Condition::Altimeter => "altimeter updating",
            Condition::Compass => "compass updating",
            Condition::Battery => "every battery above a third of its life",
            Condition::Link => "ground link fresh",
            Condition::Bypass => "emergency bypass switch on",
        }
    }

    /// What is wrong when the condition is false where a rule wants it true.
    pub const fn missing(self) -> &'static str {
        match self {
            Condition::Calibrated => "still calibrating",
            Condition::Imu => "IMU not updating",
            Condition::Uplink => "servo board uplink not updating",
            Condition::Gps => "GPS not updating",
            Condition::Satellites => "fewer than 5 satellites",
            Condition::Altimeter => "altimeter not updating",
            Condition::Compass => "compass not updating",
            Condition::Battery => "a battery down to a third of its life",
            Condition::Link => "ground link not fresh",
            Condition::Bypass => "emergency bypass switch off",
        }
    }

    const fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

/// A rule: conditions combined with AND, OR and NOT.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// The condition holds.
    Is(Condition),
    /// The condition does not hold.
    Not(Condition),
    /// Every part holds.
    All(&'static [Rule]),
    /// At least one part holds.
    Any(&'static [Rule]),
}

/// Safe for augmented flight: the pilot flies through an augmentation system, which needs the
/// estimate, the sticks, a heading reference (the compass, or the GPS's velocity) and the
/// satellites the thesis asks for, with the bypass switch off.
pub const AUGMENTED: Rule = Rule::All(&[
    Rule::Is(Condition::Calibrated),
    Rule::Is(Condition::Imu),
    Rule::Is(Condition::Uplink),
    Rule::Is(Condition::Satellites),
    Rule::Is(Condition::Battery),
    Rule::Any(&[Rule::Is(Condition::Compass), Rule::Is(Condition::Gps)]),
    Rule::Not(Condition::Bypass),
]);

/// Safe for automatic flight: everything augmented flight needs, the GPS updating (the
/// position hold flies on it) and a ground that is watching.
pub const AUTOMATIC: Rule = Rule::All(&[
    AUGMENTED,
    Rule::Is(Condition::Gps),
    Rule::Is(Condition::Link),
]);

/// What a judge knows: each condition true, false, or not observed by this judge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Facts {
    known: u16,
    true_: u16,
}

impl Facts {
    /// No fact known.
    pub const fn none() -> Self {
        Self { known: 0, true_: 0 }
    }

    /// These facts with `condition` set to `value`.
    pub const fn with(mut self, condition: Condition, value: bool) -> Self {
        self.known |= condition.bit();
        if value {
            self.true_ |= condition.bit();
        } else {
            self.true_ &= !condition.bit();
        }
        self
    }

    /// The fact of `condition`, if this judge observes it.
    pub const fn get(self, condition: Condition) -> Option<bool> {
        if self.known & condition.bit() == 0 {
            None
        } else {
            Some(self.true_ & condition.bit() != 0)
        }
    }
}

/// A set of conditions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Conditions(u16);

impl Conditions {
    /// The empty set.
    pub const EMPTY: Conditions = Conditions(0);

    /// Whether `c` is in the set.
    pub const fn contains(self, c: Condition) -> bool {
        self.0 & c.bit() != 0
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The conditions in either set.
    pub const fn union(self, other: Conditions) -> Conditions {
        Conditions(self.0 | other.0)
    }

    /// Whether every condition of `other` is in this set.
    pub const fn contains_all(self, other: Conditions) -> bool {
        self.0 & other.0 == other.0
    }

    const fn of(c: Condition) -> Conditions {
        Conditions(c.bit())
    }

    /// The members, in [`Condition::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Condition> {
        Condition::ALL
            .into_iter()
            .filter(move |c| self.contains(*c))
    }
}

/// A rule's verdict on some facts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Verdict {
    /// The rule allows it.
    pub allowed: bool,
    /// Conditions that are false where the rule wants them true (one of them, for an OR:
    /// all its parts are listed).
    pub wanted_true: Conditions,
    /// Conditions that are true where the rule wants them false.
    pub wanted_false: Conditions,
    /// Conditions this judge does not observe, passed as not judged here.
    pub not_judged: Conditions,
}

impl Rule {
    /// The rule's verdict on `facts`.
    pub fn judge(self, facts: Facts) -> Verdict {
        match self {
            Rule::Is(c) | Rule::Not(c) => {
                let want = matches!(self, Rule::Is(_));
                match facts.get(c) {
                    None => Verdict {
                        allowed: true,
                        not_judged: Conditions::of(c),
                        ..Verdict::default()
                    },
                    Some(v) if v == want => Verdict {
                        allowed: true,
                        ..Verdict::default()
                    },
                    Some(_) if want => Verdict {
                        wanted_true: Conditions::of(c),
                        ..Verdict::default()
                    },
                    Some(_) => Verdict {
                        wanted_false: Conditions::of(c),
                        ..Verdict::default()
                    },
                }
            }
            Rule::All(parts) => parts.iter().fold(
                Verdict {
                    allowed: true,
                    ..Verdict::default()
                },
                |acc, part| {
                    let v = part.judge(facts);
                    Verdict {
                        allowed: acc.allowed && v.allowed,
                        wanted_true: acc.wanted_true.union(v.wanted_true),
                        wanted_false: acc.wanted_false.union(v.wanted_false),
                        not_judged: acc.not_judged.union(v.not_judged),
                    }
                },
            ),
            Rule::Any(parts) => {
                let verdicts = parts.iter().map(|p| p.judge(facts));
                if let Some(ok) = verdicts.clone().find(|v| v.allowed) {
                    ok
                } else {
                    verdicts.fold(Verdict::default(), |acc, v| Verdict {
                        allowed: false,
                        wanted_true: acc.wanted_true.union(v.wanted_true),
                        wanted_false: acc.wanted_false.union(v.wanted_false),
                        not_judged: acc.not_judged.union(v.not_judged),
                    })
                }
            }
        }
    }
}

impl fmt::Display for Rule {
    /// The rule as written: `calibrated AND imu AND (compass OR gps) AND NOT bypass`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn parts(f: &mut fmt::Formatter<'_>, parts: &[Rule], op: &str) -> fmt::Result {
            for (i, p) in parts.iter().enumerate() {
                if i > 0 {
                    write!(f, " {op} ")?;
                }
                match p {
                    Rule::All(_) if op == "AND" => write!(f, "{p}")?,
                    Rule::All(_) | Rule::Any(_) => write!(f, "({p})")?,
                    _ => write!(f, "{p}")?,
                }
            }
            Ok(())
        }
        match self {
            Rule::Is(c) => write!(f, "{}", c.name()),
            Rule::Not(c) => write!(f, "NOT {}", c.name()),
            Rule::All(p) => parts(f, p, "AND"),
            Rule::Any(p) => parts(f, p, "OR"),
        }
    }
}

impl fmt::Display for Verdict {
    /// `allowed`, or what fails: `still calibrating, fewer than 5 satellites, emergency
    /// bypass switch on`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.allowed {
            return write!(f, "allowed");
        }
        let mut first = true;
        for c in self.wanted_true.iter() {
            write!(f, "{}{}", if first { "" } else { ", " }, c.missing())?;
            first = false;
        }
        for c in self.wanted_false.iter() {
            write!(f, "{}{}", if first { "" } else { ", " }, c.meaning())?;
            first = false;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all_good() -> Facts {
        Condition::ALL
            .into_iter()
            .fold(Facts::none(), |f, c| f.with(c, c != Condition::Bypass))
    }

    #[test]
    fn every_condition_good_allows_both_and_each_failure_is_named() {
        assert!(AUGMENTED.judge(all_good()).allowed);
        assert!(AUTOMATIC.judge(all_good()).allowed);
        let v = AUTOMATIC.judge(all_good().with(Condition::Calibrated, false));
        assert!(!v.allowed);
        assert!(v.wanted_true.contains(Condition::Calibrated));
        assert_eq!(v.to_string(), "still calibrating");
        // NOT: the bypass switch on refuses both.
        let v = AUGMENTED.judge(all_good().with(Condition::Bypass, true));
        assert!(!v.allowed && v.wanted_false.contains(Condition::Bypass));
        assert_eq!(v.to_string(), "emergency bypass switch on");
    }

    #[test]
    fn or_needs_one_heading_source_and_names_both_when_neither() {
        let no_compass = all_good().with(Condition::Compass, false);
        assert!(AUGMENTED.judge(no_compass).allowed);
        // Without the GPS, augmented flight keeps its heading on the compass; automatic
        // flight needs the GPS anyway.
        let no_gps = all_good().with(Condition::Gps, false);
        assert!(AUGMENTED.judge(no_gps).allowed);
        assert!(!AUTOMATIC.judge(no_gps).allowed);
        let neither = no_compass.with(Condition::Gps, false);
        let v = AUGMENTED.judge(neither);
        assert!(!v.allowed);
        assert!(
            v.wanted_true.contains(Condition::Compass) && v.wanted_true.contains(Condition::Gps)
        );
    }

    #[test]
    fn a_condition_not_observed_passes_as_not_judged_and_is_reported() {
        let facts = all_good();
        let onboard = Facts {
            known: facts.known & !Condition::Link.bit() & !Condition::Battery.bit(),
            ..facts
        };
        let v = AUTOMATIC.judge(onboard);
        assert!(v.allowed);
        assert!(
            v.not_judged.contains(Condition::Link) && v.not_judged.contains(Condition::Battery)
        );
        assert!(!v.not_judged.contains(Condition::Imu));
    }

    #[test]
    fn the_rules_read_as_written() {
        assert_eq!(
            AUGMENTED.to_string(),
            "calibrated AND imu AND uplink AND satellites AND battery AND (compass OR gps) AND NOT bypass"
        );
        assert!(
            AUTOMATIC
                .to_string()
                .ends_with("NOT bypass AND gps AND link")
        );
    }

    #[test]
    fn facts_set_and_reset() {
        let f = Facts::none()
            .with(Condition::Imu, true)
            .with(Condition::Imu, false);
        assert_eq!(f.get(Condition::Imu), Some(false));
        assert_eq!(f.get(Condition::Gps), None);
    }
}
