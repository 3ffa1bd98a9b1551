//! A spell of failures: how every side says a fault that repeats. The first failure of a
//! spell is said (with its cause), the failures after it are counted, not said, and the
//! first success after them is said with the count — so a port, a socket or a file that
//! keeps failing is one event and its end, never silence and never a flood.

/// A run of failures of one thing, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Spell {
    /// Failures since the last success.
    failures: u64,
}

impl Spell {
    /// One more failure; true when it begins a spell (the one to say).
    pub fn failed(&mut self) -> bool {
        self.failures = self.failures.saturating_add(1);
        self.failures == 1
    }

    /// A success; the number of failures of the spell it ends, if it ends one (to say).
    pub fn worked(&mut self) -> Option<u64> {
        let failures = std::mem::take(&mut self.failures);
        (failures > 0).then_some(failures)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spell_is_said_when_it_begins_and_counted_when_it_ends() {
        let mut spell = Spell::default();
        assert_eq!(spell.worked(), None, "no spell, nothing to say");
        assert!(spell.failed(), "the first failure begins one");
        assert!(!spell.failed(), "the next ones are counted");
        assert!(!spell.failed());
        assert_eq!(spell.worked(), Some(3));
        assert_eq!(spell.worked(), None, "the spell is over");
        assert!(spell.failed(), "a new spell");
    }
}
