//! How often a client's exchanges timed out and were tried again: plain counters the owner of a
//! link hands to every client it opens, so the counts run on across reconnections (the daemon's
//! `/metrics` reads them).

use std::sync::atomic::{AtomicU64, Ordering};

/// Lifetime counts of one link's exchange failures; they only ever go up.
#[derive(Debug, Default)]
pub struct ExchangeCounts {
    retries: AtomicU64,
    timeouts: AtomicU64,
}

impl ExchangeCounts {
    /// An exchange is being tried again (after a timeout or a garbled reply).
    pub fn retried(&self) {
        self.retries.fetch_add(1, Ordering::Relaxed);
    }

    /// An attempt got no (complete) reply in time.
    pub fn timed_out(&self) {
        self.timeouts.fetch_add(1, Ordering::Relaxed);
    }

    /// Retries so far.
    #[must_use]
    pub fn retries(&self) -> u64 {
        self.retries.load(Ordering::Relaxed)
    }

    /// Timed-out attempts so far.
    #[must_use]
    pub fn timeouts(&self) -> u64 {
        self.timeouts.load(Ordering::Relaxed)
    }
}
