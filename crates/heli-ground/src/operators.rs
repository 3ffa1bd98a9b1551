//! Several operators, one vehicle: every browser on the ground station sees the same state,
//! and only the one holding the *control token* may command; the others watch. The token is
//! taken when free, given back by its holder or by closing the page, and can be taken over
//! from a holder that has closed its page.
//!
//! Every request from a page carries a sequence number that must rise: a request sent again
//! (a replayed WebSocket message) is refused, visibly, and changes nothing.

use std::collections::BTreeMap;

/// An operator's page, numbered by the station.
pub type ClientId = u64;

/// Why an operator's request was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refused {
    /// The page is not known (it never said hello, or has left).
    UnknownClient,
    /// The request's sequence number is not above the last one: a replay.
    Replayed {
        /// The number received.
        seq: u64,
        /// The last number accepted.
        last: u64,
    },
    /// The page was opened with the observer's key: it watches, it never commands.
    Observer,
    /// Another operator holds the control token.
    NotInControl {
        /// Who holds it.
        holder: Option<ClientId>,
    },
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refused::UnknownClient => write!(f, "this page is not connected to the station"),
            Refused::Observer => write!(
                f,
                "this page is an observer's (opened with the observer's key): it watches; open the operator's address to command"
            ),
            Refused::Replayed { seq, last } => write!(
                f,
                "replayed request refused (sequence {seq}, the last accepted was {last}): nothing done"
            ),
            Refused::NotInControl { holder: Some(h) } => write!(
                f,
                "operator {h} is in control: take control to command (this page watches)"
            ),
            Refused::NotInControl { holder: None } => {
                write!(f, "nobody is in control: take control to command")
            }
        }
    }
}

/// The operators' pages and the token.
#[derive(Clone, Debug, Default)]
pub struct Operators {
    next_id: ClientId,
    /// Each page's last accepted sequence number.
    pages: BTreeMap<ClientId, u64>,
    holder: Option<ClientId>,
    /// The pages opened with the observer's key.
    observers: std::collections::BTreeSet<ClientId>,
}

impl Operators {
    /// A new page joins; returns its id.
    pub fn join(&mut self) -> ClientId {
        self.next_id = self.next_id.saturating_add(1);
        self.pages.insert(self.next_id, 0);
        self.next_id
    }

    /// A page opened with the observer's key joins: it may watch, never take the token.
    pub fn join_observer(&mut self) -> ClientId {
        let id = self.join();
        self.observers.insert(id);
        id
    }

    /// A page leaves; the token it held is free again.
    pub fn leave(&mut self, id: ClientId) {
        self.pages.remove(&id);
        self.observers.remove(&id);
        if self.holder == Some(id) {
            self.holder = None;
        }
    }

    /// How many pages are open.
    pub fn count(&self) -> usize {
        self.pages.len()
    }

    /// Who holds the token.
    pub fn holder(&self) -> Option<ClientId> {
        self.holder
    }

    /// Checks a request's sequence number and takes it as the page's last.
    pub fn accept(&mut self, id: ClientId, seq: u64) -> Result<(), Refused> {
        let last = self.pages.get_mut(&id).ok_or(Refused::UnknownClient)?;
        if seq <= *last {
            return Err(Refused::Replayed { seq, last: *last });
        }
        *last = seq;
        Ok(())
    }

    /// Whether `id` may command.
    pub fn may_command(&self, id: ClientId) -> Result<(), Refused> {
        if self.holder == Some(id) {
            Ok(())
        } else {
            Err(Refused::NotInControl {
                holder: self.holder,
            })
        }
    }

    /// `id` takes the token, if it is free (or its own).
    pub fn take(&mut self, id: ClientId) -> Result<(), Refused> {
        if !self.pages.contains_key(&id) {
            return Err(Refused::UnknownClient);
        }
        if self.observers.contains(&id) {
            return Err(Refused::Observer);
        }
        match self.holder {
            Some(h) if h != id => Err(Refused::NotInControl { holder: Some(h) }),
            _ => {
                self.holder = Some(id);
                Ok(())
            }
        }
    }

    /// `id` gives the token back (nothing if it does not hold it).
    pub fn release(&mut self, id: ClientId) {
        if self.holder == Some(id) {
            self.holder = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_operator_commands_and_the_others_watch() {
        let mut ops = Operators::default();
        let a = ops.join();
        let b = ops.join();
        assert!(ops.may_command(a).is_err());
        ops.take(a).unwrap();
        assert!(ops.may_command(a).is_ok());
        assert_eq!(
            ops.may_command(b),
            Err(Refused::NotInControl { holder: Some(a) })
        );
        assert!(ops.take(b).is_err(), "the token is not snatched");
        // Closing the page frees it.
        ops.leave(a);
        ops.take(b).unwrap();
        assert_eq!(ops.holder(), Some(b));
        ops.release(b);
        assert_eq!(ops.holder(), None);
    }

    #[test]
    fn a_replayed_request_is_refused() {
        let mut ops = Operators::default();
        let a = ops.join();
        ops.accept(a, 1).unwrap();
        ops.accept(a, 2).unwrap();
        assert_eq!(ops.accept(a, 2), Err(Refused::Replayed { seq: 2, last: 2 }));
        assert_eq!(ops.accept(a, 1), Err(Refused::Replayed { seq: 1, last: 2 }));
        assert_eq!(ops.accept(99, 5), Err(Refused::UnknownClient));
    }
}
