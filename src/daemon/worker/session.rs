//! The worker's link session: what lives exactly as long as one opened link to the PLC. Opening
//! the link makes one ([`Session::open`]); a link failure drops it, and with it everything that
//! was true only of that link (how long its exchanges take, when its PLC's mode was read). What
//! outlives the link (the queue, the machine's knowledge of the starts in flight, the reports)
//! is the worker's.

use std::sync::Arc;
use std::time::Duration;

use super::Shared;
use super::pace::LinkPace;
use crate::plc::AnyPlc;
use crate::plc::exchange::{Contract, ContractSettings};

/// One opened link: the contract over it and what was learnt of it.
pub(super) struct Session {
    /// The register contract over the link.
    pub contract: Contract<AnyPlc>,
    /// How long the last status read over it took (the pace of the link).
    pub exchange: Duration,
    /// When the PLC's mode (RUN / PROG) was last read over it.
    pub mode_read: Option<std::time::Instant>,
    /// The pace it showed when a path's parts were last preloaded over it: what judges whether
    /// a later path's parts can be written while the part before each runs
    /// ([`super::dispatch::Lead`]).
    pub pace: Option<LinkPace>,
}

impl Session {
    /// A session over `plc`, just opened: its exchanges counted in the robot's metrics, a stop
    /// asked for aborting an upload between two writes, and every exchange a beat of the worker.
    pub(super) fn open(mut plc: AnyPlc, settings: ContractSettings, shared: &Shared) -> Self {
        plc.set_exchange_counts(shared.metrics.exchange_counts());
        let mut contract = Contract::new(plc, settings);
        contract.set_abort(Arc::clone(&shared.stop_pending));
        contract.set_beat(Arc::clone(&shared.beat));
        Self {
            contract,
            exchange: Duration::ZERO,
            mode_read: None,
            pace: None,
        }
    }
}
