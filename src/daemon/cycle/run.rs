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

use std::collections::HashMap;
use std::time::Instant;

use tokio::sync::watch;

use super::act::{self, Inputs, MotionEnd, WaitEnd};
use super::control::Control;
use super::slot::SharedStatus;
use super::status::{CycleState, CycleStatus};
use crate::cycle::{Checked, LoopExit, OpKind};
use crate::daemon::RobotHandle;

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
    let mut runner = Runner {
        handle,
        program,
        count,
        control,
        status,
        resumes: 0,
    };
    let end = runner.cycles().await;
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
    handle: RobotHandle,
    program: Checked,
    count: Option<u64>,
    control: watch::Receiver<Control>,
    status: SharedStatus,
    /// Resumes seen.
    resumes: u64,
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
        let mut done = 0u64;
        loop {
            let c = *self.control.borrow();
            if c.stop || c.stop_now {
                return (CycleState::Stopped, Some("stopped by request".to_owned()));
            }
            if c.pause {
                self.set(|s| {
                    s.state = CycleState::Paused;
                    s.reason = Some(c.hold.unwrap_or("paused by request").to_owned());
                });
                if !self.until_resumed().await {
                    return (CycleState::Stopped, Some("stopped by request".to_owned()));
                }
            }
            if pc == self.program.ops.len() {
                done += 1;
                let took = began.elapsed().as_secs_f64();
                self.handle.cycle_done(took);
                self.set(|s| {
                    s.done = done;
                    s.last_cycle_s = Some(took);
                });
                if self.count.is_some_and(|n| done >= n) {
                    return (CycleState::Done, None);
                }
                pc = 0;
                loops.clear();
                began = Instant::now();
                continue;
            }
            let at = self.program.ops[pc].at.clone();
            self.set(|s| {
                s.state = CycleState::Running;
                s.step = Some(at);
                s.reason = None;
                s.stopping = c.stop;
            });
            match self.op(pc, &mut loops).await {
                Next::Go(next) => pc = next,
                Next::Stopped => {
                    return (
                        CycleState::Stopped,
                        Some("stopped now by request".to_owned()),
                    );
                }
                Next::Hold(why) => {
                    tracing::warn!(robot = %self.handle.robot().name, "cycle held: {why}");
                    self.set(|s| {
                        s.state = CycleState::Paused;
                        s.reason = Some(why);
                    });
                    if !self.until_resumed().await {
                        return (CycleState::Stopped, Some("stopped by request".to_owned()));
                    }
                }
                Next::Fault(why) => {
                    tracing::warn!(robot = %self.handle.robot().name, "cycle faulted: {why}");
                    let _ = self.handle.stop_robot().await;
                    self.set(|s| {
                        s.state = CycleState::Faulted;
                        s.reason = Some(why);
                        s.waiting_for = None;
                        s.waiting_s = None;
                    });
                    if !self.until_resumed().await {
                        return (CycleState::Stopped, Some("stopped by request".to_owned()));
                    }
                }
            }
        }
    }

    /// Waits for a resume: `false` when a stop came instead.
    async fn until_resumed(&mut self) -> bool {
        loop {
            {
                let c = *self.control.borrow_and_update();
                if c.stop || c.stop_now {
                    return false;
                }
                if c.resumes > self.resumes {
                    self.resumes = c.resumes;
                    return true;
                }
            }
            if self.control.changed().await.is_err() {
                return false;
            }
        }
    }

    async fn op(&mut self, pc: usize, loops: &mut HashMap<usize, u64>) -> Next {
        let kind = self.program.ops[pc].kind.clone();
        match kind {
            OpKind::Move(order) => {
                let relative = order.by.is_some();
                let mut started = Vec::new();
                let end = act::run_move(&self.handle, order, &mut self.control, &mut started).await;
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
            } => self.wait(pc, &until, timeout, on_timeout).await,
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
                    let _ =
                        tokio::time::timeout(std::time::Duration::from_secs(1), reads.changed())
                            .await;
                }
                next
            }
        }
    }

    /// A wait step: until its condition holds, at most `timeout`. A move right after it (to a
    /// pose, a position or joints) is prepared meanwhile: uploaded now and started as soon as
    /// the wait is met, so the robot moves one status read and a start after the input.
    async fn wait(
        &mut self,
        pc: usize,
        until: &crate::cycle::Condition,
        timeout: Option<std::time::Duration>,
        on_timeout: Option<usize>,
    ) -> Next {
        let gate = crate::daemon::gate::Gate::new();
        let prepared = match self.program.ops.get(pc + 1).map(|op| &op.kind) {
            Some(OpKind::Move(order)) if order.by.is_none() => {
                self.handle.submit_gated(order.clone(), &gate).ok()
            }
            _ => None,
        };
        let (next, met) = self.wait_only(pc, until, timeout, on_timeout).await;
        let Some(id) = prepared else {
            return next;
        };
        if met {
            gate.open();
            return self.prepared(pc + 1, id).await;
        }
        gate.shut();
        let _ = self
            .handle
            .wait(id, std::time::Duration::from_secs(30))
            .await;
        next
    }

    /// The move of op `at`, prepared during the wait before it and released: followed to its
    /// end; run afresh when it was cancelled before its start.
    async fn prepared(&mut self, at: usize, id: u64) -> Next {
        let step = self.program.ops[at].at.clone();
        self.set(|s| {
            s.state = CycleState::Running;
            s.step = Some(step);
        });
        let mut started = Vec::new();
        let end = act::follow(&self.handle, &[id], &mut self.control, &mut started).await;
        let cancelled_before_start = self.handle.report(id).is_some_and(|r| {
            r.error
                .as_deref()
                .is_some_and(|e| e.starts_with(crate::daemon::worker::PREPARED_CANCELLED))
        });
        if cancelled_before_start {
            return Next::Go(at);
        }
        self.note_moves(&started);
        Self::motion(at, end)
    }

    /// A wait step alone: what comes next, and whether its condition was met.
    async fn wait_only(
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
                    let _ =
                        tokio::time::timeout(std::time::Duration::from_secs(1), reads.changed())
                            .await;
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
