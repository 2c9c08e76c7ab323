//! The cycle runner: one task per cycle, carrying out a checked program's ops through the
//! robot's handle, writing its status as it goes, obeying its control between steps (a stop or
//! a pause takes effect at the end of the current step; a stop `now` at once).
//!
//! What ends a step other than done:
//! - a move held by the PLC (its permit dropped): the cycle pauses on that step; `resume` runs
//!   the move again from where the robot stopped (a `by` move, whose target depended on where it
//!   began, and a path, which would not be the path planned, fault instead);
//! - anything else (a move refused or failed, a wait timed out with no `on_timeout`, an output
//!   not written): the robot is stopped and the cycle faults on that step; it goes on only after
//!   `clear-fault` and `resume` (or a fresh `run`), with that step again.
//!
//! The next move is prepared ahead: while a move runs, or a wait waits, the next move step the
//! cycle comes to through outputs, waits and dwells only (wrapping round to the next cycle) is
//! uploaded behind it and held; it starts, from rest, when the runner reaches its step. (A move
//! to where the robot will already be has no motion of its own: the one after it is prepared
//! too.) Anything else the cycle does first (another motion, a fault, a hold, a pause, a stop,
//! its end) shuts its gate and it is cancelled before its start; a move cancelled so is run
//! afresh at its step.

use std::collections::{HashMap, VecDeque};
use std::time::Instant;

use tokio::sync::watch;

use super::act::{self, Inputs, MotionEnd, WaitEnd};
use super::control::Control;
use super::slot::SharedStatus;
use crate::cycle::{Checked, LoopExit, OpKind};
use crate::daemon::RobotHandle;
use crate::daemon::Snapshot;
use crate::daemon::gate::Gate;
use crate::wire::MoveId;
use crate::wire::{CycleState, CycleStatus};

/// Moves kept in the status, the newest last.
const MOVES_SHOWN: usize = 10;

/// Runs `program` `count` times (or until stopped).
pub(crate) async fn run(
    handle: RobotHandle,
    program: Checked,
    count: Option<u64>,
    control: watch::Receiver<Control>,
    status: SharedStatus,
) {
    let incidents = handle.watch_incidents();
    let epoch = incidents.borrow().incidents.count;
    let mut runner = Runner {
        handle: handle.under(epoch),
        base: handle,
        incidents,
        epoch,
        reported: epoch,
        program,
        count,
        control,
        status,
        resumes: 0,
        done: 0,
        waited_s: 0.0,
        ahead: VecDeque::new(),
    };
    let end = runner.cycles().await;
    runner.drop_ahead().await;
    runner.set(|s| {
        s.state = end.0;
        s.reason = end.1;
        s.waiting_for = None;
        s.waiting_s = None;
        s.stopping = false;
    });
    tracing::info!(robot = %runner.handle.robot().name, program = %runner.program.name, state = ?end.0, "cycle ended");
}

struct Runner {
    /// The robot, acting under [`Self::epoch`]: what the cycle asks for is refused once
    /// another incident came.
    handle: RobotHandle,
    /// The robot, as any client.
    base: RobotHandle,
    /// The robot's snapshot, for its incidents (restarts, stalls and PROG mode, links lost past
    /// a move's end).
    incidents: watch::Receiver<Snapshot>,
    /// The incident count the cycle acts under: from its start, or the fault clear it was
    /// resumed after. Any incident since faults it, whatever it is doing.
    epoch: u64,
    /// The incident count the status last reported.
    reported: u64,
    program: Checked,
    count: Option<u64>,
    control: watch::Receiver<Control>,
    status: SharedStatus,
    /// Resumes seen.
    resumes: u64,
    /// Cycles done.
    done: u64,
    /// Time this cycle's waits waited so far, s.
    waited_s: f64,
    /// The next move steps' moves, prepared ahead, in the order the cycle comes to them: one
    /// that moves, and before it any that do not.
    ahead: VecDeque<Ahead>,
}

/// A move uploaded ahead of its step and held until the runner reaches it.
struct Ahead {
    /// Its op.
    at: usize,
    /// Its move.
    id: MoveId,
    /// Opened at its step; shut when the cycle goes another way.
    gate: Gate,
    /// Whether it moves the robot (planned to end more than a pulse from where it begins).
    moves: bool,
}

/// How a step ended.
#[derive(Debug, PartialEq)]
enum Next {
    /// Go on at this op.
    Go(usize),
    /// The PLC held the robot: pause on this op.
    Hold(String),
    /// Stop the robot and fault on this op.
    Fault(String),
    /// A stop now: end.
    Stopped,
}

impl Runner {
    fn set(&self, f: impl FnOnce(&mut CycleStatus)) {
        f(&mut self
            .status
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner));
    }

    /// Every cycle: the final state and why.
    async fn cycles(&mut self) -> (CycleState, Option<String>) {
        let mut pc = 0;
        let mut loops: HashMap<usize, u64> = HashMap::new();
        let mut began = Instant::now();
        loop {
            let c = *self.control.borrow();
            if c.stop || c.stop_now {
                return (CycleState::Stopped, Some("stopped by request".to_owned()));
            }
            if let Some(why) = self.incident() {
                if !self.faulted(why).await {
                    return (CycleState::Stopped, Some("stopped by request".to_owned()));
                }
                continue;
            }
            if c.pause {
                self.drop_ahead().await;
                self.set(|s| {
                    s.state = CycleState::Paused;
                    s.reason = Some(c.hold.unwrap_or("paused by request").to_owned());
                });
                if !self.until_resumed().await {
                    return (CycleState::Stopped, Some("stopped by request".to_owned()));
                }
            }
            if pc == self.program.ops.len() {
                self.done += 1;
                let (took, done) = (began.elapsed().as_secs_f64(), self.done);
                let waited = std::mem::take(&mut self.waited_s);
                self.handle.cycle_done(took);
                self.set(|s| {
                    s.done = done;
                    s.last_cycle_s = Some(took);
                    s.last_cycle_waiting_s = Some(waited);
                });
                if self.count.is_some_and(|n| done >= n) {
                    return (CycleState::Done, None);
                }
                pc = 0;
                loops.clear();
                began = Instant::now();
                continue;
            }
            let moves_elsewhere =
                matches!(self.program.ops[pc].kind, OpKind::Move(_) | OpKind::Path(_))
                    && self.ahead.front().is_some_and(|a| a.at != pc);
            if moves_elsewhere {
                self.drop_ahead().await;
            }
            let at = self.program.ops[pc].at.clone();
            tracing::debug!(robot = %self.handle.robot().name, step = at.step, ahead = ?self.ahead.iter().map(|a| a.at).collect::<Vec<_>>(), "cycle step");
            self.set(|s| {
                s.state = CycleState::Running;
                s.step = Some(at);
                s.reason = None;
                s.stopping = c.stop;
            });
            let next = {
                let mut incidents = self.incidents.clone();
                let epoch = self.epoch;
                tokio::select! {
                    biased;
                    why = until_incident(&mut incidents, epoch) => Next::Fault(why),
                    next = self.op(pc, &mut loops) => next,
                }
            };
            match next {
                Next::Go(next) => pc = next,
                Next::Stopped => {
                    return (
                        CycleState::Stopped,
                        Some("stopped now by request".to_owned()),
                    );
                }
                Next::Hold(why) => {
                    tracing::warn!(robot = %self.handle.robot().name, "cycle held: {why}");
                    self.drop_ahead().await;
                    self.set(|s| {
                        s.state = CycleState::Paused;
                        s.reason = Some(why);
                    });
                    if !self.until_resumed().await {
                        return (CycleState::Stopped, Some("stopped by request".to_owned()));
                    }
                }
                Next::Fault(why) => {
                    if !self.faulted(why).await {
                        return (CycleState::Stopped, Some("stopped by request".to_owned()));
                    }
                }
            }
        }
    }

    /// What an incident since the cycle's epoch was, if one came.
    fn incident(&self) -> Option<String> {
        let now = &self.incidents.borrow().incidents;
        (now.count != self.epoch).then(|| now.last.clone().unwrap_or_default())
    }

    /// Faults the cycle on its step (`why`): the robot stopped, the prepared moves dropped; then
    /// waits for a resume after `clear-fault` (`false`: a stop came instead).
    async fn faulted(&mut self, why: String) -> bool {
        tracing::warn!(robot = %self.handle.robot().name, "cycle faulted: {why}");
        self.reported = self.incidents.borrow().incidents.count;
        let _ = self.base.stop_robot().await;
        self.drop_ahead().await;
        self.set(|s| {
            s.state = CycleState::Faulted;
            s.reason = Some(why);
            s.waiting_for = None;
            s.waiting_s = None;
        });
        self.until_resumed().await
    }

    /// Waits for a resume: `false` when a stop came instead. An incident meanwhile faults a
    /// paused cycle (and a faulted one names it): only a resume after `clear-fault` goes on.
    async fn until_resumed(&mut self) -> bool {
        loop {
            {
                let c = *self.control.borrow_and_update();
                if c.stop || c.stop_now {
                    return false;
                }
                if c.resumes > self.resumes {
                    self.resumes = c.resumes;
                    if let Some(epoch) = c.epoch {
                        // Resumed after a clear with no incident since: it acts under it now.
                        self.epoch = epoch;
                        self.reported = epoch;
                        self.handle = self.base.under(epoch);
                    }
                    return true;
                }
            }
            let mut incidents = self.incidents.clone();
            let reported = self.reported;
            tokio::select! {
                changed = self.control.changed() => {
                    if changed.is_err() {
                        return false;
                    }
                }
                why = until_incident(&mut incidents, reported) => {
                    tracing::warn!(robot = %self.handle.robot().name, "cycle faulted while it stood: {why}");
                    self.reported = incidents.borrow().incidents.count;
                    self.set(|s| {
                        s.state = CycleState::Faulted;
                        s.reason = Some(why);
                    });
                }
            }
        }
    }

    async fn op(&mut self, pc: usize, loops: &mut HashMap<usize, u64>) -> Next {
        let kind = self.program.ops[pc].kind.clone();
        match kind {
            OpKind::Move(order) => {
                if self.ahead.front().is_some_and(|a| a.at == pc) {
                    // Held from outside the PLC (move-enable dropped): its gate shuts, as a
                    // move not prepared is not queued.
                    let hold = self.control.borrow().hold;
                    if let Some(why) = hold {
                        self.drop_ahead().await;
                        return Next::Hold(why.to_owned());
                    }
                    let ahead = self.ahead.pop_front().expect("just seen");
                    ahead.gate.open();
                    return self.prepared(pc, ahead.id).await;
                }
                let relative = order.by.is_some();
                let mut started = Vec::new();
                let end = match act::submit_move(&self.handle, order, &self.control).await {
                    Ok(ids) => {
                        self.prepare(pc).await;
                        act::follow(&self.handle, &ids, &mut self.control, &mut started).await
                    }
                    Err(end) => end,
                };
                self.note_moves(&started);
                match end {
                    MotionEnd::Held { why } if relative => Next::Fault(format!(
                        "{why}; a move `by` an offset is not resumed mid-way (its target depended \
                         on where it began)"
                    )),
                    end => Self::motion(pc, end),
                }
            }
            OpKind::Path(order) => {
                let mut started = Vec::new();
                let end =
                    act::run_path(&self.handle, &order, &mut self.control, &mut started).await;
                self.note_moves(&started);
                match end {
                    MotionEnd::Held { why } => Next::Fault(format!(
                        "{why}; a path is not resumed mid-way (it would not be the path planned)"
                    )),
                    end => Self::motion(pc, end),
                }
            }
            OpKind::Wait {
                until,
                timeout,
                on_timeout,
            } => {
                self.prepare(pc).await;
                self.wait(pc, &until, timeout, on_timeout).await.0
            }
            OpKind::Set(writes) => {
                for (address, values) in writes {
                    if let Err(e) = self.handle.write_registers(address, values).await {
                        return Next::Fault(format!("set {address}: {e}"));
                    }
                }
                Next::Go(pc + 1)
            }
            OpKind::Dwell(d) => {
                if act::dwell(d, &mut self.control).await {
                    Next::Go(pc + 1)
                } else {
                    Next::Stopped
                }
            }
            OpKind::Loop { to, exit } => {
                let next = self.loop_next(pc, to, exit, loops).await;
                if next == Next::Go(to) && !self.takes_time(to, pc) {
                    // A loop whose steps take no time (outputs, conditions) goes round at the
                    // pace of the status reads, not as fast as the runtime can spin.
                    let mut reads = self.handle.watch_reads();
                    let read =
                        tokio::time::timeout(std::time::Duration::from_secs(1), reads.next()).await;
                    if matches!(read, Ok(Err(_))) {
                        // The robot's worker is gone: the cycle ends with it.
                        return Next::Stopped;
                    }
                }
                next
            }
        }
    }

    /// The next move step the cycle comes to after op `pc` through outputs, waits and dwells
    /// only (round to the first op when another cycle follows, on through a loop that always
    /// goes back): that step's op, if its move can be prepared (to a pose, a position or
    /// joints; not `by` an offset, not a path).
    fn next_move(&self, pc: usize) -> Option<usize> {
        let ops = &self.program.ops;
        let wraps = self.count.is_none_or(|n| self.done + 1 < n);
        let mut at = pc + 1;
        for _ in 0..=ops.len() {
            if at == ops.len() {
                if !wraps {
                    return None;
                }
                at = 0;
            }
            match &ops[at].kind {
                OpKind::Set(_) | OpKind::Wait { .. } | OpKind::Dwell(_) => at += 1,
                OpKind::Loop {
                    to,
                    exit: LoopExit::Stop,
                } => at = *to,
                OpKind::Move(order) if order.by.is_none() && at != pc => return Some(at),
                _ => return None,
            }
        }
        None
    }

    /// Prepares the next moves after op `pc` ([`Self::next_move`]) up to one that moves,
    /// unless a stop, a pause or a hold is asked for; one the robot refuses now is left to run
    /// at its step.
    async fn prepare(&mut self, pc: usize) {
        let c = *self.control.borrow();
        if c.stop || c.stop_now || c.pause || c.hold.is_some() {
            return;
        }
        // Never round the program more than once: a move's step is prepared once.
        while self.ahead.len() < self.program.ops.len()
            && self.ahead.back().is_none_or(|a| !a.moves)
        {
            let after = self.ahead.back().map_or(pc, |a| a.at);
            let Some(at) = self.next_move(after) else {
                return;
            };
            if at == pc || self.ahead.iter().any(|a| a.at == at) {
                return;
            }
            let OpKind::Move(order) = &self.program.ops[at].kind else {
                return;
            };
            let gate = Gate::new();
            let Ok((id, moves)) = self.handle.submit_gated(order.clone(), &gate).await else {
                return;
            };
            self.ahead.push_back(Ahead {
                at,
                id,
                gate,
                moves,
            });
        }
    }

    /// Shuts the prepared moves' gates and waits for them to end (cancelled before their
    /// start), so nothing is queued behind them.
    async fn drop_ahead(&mut self) {
        let dropped: Vec<Ahead> = self.ahead.drain(..).collect();
        for ahead in &dropped {
            self.handle.shut_gate(&ahead.gate);
        }
        for ahead in dropped {
            let _ = self
                .handle
                .wait(ahead.id, std::time::Duration::from_secs(30))
                .await;
        }
    }

    /// The move of op `at`, prepared ahead and released now: followed to its end (the move
    /// after it prepared meanwhile); run afresh when it was cancelled before its start.
    async fn prepared(&mut self, at: usize, id: MoveId) -> Next {
        self.prepare(at).await;
        let mut started = Vec::new();
        let end = act::follow(&self.handle, &[id], &mut self.control, &mut started).await;
        let cancelled_before_start = self
            .handle
            .report(id)
            .is_some_and(|r| r.end == Some(crate::wire::EndReason::CancelledBeforeStart));
        if cancelled_before_start {
            self.drop_ahead().await;
            return Next::Go(at);
        }
        self.note_moves(&started);
        Self::motion(at, end)
    }

    /// A wait step: until its condition holds, at most `timeout`: what comes next, and whether
    /// its condition was met.
    async fn wait(
        &mut self,
        pc: usize,
        until: &crate::cycle::Condition,
        timeout: Option<std::time::Duration>,
        on_timeout: Option<usize>,
    ) -> (Next, bool) {
        let since = tokio::time::Instant::now();
        self.set(|s| {
            s.state = CycleState::Waiting;
            s.waiting_for = Some(until.to_string());
            s.waiting_s = Some(0.0);
        });
        let status = std::sync::Arc::clone(&self.status);
        let holds = |inputs: &Inputs| {
            let waited = since.elapsed().as_secs_f64();
            if let Ok(mut s) = status.lock() {
                s.waiting_s = Some(waited);
            }
            inputs.meet(until)
        };
        let end = act::wait_until(
            &self.handle,
            holds,
            &until.reads(),
            timeout,
            &mut self.control,
        )
        .await;
        let waited = since.elapsed().as_secs_f64();
        self.waited_s += waited;
        self.handle.waited(&self.program.ops[pc].at, waited);
        self.set(|s| {
            s.waiting_for = None;
            s.waiting_s = None;
        });
        let next = match (end, on_timeout) {
            (WaitEnd::Met, _) => Next::Go(pc + 1),
            (WaitEnd::TimedOut, Some(to)) => Next::Go(to),
            (WaitEnd::TimedOut, None) => {
                Next::Fault(format!("wait for {until} timed out after {waited:.1} s"))
            }
            (WaitEnd::StoppedNow, _) => Next::Stopped,
            // The pause at the top of the loop takes it; the wait runs again on resume.
            (WaitEnd::Paused, _) => Next::Go(pc),
        };
        (next, end == WaitEnd::Met)
    }

    /// Whether ops `from..=to` include one that takes time (a motion, a wait, a dwell).
    fn takes_time(&self, from: usize, to: usize) -> bool {
        self.program.ops[from..=to].iter().any(|op| {
            matches!(
                op.kind,
                OpKind::Move(_) | OpKind::Path(_) | OpKind::Wait { .. } | OpKind::Dwell(_)
            )
        })
    }

    async fn loop_next(
        &mut self,
        pc: usize,
        to: usize,
        exit: LoopExit,
        loops: &mut HashMap<usize, u64>,
    ) -> Next {
        match exit {
            LoopExit::Count(n) => {
                let ran = loops.entry(pc).or_insert(1);
                if *ran < n {
                    *ran += 1;
                    Next::Go(to)
                } else {
                    loops.remove(&pc);
                    Next::Go(pc + 1)
                }
            }
            LoopExit::Stop => Next::Go(to),
            LoopExit::Until(until) => {
                if self
                    .handle
                    .since_status_read()
                    .is_none_or(|age| age > act::FRESH)
                {
                    // Decided on a fresh status block, not one from before the steps ran.
                    let mut reads = self.handle.watch_reads();
                    let read =
                        tokio::time::timeout(std::time::Duration::from_secs(1), reads.next()).await;
                    if matches!(read, Ok(Err(_))) {
                        return Next::Stopped;
                    }
                }
                let met = Inputs::read(&self.handle, &until.reads())
                    .await
                    .meet(&until);
                Next::Go(if met { pc + 1 } else { to })
            }
        }
    }

    fn motion(pc: usize, end: MotionEnd) -> Next {
        match end {
            MotionEnd::Done => Next::Go(pc + 1),
            MotionEnd::Held { why } => Next::Hold(why),
            MotionEnd::Failed { why } => Next::Fault(why),
            MotionEnd::StoppedNow => Next::Stopped,
        }
    }

    fn note_moves(&self, ids: &[u64]) {
        self.set(|s| {
            s.moves.extend_from_slice(ids);
            let extra = s.moves.len().saturating_sub(MOVES_SHOWN);
            s.moves.drain(..extra);
        });
    }
}

/// Waits until the incident count is other than `epoch`: the last incident, in words.
async fn until_incident(incidents: &mut watch::Receiver<Snapshot>, epoch: u64) -> String {
    loop {
        {
            let now = &incidents.borrow_and_update().incidents;
            if now.count != epoch {
                return now.last.clone().unwrap_or_default();
            }
        }
        if incidents.changed().await.is_err() {
            // The robot's worker is gone: nothing more comes.
            std::future::pending::<()>().await;
        }
    }
}
