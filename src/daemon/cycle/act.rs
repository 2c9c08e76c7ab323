//! What a cycle's steps do to the robot, each through the robot's handle as any client would:
//! a move or a path followed to its end, a wait on the cell's inputs decided on every
//! status block the worker reads, outputs written through the gateway, a dwell. Each gives way
//! to a control request (stop now, or a stop / pause that waits for the step's end) as soon as
//! one comes. And what a pause and a fault do: the robot stopped (a fault), the pallets' slots
//! in progress made unsure (a fault after a restart of the PLC), the moves prepared ahead
//! unprepared.

use std::time::Duration;

use tokio::sync::watch;

use super::pallet::Palletising;
use super::status::Status;
use crate::contract::INPUT_WORDS;
use crate::cycle::runner::{Control, Event, Motion, MotionEnd, Prepared, WaitEnd};
use crate::cycle::{Condition, PalletView};
use crate::daemon::RobotHandle;
use crate::daemon::gate::Gate;
use crate::gateway::{Address, Values};
use crate::wire::{EndReason, MoveId, MoveReport, Stage, StepAt};

/// Each pallet's counter as a condition reads it (`None`: not a pallet of the program).
pub(super) type Pallets<'a> = &'a (dyn Fn(&str) -> Option<PalletView> + Sync);

/// Queues `motion`: its starts, or why it was refused.
pub(super) async fn submit(handle: &RobotHandle, motion: Motion) -> Event<Gate> {
    let submitted = match motion {
        // The handle plans a path off the runtime (it takes milliseconds), as for the API.
        Motion::Move(order, permit) => handle.submit_checked(order, permit).await,
        Motion::Path(order, permit) => handle.submit_checked_path(&order, permit).await,
        // Carried out by the driver's pallets (`super::pallet`), which know the slots.
        Motion::Pallet { pallet, .. } => {
            return Event::Refused(format!("pallet {pallet:?}: no pallet way here"));
        }
    };
    match submitted {
        Ok(ids) => Event::Queued(ids),
        Err(e) => Event::Refused(e.to_string()),
    }
}

/// Uploads `motion` ahead, held behind a gate of its own (`None`: the robot refused it now).
pub(super) async fn prepare(handle: &RobotHandle, motion: Motion) -> Event<Gate> {
    let gate = Gate::new();
    let prepared = match motion {
        Motion::Move(order, permit) => handle
            .submit_gated(order, permit, &gate)
            .await
            .map(|(id, moves)| (vec![id], moves)),
        // A path's sections: the first held behind the gate, the rest queued behind it.
        Motion::Path(order, permit) => handle
            .submit_gated_path(&order, permit, &gate)
            .await
            .map(|ids| (ids, true)),
        // The runner never prepares a pallet's way (its slot is known at its step only).
        Motion::Pallet { .. } => return Event::Prepared(None),
    };
    Event::Prepared(
        prepared
            .ok()
            .map(|(ids, moves)| Prepared { ids, moves, gate }),
    )
}

/// Writes `writes` through the gateway, in order, up to the first that fails.
pub(super) async fn write(handle: &RobotHandle, writes: Vec<(Address, Values)>) -> Event<Gate> {
    for (address, values) in writes {
        if let Err(e) = handle.write_registers(address, values).await {
            return Event::Written(Some(format!("set {address}: {e}")));
        }
    }
    Event::Written(None)
}

/// A follow step: every start of `ids` to its end, the status naming them once they started.
pub(super) async fn follow_step(
    handle: &RobotHandle,
    status: &Status,
    ids: &[MoveId],
    control: &mut watch::Receiver<Control>,
) -> Event<Gate> {
    let mut started = Vec::new();
    let end = follow(handle, ids, control, &mut started).await;
    if end != MotionEnd::NotStarted {
        status.moves(&started);
    }
    Event::Followed(end)
}

/// Follows every start of `ids` to its end.
async fn follow(
    handle: &RobotHandle,
    ids: &[MoveId],
    control: &mut watch::Receiver<Control>,
    started: &mut Vec<MoveId>,
) -> MotionEnd {
    started.extend_from_slice(ids);
    for &id in ids {
        let report = match at_end(handle, id, control).await {
            Ok(report) => report,
            Err(end) => return end,
        };
        // A hold from outside the PLC is set before the robot is stopped: the move that ends
        // short under it was held.
        let held = control.borrow().hold();
        match report.or_else(|| handle.report(id)) {
            Some(r) if r.stage == Stage::Done => {}
            Some(r) if r.end == Some(EndReason::CancelledBeforeStart) => {
                return MotionEnd::NotStarted;
            }
            Some(_) if held.is_some() => {
                return MotionEnd::Held {
                    why: held.unwrap_or_default().to_owned(),
                };
            }
            Some(r) => return ended_short(&r),
            None => {
                return MotionEnd::Failed {
                    why: format!("move {id}'s report was dropped"),
                };
            }
        }
    }
    MotionEnd::Done
}

/// Start `id`'s report once it ends (`None`: its feed closed first); the cycle's end instead
/// when it has no report, or when its control stops it now (the robot stopped).
async fn at_end(
    handle: &RobotHandle,
    id: MoveId,
    control: &mut watch::Receiver<Control>,
) -> Result<Option<MoveReport>, MotionEnd> {
    let Some(mut feed) = handle.subscribe(id) else {
        return Err(MotionEnd::Failed {
            why: format!("move {id} has no report"),
        });
    };
    loop {
        let ended = async {
            let r = feed.wait_for(|r| r.stage.is_final()).await;
            r.map(|r| r.clone()).ok()
        };
        tokio::select! {
            ended = ended => return Ok(ended),
            changed = control.changed() => {
                if changed.is_err() || control.borrow().stops_now() {
                    let _ = handle.stop().await;
                    return Err(MotionEnd::StoppedNow);
                }
            }
        }
    }
}

fn ended_short(r: &MoveReport) -> MotionEnd {
    let why = r.error.clone().unwrap_or_else(|| r.stage.name().to_owned());
    if r.held() {
        MotionEnd::Held { why }
    } else {
        MotionEnd::Failed {
            why: format!("move {} ended {}: {why}", r.id, r.stage.name()),
        }
    }
}

/// The oldest status block a wait is decided on (two busy polls).
pub(super) const FRESH: Duration = Duration::from_millis(40);

/// What a wait decides on: the cell's input words of a status block, and the words a condition
/// reads beyond them (DT words, bits outside the input words), read through the gateway.
pub(super) struct Inputs {
    /// The status block's input words (`None` while the link is down: nothing is met).
    pub words: Option<[u16; INPUT_WORDS]>,
    /// The extra reads, in the order asked.
    pub reads: Vec<(Address, Option<u16>)>,
}

/// Waits until `holds` says the inputs meet the condition, deciding on every status block the
/// worker reads (and reading `extra` through the gateway each time, when the condition needs
/// it), at most `timeout`.
pub(super) async fn wait_until(
    handle: &RobotHandle,
    holds: impl Fn(&Inputs) -> bool,
    extra: &[Address],
    timeout: Option<Duration>,
    control: &mut watch::Receiver<Control>,
) -> WaitEnd {
    let mut reads = handle.watch_reads();
    let deadline = timeout.map(|t| tokio::time::Instant::now() + t);
    let _watching = Watching::inputs(handle);
    wait_loop(handle, holds, extra, deadline, control, &mut reads).await
}

/// The worker reads the status block at its busy pace while this lives: dropped when the wait
/// ends, or is given up (the cycle faulted on an incident meanwhile).
struct Watching<'h>(&'h RobotHandle);

impl<'h> Watching<'h> {
    fn inputs(handle: &'h RobotHandle) -> Self {
        handle.watch_inputs(true);
        Self(handle)
    }
}

impl Drop for Watching<'_> {
    fn drop(&mut self) {
        self.0.watch_inputs(false);
    }
}

async fn wait_loop(
    handle: &RobotHandle,
    holds: impl Fn(&Inputs) -> bool,
    extra: &[Address],
    deadline: Option<tokio::time::Instant>,
    control: &mut watch::Receiver<Control>,
    reads: &mut crate::daemon::Reads,
) -> WaitEnd {
    loop {
        let inputs = Inputs::read(handle, extra).await;
        // Decided only on a status block read within the last poll or two: one read while the
        // robot stood (every 250 ms) may show an input that has changed since.
        let fresh = handle.since_status_read().is_some_and(|age| age <= FRESH);
        if fresh && inputs.words.is_some() && holds(&inputs) {
            return WaitEnd::Met;
        }
        let expired = async {
            match deadline {
                Some(at) => tokio::time::sleep_until(at).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            read = reads.next() => {
                if read.is_err() {
                    // The robot's worker is gone (the daemon shuts down): nothing more is read.
                    return WaitEnd::StoppedNow;
                }
            }
            () = expired => return WaitEnd::TimedOut,
            changed = control.changed() => {
                let c = *control.borrow();
                if changed.is_err() || c.stops() {
                    return WaitEnd::StoppedNow;
                }
                if c.pause().is_some() {
                    return WaitEnd::Paused;
                }
            }
        }
    }
}

impl Inputs {
    /// The input words of the last status block, and `extra` read through the gateway now.
    pub(super) async fn read(handle: &RobotHandle, extra: &[Address]) -> Self {
        let mut reads = Vec::with_capacity(extra.len());
        for &address in extra {
            reads.push((address, read_one(handle, address).await));
        }
        Self {
            words: handle.state().inputs,
            reads,
        }
    }

    /// Whether `until` holds on them (never while the input words are unknown), `pallets`
    /// giving each pallet's counter.
    pub(super) fn meet(&self, until: &Condition, pallets: Pallets<'_>) -> bool {
        let read = |a| {
            self.reads
                .iter()
                .find(|(r, _)| *r == a)
                .and_then(|(_, v)| *v)
        };
        self.words
            .is_some_and(|w| until.holds_with(&w, &read, pallets))
    }
}

/// One word or bit read through the gateway (`None`: it could not be read).
async fn read_one(handle: &RobotHandle, address: Address) -> Option<u16> {
    match handle.read_registers(address, 1).await {
        Ok(Values::Words(w)) => w.first().copied(),
        Ok(Values::Bits(b)) => b.first().map(|&on| u16::from(on)),
        Err(_) => None,
    }
}

/// Sleeps `for_`, or until a stop (now or at the step's end: a dwell moves nothing): whether it
/// slept the whole time.
pub(super) async fn dwell(for_: Duration, control: &mut watch::Receiver<Control>) -> bool {
    let end = tokio::time::Instant::now() + for_;
    loop {
        tokio::select! {
            () = tokio::time::sleep_until(end) => return true,
            changed = control.changed() => {
                if changed.is_err() || control.borrow().stops() {
                    return false;
                }
            }
        }
    }
}

/// Unprepares motions prepared ahead: their gates shut, then every start of them waited out
/// (cancelled before their start), so nothing is queued behind them.
pub(super) async fn unprepare(handle: &RobotHandle, moves: Vec<Prepared<Gate>>) {
    for prepared in &moves {
        handle.shut_gate(&prepared.gate);
    }
    for id in moves.into_iter().flat_map(|p| p.ids) {
        let _ = handle.wait(id, Duration::from_secs(30)).await;
    }
}

/// Whether a loop's `until` (or a skip's condition) holds, decided on a fresh status block,
/// not one from before the steps ran (`None`: the robot's worker is gone); one that reads
/// pallets alone at once.
pub(super) async fn decide(
    handle: &RobotHandle,
    until: &Condition,
    pallets: Pallets<'_>,
) -> Option<bool> {
    if !reads_the_plc(until) {
        return Some(until.holds_with(&[0; INPUT_WORDS], &|_| None, pallets));
    }
    let stale = handle.since_status_read().is_none_or(|age| age > FRESH);
    if stale && !pace(handle).await {
        return None;
    }
    Some(
        Inputs::read(handle, &until.reads())
            .await
            .meet(until, pallets),
    )
}

/// Whether `c` reads anything of the PLC (an input, a bit, a word), not pallets alone.
fn reads_the_plc(c: &Condition) -> bool {
    match c {
        Condition::Pallet { .. } => false,
        Condition::Not(c) => reads_the_plc(c),
        Condition::All(cs) | Condition::Any(cs) => cs.iter().any(reads_the_plc),
        Condition::Bit { .. } | Condition::Word { .. } => true,
    }
}

/// Lets one status read pass (at most a second): `false` when the robot's worker is gone.
pub(super) async fn pace(handle: &RobotHandle) -> bool {
    let mut reads = handle.watch_reads();
    let read = tokio::time::timeout(Duration::from_secs(1), reads.next()).await;
    !matches!(read, Ok(Err(_)))
}

/// A wait step at `at`: until `until` holds, at most `timeout`, the status saying so.
pub(super) async fn wait_step(
    handle: &RobotHandle,
    status: &Status,
    (at, until, timeout): (&StepAt, &Condition, Option<Duration>),
    pallets: Pallets<'_>,
    control: &mut watch::Receiver<Control>,
) -> Event<Gate> {
    let since = tokio::time::Instant::now();
    status.waiting(Some(until.to_string()), Some(0.0));
    let holds = |inputs: &Inputs| {
        status.waited(since.elapsed().as_secs_f64());
        inputs.meet(until, pallets)
    };
    let end = wait_until(handle, holds, &until.reads(), timeout, control).await;
    let waited_s = since.elapsed().as_secs_f64();
    handle.waited(at, waited_s);
    status.waiting(None, None);
    Event::Waited { end, waited_s }
}

/// Pauses the cycle (`why`): the moves prepared ahead unprepared, the status saying so.
pub(super) async fn pause(
    handle: &RobotHandle,
    status: &Status,
    why: String,
    moves: Vec<Prepared<Gate>>,
) -> Event<Gate> {
    tracing::warn!(robot = %handle.robot().name, "cycle paused: {why}");
    unprepare(handle, moves).await;
    status.paused(why);
    Event::Changed
}

/// Faults the cycle on its step (`why`): the robot stopped when `stop_robot` (through `base`,
/// as any client: the stop is not refused for an incident), the pallets' slots in progress made
/// unsure when `interrupted` (the PLC restarted under the cycle), the moves prepared ahead
/// unprepared, the status saying so.
pub(super) async fn fault(
    handle: &RobotHandle,
    base: &RobotHandle,
    status: &Status,
    why: String,
    (stop_robot, interrupted): (bool, bool),
    moves: Vec<Prepared<Gate>>,
) -> Event<Gate> {
    tracing::warn!(robot = %handle.robot().name, "cycle faulted: {why}");
    if interrupted {
        Palletising::interrupted(base);
    }
    if stop_robot {
        let _ = base.stop_robot().await;
    }
    unprepare(handle, moves).await;
    status.ended(crate::wire::CycleState::Faulted, Some(why));
    Event::Changed
}
