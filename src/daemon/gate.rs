//! A start gate: a move (or a path's first start) uploaded ahead of the condition it waits for
//! and started only once the gate opens (a cycle's wait met), or never (the gate shut). The worker holds the verified bank
//! while the gate is closed, reading the status block and serving the gateway as usual; anything
//! else (a stop, a command, the PLC changing under it, the link) cancels the move before its
//! start, and the cycle then runs it as any move, after its wait.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use tokio::sync::Notify;

/// Where a gate stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GateState {
    /// Closed: the move waits, uploaded.
    Closed,
    /// Open: start it.
    Open,
    /// Shut: never start it.
    Shut,
}

const CLOSED: u8 = 0;
const OPEN: u8 = 1;
const SHUT: u8 = 2;

/// A start gate; clones share it.
#[derive(Debug, Clone, Default)]
pub struct Gate(Arc<Inner>);

#[derive(Debug, Default)]
struct Inner {
    state: AtomicU8,
    changed: Notify,
}

impl Gate {
    /// A closed gate.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Opens it (once: a shut gate stays shut).
    pub fn open(&self) {
        self.set(OPEN);
    }

    /// Shuts it (once: an open gate stays open).
    pub fn shut(&self) {
        self.set(SHUT);
    }

    fn set(&self, to: u8) {
        let _ = self
            .0
            .state
            .compare_exchange(CLOSED, to, Ordering::SeqCst, Ordering::SeqCst);
        self.0.changed.notify_waiters();
    }

    /// Where it stands.
    #[must_use]
    pub fn state(&self) -> GateState {
        match self.0.state.load(Ordering::SeqCst) {
            CLOSED => GateState::Closed,
            OPEN => GateState::Open,
            _ => GateState::Shut,
        }
    }

    /// Completes when it opens or shuts (at once if it has).
    pub async fn decided(&self) {
        loop {
            let changed = self.0.changed.notified();
            if self.state() != GateState::Closed {
                return;
            }
            changed.await;
        }
    }
}

impl PartialEq for Gate {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gate_is_decided_once() {
        let g = Gate::new();
        assert_eq!(g.state(), GateState::Closed);
        g.open();
        g.shut();
        assert_eq!(g.state(), GateState::Open);
        let h = Gate::new();
        h.shut();
        h.open();
        assert_eq!(h.state(), GateState::Shut);
        assert_ne!(g, h);
        assert_eq!(g, g.clone());
    }

    #[tokio::test]
    async fn decided_completes_when_it_opens() {
        let g = Gate::new();
        let waiter = tokio::spawn({
            let g = g.clone();
            async move { g.decided().await }
        });
        tokio::task::yield_now().await;
        g.open();
        waiter.await.unwrap();
    }
}
