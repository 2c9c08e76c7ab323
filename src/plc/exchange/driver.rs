//! The tests' driver of the pure [`Machine`] over a [`Contract`], shared by the crate's unit
//! tests and the integration tests in `tests/common/`. It makes the daemon worker's exchanges in
//! its order: status reads until the PLC takes a start ([`until_ready`]), the upload (begun in
//! the machine first, by the caller), then the worker's own [`Contract::proof_read`] (the
//! heartbeat word alone first, when the machine wants two reads, then the status block) until
//! [`Machine::may_start`] ([`until_it_may_start`]), the start written once, and status reads
//! every poll interval to the start's end ([`start_and_follow`]).
//!
//! Not product code: the daemon drives the machine its own way (`daemon/`); this is the
//! smallest driver that shows the contract working against a mock or a fake PLC.

use std::time::Duration;

use super::{CommandWrite, Contract, ContractError, VerifiedBank};
use crate::contract::machine::{Blocker, Event, Machine, Planned, Status};
use crate::plc::{Plc, PlcMode};

/// Reads the status block into `machine` (carrying out the host word and stop it asks for)
/// until a start can be written, as long as the heartbeat stands still no longer than its
/// limit: the heartbeat seen moving, the host word echoed, no fault, the ready bits set.
pub async fn until_ready<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
) -> Result<Status, ContractError> {
    let limit = machine.settings().heartbeat_timeout;
    let began = tokio::time::Instant::now();
    let mut first = None;
    loop {
        let status = c.status().await?;
        let now = tokio::time::Instant::now().into_std();
        for event in machine.on_status(&status, now) {
            carry_out(c, &event, machine).await?;
        }
        let moved = *first.get_or_insert(status.block.heartbeat) != status.block.heartbeat;
        let still = machine.heartbeat_age(now).unwrap_or_default();
        match machine.blocker(now) {
            None if moved => return Ok(status),
            Some(b @ (Blocker::Faulted { .. } | Blocker::NotReady { .. } | Blocker::NotHomed)) => {
                return Err(ContractError::Blocked(b));
            }
            _ if still > limit => return Err(stalled(c, still, limit).await),
            Some(b) if began.elapsed() > limit * 4 => return Err(ContractError::Blocked(b)),
            _ => tokio::time::sleep(c.settings().scan_time.min(limit / 4)).await,
        }
    }
}

/// Starts `bank`, uploaded for `start`, and follows it to its end: the start is written only
/// once the heartbeat is seen moving after the upload, the PLC takes a start and every count is
/// `start.from`. Done: the last status block; anything else: an error
/// ([`ContractError::Ended`] once the start was written).
pub async fn start_and_follow<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
    bank: &VerifiedBank,
    start: Planned,
) -> Result<Status, ContractError> {
    until_it_may_start(c, machine, &start).await?;
    let confirmed = matches!(c.start(bank).await?, CommandWrite::Confirmed);
    machine.start_written(
        start.clone(),
        tokio::time::Instant::now().into_std(),
        confirmed,
    );
    loop {
        tokio::time::sleep(c.settings().poll_interval).await;
        let status = c.status().await?;
        let now = tokio::time::Instant::now().into_std();
        let mut end = None;
        for event in machine.on_status(&status, now) {
            match event {
                Event::Done { tag, .. } if tag == start.tag => end = Some(Ok(status)),
                Event::Ended { tag, outcome } if tag == start.tag => {
                    end = Some(Err(ContractError::Ended {
                        seq: start.seq,
                        outcome,
                    }));
                }
                Event::RewriteStart { .. } => {
                    let confirmed = matches!(c.start(bank).await?, CommandWrite::Confirmed);
                    machine.start_rewritten(tokio::time::Instant::now().into_std(), confirmed);
                }
                other => carry_out(c, &other, machine).await?,
            }
        }
        if let Some(end) = end {
            return end;
        }
    }
}

/// After the upload of `start` (begun with [`Machine::upload_begun`]): the daemon's reads
/// toward the heartbeat proof ([`Contract::proof_read`]) until the start may be written. Counts
/// other than `start.from`, a stalled PLC or anything else that blocks it end the upload with
/// the reason.
pub async fn until_it_may_start<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
    start: &Planned,
) -> Result<(), ContractError> {
    loop {
        let status = c.proof_read(machine).await?;
        let now = tokio::time::Instant::now().into_std();
        for event in machine.on_status(&status, now) {
            carry_out(c, &event, machine).await?;
        }
        let blocker = match machine.may_start(start, now) {
            Ok(()) => return Ok(()),
            Err(Blocker::Unproven) => {
                tokio::time::sleep(c.settings().scan_time / 2).await;
                continue;
            }
            Err(blocker) => blocker,
        };
        machine.upload_ended();
        return Err(match blocker {
            Blocker::NotAtFrom {
                channel,
                count,
                from,
            } => ContractError::NotAtFrom {
                channel,
                count,
                from,
            },
            Blocker::Stalled => {
                let limit = machine.settings().heartbeat_timeout;
                let still = machine.heartbeat_age(now).unwrap_or_default();
                stalled(c, still, limit).await
            }
            other => ContractError::Blocked(other),
        });
    }
}

/// What the machine asks for that needs only the link: the host word, a stop.
async fn carry_out<P: Plc>(
    c: &mut Contract<P>,
    event: &Event,
    machine: &Machine,
) -> Result<(), ContractError> {
    match event {
        Event::WriteHost => c.write_host(machine.host()).await,
        Event::WriteStop => c.stop().await,
        _ => Ok(()),
    }
}

/// A stalled PLC, named with its mode when it says PROG.
async fn stalled<P: Plc>(c: &mut Contract<P>, still: Duration, limit: Duration) -> ContractError {
    let prog = matches!(c.plc().mode().await, Ok(PlcMode::Prog));
    ContractError::Stalled {
        still_ms: still.as_millis() as u64,
        limit_ms: limit.as_millis() as u64,
        mode: if prog { ", and in PROG mode" } else { "" },
    }
}
