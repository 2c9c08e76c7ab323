//! A cycle's move prepared ahead: its bank uploaded and verified, then held behind a start gate
//! until the cycle reaches its step ([`crate::daemon::gate`]). While held, the status block is
//! read at the busy pace and the gateway served; anything else (a stop, a command, the PLC
//! changing under it, the link, the gate shut) cancels it before its start.

use std::time::Duration;

use super::dispatch::{Hold, PREPARED_CANCELLED};
use super::{Worker, now};
use crate::contract::machine::{Blocker, Phase};
use crate::daemon::gate::{Gate, GateState};
use crate::plc::exchange::ContractError;
use crate::wire::{EndReason, MoveId, Stage};

/// How often the status block is read during a prepared move's upload behind a running move,
/// when a status read takes `exchange`: five exchanges of the upload to one read (at least
/// `poll`, the busy pace, apart).
pub(super) fn prepared_watch(exchange: Duration, poll: Duration) -> Duration {
    (exchange * 6).max(poll)
}

impl Worker {
    /// One step of holding an uploaded, verified bank until `gate` opens ([`Hold`]): the
    /// status block read at the busy pace (the cycle's wait is decided on it) and the gateway
    /// served meanwhile, else a wait for what comes next. Anything else cancels it: the gate
    /// shut, a stop or a command asked for, the PLC no longer where the upload left it (a
    /// restart, a fault); a link that fails is the error.
    pub(super) async fn hold_step(&mut self, gate: &Gate) -> Result<Hold, ContractError> {
        let runs_ahead = self.dispatch.machine.uploading_behind().is_some();
        let on_gate = Hold::on_gate(gate.state(), runs_ahead);
        if on_gate != Hold::Wait {
            return Ok(on_gate);
        }
        self.take_pending_requests();
        let stopping = !self.inbox.pending_stops.is_empty()
            || self
                .shared
                .stop_pending
                .load(std::sync::atomic::Ordering::SeqCst);
        let shutting_down = *self.inbox.shutdown.borrow();
        let on_requests =
            Hold::on_requests(shutting_down, stopping, !self.inbox.commands.is_empty());
        if on_requests != Hold::Wait {
            return Ok(on_requests);
        }
        while let Ok(job) = self.inbox.gateway_rx.try_recv() {
            self.inbox.gateway.push_back(job);
        }
        if !self.inbox.gateway.is_empty() {
            self.gateway_exchange().await?;
            return Ok(Hold::Wait);
        }
        if tokio::time::Instant::now() >= self.next_poll {
            self.poll().await?;
            self.next_poll = tokio::time::Instant::now() + self.poll_pause();
            // Behind a running move, which may end meanwhile (followed as ever), or alone.
            let uploading = matches!(self.dispatch.machine.phase(), Phase::Uploading { .. });
            let blocked = self
                .dispatch
                .machine
                .blocker(now())
                .is_some_and(|b| b != Blocker::Full);
            if !uploading || blocked {
                return Ok(Hold::Cancel("the PLC changed under it"));
            }
            return Ok(Hold::Wait);
        }
        let closed = (gate.state() == GateState::Closed).then_some(gate);
        self.wait_until(self.next_poll, closed).await;
        Ok(Hold::Wait)
    }

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

    /// Ends the queued prepared moves whose gate shut before their turn, and every move queued
    /// behind one ([`Dispatcher::drop_shut`]).
    ///
    /// [`Dispatcher::drop_shut`]: super::dispatch::Dispatcher::drop_shut
    pub(super) fn drop_shut(&mut self) {
        let ends = self.dispatch.drop_shut();
        self.finish_all(ends);
    }

    /// Ends prepared move `id` cancelled before its start (`why`), its end reason said before
    /// its final stage is.
    fn cancel_prepared(&mut self, id: MoveId, why: &str) {
        self.mark_end(id, EndReason::CancelledBeforeStart);
        let why = format!("{PREPARED_CANCELLED}: {why}");
        self.finish(id, Stage::Cancelled, Some(why), None);
    }
}
