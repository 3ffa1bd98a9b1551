//! Who holds the simulator's transmitter: one page at a time, taken and released
//! explicitly, like the operator's control token on the ground display. Sticks from any
//! other page are refused — two pilots on one receiver would fight over the collective.

use std::sync::{Arc, Mutex, PoisonError};

/// A page of the view, numbered from 1 as it connects.
pub type PageId = u64;

/// The transmitter's holder, shared by every page's connection.
#[derive(Clone, Debug, Default)]
pub struct Holder {
    inner: Arc<Mutex<Inner>>,
}

#[derive(Debug, Default)]
struct Inner {
    pages: PageId,
    holder: Option<PageId>,
}

/// Why a page may not do what it asked with the transmitter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NotHeld {
    /// Another page holds it.
    HeldBy(PageId),
    /// Nobody holds it: the page must take it first.
    Free,
}

impl std::fmt::Display for NotHeld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotHeld::HeldBy(p) => write!(
                f,
                "page {p} holds the transmitter: it must release it before another page flies"
            ),
            NotHeld::Free => f.write_str("take the transmitter first (nobody holds it)"),
        }
    }
}

impl Holder {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A page connects: its number.
    pub fn join(&self) -> PageId {
        let mut i = self.lock();
        i.pages = i.pages.saturating_add(1);
        i.pages
    }

    /// Who holds it now.
    pub fn holder(&self) -> Option<PageId> {
        self.lock().holder
    }

    /// `page` takes it: refused while another page holds it.
    pub fn take(&self, page: PageId) -> Result<(), NotHeld> {
        let mut i = self.lock();
        match i.holder {
            Some(h) if h != page => Err(NotHeld::HeldBy(h)),
            _ => {
                i.holder = Some(page);
                Ok(())
            }
        }
    }

    /// Whether `page` may send sticks (or release): only the holder.
    pub fn check(&self, page: PageId) -> Result<(), NotHeld> {
        match self.lock().holder {
            Some(h) if h == page => Ok(()),
            Some(h) => Err(NotHeld::HeldBy(h)),
            None => Err(NotHeld::Free),
        }
    }

    /// `page` gives it back (refused if it does not hold it).
    pub fn release(&self, page: PageId) -> Result<(), NotHeld> {
        self.check(page)?;
        self.lock().holder = None;
        Ok(())
    }

    /// `page` is gone: if it held the transmitter, nobody does (the receiver loses the
    /// signal, as with a transmitter switched off, until a page takes it). Returns whether it
    /// held it.
    pub fn leave(&self, page: PageId) -> bool {
        let mut i = self.lock();
        if i.holder == Some(page) {
            i.holder = None;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_page_holds_the_transmitter_until_it_releases_it_or_goes() {
        let h = Holder::default();
        let (a, b) = (h.join(), h.join());
        assert_eq!(h.check(a), Err(NotHeld::Free));
        h.take(a).unwrap();
        h.take(a).unwrap();
        assert_eq!(h.take(b), Err(NotHeld::HeldBy(a)));
        assert_eq!(h.check(b), Err(NotHeld::HeldBy(a)));
        assert_eq!(h.release(b), Err(NotHeld::HeldBy(a)));
        assert!(h.check(a).is_ok());
        h.release(a).unwrap();
        assert_eq!(h.holder(), None);
        h.take(b).unwrap();
        assert!(!h.leave(a));
        assert!(h.leave(b));
        assert_eq!(h.holder(), None);
        assert!(NotHeld::HeldBy(3).to_string().contains("page 3 holds"));
    }
}
