//! The link: (re)connecting with backoff, a link that fails, and a PLC program that answers but
//! not as the contract says (wrong magic or version): then the link is kept, nothing moves, and
//! the reason is what every order is refused with.

use std::time::Duration;

use super::session::Session;
use super::{Connector, Worker, describe, now};
use crate::contract::machine::Blocker;
use crate::plc::exchange::ContractError;

/// Reconnection backoff bounds.
const BACKOFF_MIN: Duration = Duration::from_millis(100);
const BACKOFF_MAX: Duration = Duration::from_secs(5);

/// The robot's link: how to open it, the session while it is open, and how long to wait before
/// the next attempt while it is not.
pub(super) struct Connection {
    /// Opens the link (called again after every link failure).
    pub connect: Connector,
    /// The open link and what is known of it; `None` while the link is down.
    pub session: Option<Session>,
    /// The wait before the next attempt to open it.
    pub backoff: Duration,
    /// Whether the link was ever opened (a later opening is a reconnection).
    pub opened_before: bool,
}

impl Connection {
    /// Not opened yet.
    pub(super) fn new(connect: Connector) -> Self {
        Self {
            connect,
            session: None,
            backoff: BACKOFF_MIN,
            opened_before: false,
        }
    }
}

impl Worker {
    /// Opens the link again; while it is down, a move in flight is ended at the instant its
    /// run limit and the link's grace run out ([`Machine::expires_while_down`]), whatever the
    /// backoff or a connection attempt that hangs: by the deadline its report gave.
    ///
    /// [`Machine::expires_while_down`]: crate::contract::machine::Machine::expires_while_down
    pub(super) async fn reconnect(&mut self) {
        self.expire_offline();
        let expiry = self
            .dispatch
            .machine
            .expires_while_down()
            .map(tokio::time::Instant::from_std);
        let attempt = (self.conn.connect)();
        let opened = match expiry {
            Some(at) => tokio::select! {
                opened = attempt => opened,
                () = tokio::time::sleep_until(at) => return,
            },
            None => attempt.await,
        };
        match opened {
            Ok(plc) => self.opened(plc).await,
            Err(e) => self.open_failed(&e),
        }
    }

    /// The link opened: a session over it, and its first status block read.
    async fn opened(&mut self, plc: crate::plc::AnyPlc) {
        self.conn.session = Some(Session::open(plc, self.settings, &self.shared));
        self.conn.backoff = BACKOFF_MIN;
        // The first opening is a connection, not a reconnection.
        let again = std::mem::replace(&mut self.conn.opened_before, true);
        self.out.state(|s| s.link.reconnects += u64::from(again));
        if again {
            self.shared.metrics.reconnected();
        }
        tracing::info!(robot = %self.robot.name, "PLC link opened");
        if let Err(e) = self.poll().await {
            self.link_failed(&e);
        }
    }

    /// An attempt to open the link failed by `e`: said once per change, and the next attempt
    /// after the backoff, which doubles.
    fn open_failed(&mut self, e: &crate::plc::PlcError) {
        let text = describe(e);
        let changed = self.out.state(|s| {
            s.link.connected = false;
            let changed = s.link.error.as_deref() != Some(text.as_str());
            s.link.error = Some(text.clone());
            changed
        });
        // Once per change, not once per retry: the journal keeps the first and the news.
        if changed {
            let hint = crate::plc::open_hint(e);
            tracing::warn!(robot = %self.robot.name, error = %text, hint, "cannot open the PLC link");
        }
        self.publish_refusal();
        // The dispatcher waits this long (never past a move's expiry), answers what came
        // meanwhile and opens the link again.
        self.dispatch.connect_failed(now(), self.conn.backoff);
        self.conn.backoff = (self.conn.backoff * 2).min(BACKOFF_MAX);
    }

    /// Starts in flight past their planned end while the link is down end as unknown.
    fn expire_offline(&mut self) {
        let events = self.dispatch.machine.tick(now());
        self.apply_offline(events);
        self.settle_late();
        self.publish_phase();
    }

    pub(super) fn link_failed(&mut self, e: &ContractError) {
        let text = describe(e);
        // A link that opens and fails at once fails again on every retry: say it once.
        if self.out.get().state.link.error.as_deref() == Some(text.as_str()) {
            tracing::debug!(robot = %self.robot.name, error = %text, "PLC link failed again; reconnecting");
        } else {
            tracing::warn!(robot = %self.robot.name, error = %text, "PLC link failed; reconnecting");
        }
        self.conn.session = None;
        // The moves in flight are kept: after the reconnection the status block says whether the
        // PLC went on with them (same host word) or restarted.
        self.dispatch.machine.link_lost(now());
        self.out.state(|s| {
            s.link.connected = false;
            s.link.error = Some(text);
            // Unknown until the link is back; the rest stays as last read.
            s.heartbeat_age_ms = None;
            s.inputs = None;
        });
        self.out.no_read();
        self.publish_refusal();
        self.publish_phase();
    }

    /// The PLC answered, but not as the contract says (wrong magic or version, a word the
    /// contract does not define): nothing moves until it does.
    pub(super) fn contract_unusable(&mut self, e: &ContractError) {
        let text = describe(e);
        let changed = self.out.state(|s| {
            let changed = s.link.error.as_deref() != Some(text.as_str());
            s.link.connected = false;
            s.link.error = Some(text.clone());
            changed
        });
        if changed {
            tracing::error!(robot = %self.robot.name, error = %text, "the PLC program does not answer as the contract says");
        }
        self.dispatch.machine.link_lost(now());
        self.out.set_refusal(Some(Blocker::LinkDown));
        self.publish_phase();
    }

    pub(super) fn note_error(&self, e: &ContractError) {
        tracing::warn!(robot = %self.robot.name, error = %describe(e), "PLC exchange failed");
        self.out.state(|s| s.link.error = Some(describe(e)));
    }
}
