//! A cycle's move prepared ahead (or a path's first start, the path's other starts queued
//! behind it): its bank uploaded and verified, then held behind a start gate until the cycle
//! reaches its step ([`crate::daemon::gate`]). While held, the status block is
//! read at the busy pace and the gateway served ([`Dispatcher::next`]); anything else (a stop, a command, the PLC
//! changing under it, the link, the gate shut) cancels it before its start.

use std::time::Duration;

use super::Worker;
use super::dispatch::PREPARED_CANCELLED;
use crate::plc::exchange::ContractError;
use crate::wire::{EndReason, MoveId, Stage};

/// How often the status block is read during a prepared move's upload behind a running move,
/// when a status read takes `exchange`: five exchanges of the upload to one read (at least
/// `poll`, the busy pace, apart).
pub(super) fn prepared_watch(exchange: Duration, poll: Duration) -> Duration {
    (exchange * 6).max(poll)
}

impl Worker {
    /// Ends prepared move `id` before its start (cancelled, `why`; the cycle runs it afresh
    /// after its wait); a link failure (`link`) goes on up.
    pub(super) fn unprepared(
        &mut self,
        id: MoveId,
        why: &str,
        link: Option<ContractError>,
    ) -> Result<(), ContractError> {
        self.dispatch.machine.upload_ended();
        self.publish_phase();
        tracing::info!(robot = %self.robot.name, id, "prepared move cancelled: {why}");
        self.cancel_prepared(id, why);
        self.cancel_queue("cancelled: the move before it did not start");
        link.map_or(Ok(()), Err)
    }

    /// Ends prepared move `id` cancelled before its start (`why`), its end reason said before
    /// its final stage is.
    fn cancel_prepared(&mut self, id: MoveId, why: &str) {
        self.mark_end(id, EndReason::CancelledBeforeStart);
        let why = format!("{PREPARED_CANCELLED}: {why}");
        self.finish(id, Stage::Cancelled, Some(why), None);
    }
}
