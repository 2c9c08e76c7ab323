//! A cycle's move prepared ahead: its bank uploaded and verified, then held behind a start gate
//! until the cycle reaches its step ([`crate::daemon::gate`]). While held, the status block is
//! read at the busy pace and the gateway served; anything else (a stop, a command, the PLC
//! changing under it, the link, the gate shut) cancels it before its start.

use std::time::Duration;

use super::{Queued, Worker, now};
use crate::contract::machine::{Blocker, Phase};
use crate::daemon::gate::{Gate, GateState};
use crate::plc::exchange::ContractError;
use crate::wire::{EndReason, MoveId, Stage};

/// How a prepared move cancelled before its start begins its report's error (its end reason is
/// [`EndReason::CancelledBeforeStart`]): the cycle then runs it as any move, after its wait.
const PREPARED_CANCELLED: &str = "cancelled before its start";

/// Why a prepared move whose gate shut before its start was not started.
pub(super) const CYCLE_WENT_ON: &str =
    "its cycle went another way (a fault, a stop, a pause, a timeout)";

/// Why a held bank was not started.
pub(super) enum Held {
    /// Cancelled before its start, for this reason.
    Cancelled(&'static str),
    /// The link failed.
    Link(ContractError),
}

/// How often the status block is read during a prepared move's upload behind a running move,
/// when a status read takes `exchange`: five exchanges of the upload to one read (at least
/// `poll`, the busy pace, apart).
pub(super) fn prepared_watch(exchange: Duration, poll: Duration) -> Duration {
    (exchange * 6).max(poll)
}

impl Worker {
    /// Holds an uploaded, verified bank until `gate` opens: the status block read at the busy
    /// pace (the cycle's wait is decided on it) and the gateway served meanwhile. Anything
    /// else cancels it: the gate shut, a stop or a command asked for, the PLC no longer where
    /// the upload left it (a restart, a fault), the link failing.
    pub(super) async fn hold_for(&mut self, gate: &Gate) -> Result<(), Held> {
        loop {
            match gate.state() {
                // Started from rest only: never chained behind the move still running ahead
                // of it (the steps between, outputs and waits, come after that one's end).
                GateState::Open if self.machine.uploading_behind().is_none() => return Ok(()),
                GateState::Shut => return Err(Held::Cancelled(CYCLE_WENT_ON)),
                GateState::Open | GateState::Closed => {}
            }
            self.take_pending_requests();
            if *self.shutdown.borrow() {
                return Err(Held::Cancelled("the daemon is shutting down"));
            }
            let stopping = !self.pending_stops.is_empty()
                || self
                    .shared
                    .stop_pending
                    .load(std::sync::atomic::Ordering::SeqCst);
            if stopping {
                return Err(Held::Cancelled("a stop was asked for"));
            }
            if !self.commands.is_empty() {
                return Err(Held::Cancelled("a command came (home, clear-fault)"));
            }
            while let Ok(job) = self.gateway_rx.try_recv() {
                self.gateway.push_back(job);
            }
            if !self.gateway.is_empty() {
                self.gateway_exchange().await.map_err(Held::Link)?;
                continue;
            }
            if tokio::time::Instant::now() >= self.next_poll {
                self.poll().await.map_err(Held::Link)?;
                self.next_poll = tokio::time::Instant::now() + self.poll_pause();
                // Behind a running move, which may end meanwhile (followed as ever), or alone.
                let uploading = matches!(self.machine.phase(), Phase::Uploading { .. });
                if !uploading
                    || self
                        .machine
                        .blocker(now())
                        .is_some_and(|b| b != Blocker::Full)
                {
                    return Err(Held::Cancelled("the PLC changed under it"));
                }
                continue;
            }
            let closed = (gate.state() == GateState::Closed).then_some(gate);
            self.wait_until(self.next_poll, closed).await;
        }
    }

    /// Ends prepared move `id` before its start (cancelled, `why`; the cycle runs it afresh
    /// after its wait); a link failure (`link`) goes on up.
    pub(super) fn unprepared(
        &mut self,
        id: MoveId,
        why: &str,
        link: Option<ContractError>,
    ) -> Result<(), ContractError> {
        self.machine.upload_ended();
        self.publish_phase();
        tracing::info!(robot = %self.robot.name, id, "prepared move cancelled: {why}");
        self.cancel_prepared(id, why);
        self.cancel_queue("cancelled: the move before it did not start");
        link.map_or(Ok(()), Err)
    }

    /// Ends the queued prepared moves whose gate shut before their turn (their cycle went
    /// another way), and every move queued behind one (planned from where it would have ended).
    pub(super) fn drop_shut(&mut self) {
        let shut = |q: &Queued| {
            q.gate
                .as_ref()
                .is_some_and(|g| g.state() == GateState::Shut)
        };
        let Some(at) = self.queue.iter().position(shut) else {
            return;
        };
        for (k, queued) in self.queue.split_off(at).into_iter().enumerate() {
            if k == 0 {
                self.cancel_prepared(queued.id, CYCLE_WENT_ON);
            } else {
                let why = "cancelled: the move before it did not start".to_owned();
                self.finish(queued.id, Stage::Cancelled, Some(why), None);
            }
        }
    }

    /// Ends prepared move `id` cancelled before its start (`why`), its end reason said before
    /// its final stage is.
    fn cancel_prepared(&mut self, id: MoveId, why: &str) {
        let end = Some(EndReason::CancelledBeforeStart);
        self.shared.moves(|m| {
            m.update(id, |r| {
                if !r.stage.is_final() {
                    r.end = end;
                }
            });
        });
        let why = format!("{PREPARED_CANCELLED}: {why}");
        self.finish(id, Stage::Cancelled, Some(why), None);
    }
}
