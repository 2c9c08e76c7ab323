//! The register gateway's side of the worker: one exchange of the oldest request at a time, put
//! between the worker's own exchanges, so a status read or a start waits behind one gateway
//! exchange at most.

use std::time::Duration;

use super::{Worker, now};
use crate::daemon::gateway::{GatewayError, Job, Piece, Values};
use crate::plc::exchange::ContractError;
use crate::plc::{AnyPlc, Plc, PlcError};

impl Worker {
    /// Carries out the next piece of the oldest gateway request; answers it when it is done or
    /// failed. A link failure also fails the link (the caller reconnects).
    pub(super) async fn gateway_exchange(&mut self) -> Result<(), ContractError> {
        let Some(session) = self.conn.session.as_mut() else {
            self.gateway_link_down();
            return Ok(());
        };
        let sizes = session.contract.plc().exchange_sizes();
        if self.inbox.gateway.is_empty() || self.refuse_untrusted() {
            return Ok(());
        }
        let job = self.inbox.gateway.front_mut().expect("not empty");
        let Some(piece) = job.next_piece(sizes) else {
            let job = self.inbox.gateway.pop_front().expect("front");
            job.finish();
            return Ok(());
        };
        match self.timed_exchange(&piece).await? {
            Ok(read) => {
                let job = self.inbox.gateway.front_mut().expect("front");
                job.piece_done(&piece, read);
                if job.next_piece(sizes).is_none() {
                    let job = self.inbox.gateway.pop_front().expect("front");
                    self.out.state(|s| s.gateway.requests += 1);
                    self.shared.metrics.gateway_request(false);
                    job.finish();
                }
                Ok(())
            }
            Err(e) => self.gateway_failed(e),
        }
    }

    /// Refuses the oldest request if it was asked for before the PLC restarted, stalled or was
    /// lost: a cycle's output is never written to a PLC it no longer knows.
    fn refuse_untrusted(&mut self) -> bool {
        let incidents = self.out.incidents();
        let stale = |job: &Job| job.epoch.is_some_and(|e| e != incidents.count);
        if !self.inbox.gateway.front().is_some_and(stale) {
            return false;
        }
        let job = self.inbox.gateway.pop_front().expect("front");
        let why = incidents.last.unwrap_or_default();
        tracing::warn!(robot = %self.robot.name, range = %job.range, "a cycle's output not written: {why} since it was asked for");
        let _ = job.reply.send(Err(GatewayError::Untrusted { why }));
        true
    }

    /// One exchange of `piece`, timed into the gateway's figures: how long it took and how long
    /// a status read that fell due meanwhile waited for it.
    async fn timed_exchange(
        &mut self,
        piece: &Piece,
    ) -> Result<Result<Option<Values>, PlcError>, ContractError> {
        let plc = self.link()?.plc();
        let began = now();
        let result = exchange(plc, piece).await;
        let ended = now();
        let due = self.dispatch.next_poll().unwrap_or(began);
        let held = ended.saturating_duration_since(began.max(due));
        self.out.state(|s| {
            s.gateway.exchanges += 1;
            s.gateway.longest_exchange_ms =
                s.gateway.longest_exchange_ms.max(millis(ended - began));
            s.gateway.longest_poll_delay_ms = s.gateway.longest_poll_delay_ms.max(millis(held));
        });
        if due <= ended {
            self.shared
                .metrics
                .waited_behind_gateway(held.as_secs_f64());
        }
        Ok(result)
    }

    /// The oldest request failed by `e`: answered; a link failure goes on up.
    fn gateway_failed(&mut self, e: PlcError) -> Result<(), ContractError> {
        let job = self.inbox.gateway.pop_front().expect("front");
        self.out.state(|s| {
            s.gateway.requests += 1;
            s.gateway.failed += 1;
        });
        self.shared.metrics.gateway_request(true);
        if e.is_link_failure() {
            let _ = job.reply.send(Err(GatewayError::LinkDown {
                detail: Some(e.to_string()),
            }));
            Err(ContractError::Plc(e))
        } else {
            let _ = job.reply.send(Err(GatewayError::Plc(e.to_string())));
            Ok(())
        }
    }

    /// Answers every gateway request waiting: the link is down.
    pub(super) fn gateway_link_down(&mut self) {
        while let Ok(job) = self.inbox.gateway_rx.try_recv() {
            self.inbox.gateway.push_back(job);
        }
        if self.inbox.gateway.is_empty() {
            return;
        }
        let detail = self.out.state(|s| s.link.error.clone());
        for job in std::mem::take(&mut self.inbox.gateway) {
            self.out.state(|s| {
                s.gateway.requests += 1;
                s.gateway.failed += 1;
            });
            self.shared.metrics.gateway_request(true);
            let _ = job.reply.send(Err(GatewayError::LinkDown {
                detail: detail.clone(),
            }));
        }
    }
}

fn millis(d: Duration) -> u64 {
    u64::try_from(d.as_millis()).unwrap_or(u64::MAX)
}

/// One exchange of a piece; what it read, if it reads.
async fn exchange(plc: &mut AnyPlc, piece: &Piece) -> Result<Option<Values>, PlcError> {
    Ok(match piece {
        Piece::ReadWords { start, count } => {
            Some(Values::Words(plc.read_words(*start, *count).await?))
        }
        Piece::WriteWords { start, words } => {
            plc.write_words(*start, words).await?;
            None
        }
        Piece::ReadBits { area, start, count } => {
            Some(Values::Bits(plc.read_bits(*area, *start, *count).await?))
        }
        Piece::WriteBit { area, bit, on } => {
            plc.write_bit(*area, *bit, *on).await?;
            None
        }
    })
}
