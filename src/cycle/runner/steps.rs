//! The ops: what each asks of the driver, the motions prepared ahead of it, and how what came
//! of it moves the program counter.

use super::{Action, Event, Motion, MotionEnd, Next, Phase, Prepared, Runner, Seen, Then, WaitEnd};
use crate::cycle::check::{LoopExit, OpKind};

impl<G> Runner<G> {
    /// Op `pc` begins.
    pub(super) fn begin(&mut self, seen: &Seen) -> Action<G> {
        let pc = self.pc;
        self.phase = super::Phase::Op;
        let hold = seen.control.hold();
        match self.ops[pc].kind.clone() {
            OpKind::Move(_) | OpKind::Path(_)
                if self.ahead.front().is_some_and(|(at, _)| *at == pc) =>
            {
                if let Some(why) = hold {
                    // Held from outside the PLC (move-enable dropped): its gate shuts, as a
                    // motion not prepared is not queued.
                    return self.next(Next::Hold(why.to_owned()), seen);
                }
                let (_, prepared) = self.ahead.pop_front().expect("just seen");
                self.phase = Phase::Released(prepared.ids);
                Action::Release(prepared.gate)
            }
            OpKind::Move(_) | OpKind::Path(_) | OpKind::PalletPath { .. } if hold.is_some() => {
                let why = hold.unwrap_or_default().to_owned();
                self.followed(MotionEnd::Held { why }, seen)
            }
            OpKind::Move(order) => Action::Submit(Motion::Move(order, self.ops[pc].permit)),
            OpKind::Path(order) => Action::Submit(Motion::Path(order, self.ops[pc].permit)),
            OpKind::PalletPath {
                pallet,
                leg,
                speed_mm_s,
            } => Action::Submit(Motion::Pallet {
                pallet,
                leg,
                speed_mm_s,
            }),
            OpKind::Pallet { pallet, act } => Action::Pallet { pallet, act },
            OpKind::Skip { unless, .. } => Action::Decide(unless),
            OpKind::Wait { .. } => self.prepare(pc, Then::Wait, seen),
            OpKind::Set(writes) => Action::Write(writes),
            OpKind::Dwell(d) => self.prepare(pc, Then::Dwell(d), seen),
            OpKind::Loop { to, exit } => self.loop_op(to, exit, seen),
        }
    }

    /// Loop op `self.pc`, back to op `to` until `exit`.
    fn loop_op(&mut self, to: usize, exit: LoopExit, seen: &Seen) -> Action<G> {
        let pc = self.pc;
        match exit {
            LoopExit::Count(n) => {
                let ran = self.round.loops.entry(pc).or_insert(1);
                if *ran < n {
                    *ran += 1;
                    self.back_to(to, seen)
                } else {
                    self.round.loops.remove(&pc);
                    self.next(Next::Go(pc + 1), seen)
                }
            }
            LoopExit::Stop => self.back_to(to, seen),
            LoopExit::Until(until) => Action::Decide(until),
        }
    }

    /// What came of op `pc`'s action.
    pub(super) fn answer(&mut self, event: Event<G>, seen: &Seen) -> Action<G> {
        let pc = self.pc;
        let next = match event {
            Event::Queued(ids) if matches!(self.ops[pc].kind, OpKind::PalletPath { .. }) => {
                return Action::Follow(ids);
            }
            Event::Queued(ids) => return self.prepare(pc, Then::Follow(ids), seen),
            Event::Refused(why) => {
                let why = format!("refused: {why}");
                return self.followed(MotionEnd::Failed { why }, seen);
            }
            Event::Prepared(prepared) => return self.prepared(prepared),
            Event::Followed(end) => return self.followed(end, seen),
            Event::Waited { end, waited_s } => self.waited(end, waited_s),
            Event::Written(None)
            | Event::Counted(None)
            | Event::Dwelt(true)
            | Event::Decided(Some(true)) => Next::Go(pc + 1),
            Event::Written(Some(why)) | Event::Counted(Some(why)) | Event::Incident(why) => {
                Next::Fault(why)
            }
            Event::Decided(Some(false)) if let OpKind::Skip { to, .. } = self.ops[pc].kind => {
                Next::Go(to)
            }
            Event::Dwelt(false) | Event::Decided(None) | Event::Paced(false) => Next::Stopped,
            Event::Decided(Some(false)) => return self.back_to(self.loop_to(), seen),
            Event::Paced(true) => Next::Go(self.loop_to()),
            Event::Go | Event::Changed => return Action::Stand,
        };
        self.next(next, seen)
    }

    /// Jumps back to op `to`: at the pace of the status reads when the steps from there to
    /// here take no time (outputs, conditions), not as fast as the runtime can spin.
    fn back_to(&mut self, to: usize, seen: &Seen) -> Action<G> {
        if self.takes_time(to, self.pc) {
            self.next(Next::Go(to), seen)
        } else {
            Action::Pace
        }
    }

    /// The op loop op `pc` jumps to.
    fn loop_to(&self) -> usize {
        match self.ops[self.pc].kind {
            OpKind::Loop { to, .. } => to,
            _ => self.pc + 1,
        }
    }

    /// Whether ops `from..=to` include one that takes time (a motion, a wait, a dwell).
    fn takes_time(&self, from: usize, to: usize) -> bool {
        self.ops[from..=to].iter().any(|op| {
            matches!(
                op.kind,
                OpKind::Move(_)
                    | OpKind::Path(_)
                    | OpKind::PalletPath { .. }
                    | OpKind::Wait { .. }
                    | OpKind::Dwell(_)
            )
        })
    }

    fn waited(&mut self, end: WaitEnd, waited_s: f64) -> Next {
        self.round.waited_s += waited_s;
        let OpKind::Wait {
            until, on_timeout, ..
        } = &self.ops[self.pc].kind
        else {
            return Next::Go(self.pc + 1);
        };
        match (end, on_timeout) {
            (WaitEnd::Met, _) => Next::Go(self.pc + 1),
            (WaitEnd::TimedOut, Some(to)) => Next::Go(*to),
            (WaitEnd::TimedOut, None) => {
                Next::Fault(format!("wait for {until} timed out after {waited_s:.1} s"))
            }
            (WaitEnd::StoppedNow, _) => Next::Stopped,
            // The pause at the top takes it; the wait runs again on resume.
            (WaitEnd::Paused, _) => Next::Go(self.pc),
        }
    }

    /// How op `pc`'s motion ended.
    fn followed(&mut self, end: MotionEnd, seen: &Seen) -> Action<G> {
        let next = match (end, &self.ops[self.pc].kind) {
            (MotionEnd::NotStarted, _) => {
                // Cancelled before its start: run afresh at its step.
                self.phase = Phase::Top;
                let unprepare = self.unprepare();
                if unprepare.is_empty() {
                    return self.top(seen);
                }
                return Action::Unprepare(unprepare);
            }
            (MotionEnd::Held { why }, OpKind::Move(order)) if order.by.is_some() => {
                Next::Fault(format!(
                    "{why}; a move `by` an offset is not resumed mid-way (its target depended \
                     on where it began)"
                ))
            }
            (MotionEnd::Held { why }, OpKind::Path(_)) => Next::Fault(format!(
                "{why}; a path is not resumed mid-way (it would not be the path planned)"
            )),
            (MotionEnd::Done, _) => Next::Go(self.pc + 1),
            (MotionEnd::Held { why }, _) => Next::Hold(why),
            (MotionEnd::Failed { why }, _) => Next::Fault(why),
            (MotionEnd::StoppedNow, _) => Next::Stopped,
        };
        self.next(next, seen)
    }

    /// Prepares the next motions after op `after` up to one that moves, unless a stop, a
    /// pause or a hold is asked for; then `then`.
    pub(super) fn prepare(&mut self, after: usize, then: Then, seen: &Seen) -> Action<G> {
        self.phase = Phase::Op;
        self.then = Some((after, then));
        if !seen.control.runs() {
            return self.then();
        }
        self.prepare_next()
    }

    /// The motion prepared (`None`: refused now, left to run at its step), and the next.
    fn prepared(&mut self, prepared: Option<Prepared<G>>) -> Action<G> {
        match (prepared, self.next_to_prepare()) {
            (Some(prepared), Some(at)) => {
                self.ahead.push_back((at, prepared));
                self.prepare_next()
            }
            _ => self.then(),
        }
    }

    fn prepare_next(&mut self) -> Action<G> {
        let Some(at) = self.next_to_prepare() else {
            return self.then();
        };
        let permit = self.ops[at].permit;
        let motion = match &self.ops[at].kind {
            OpKind::Move(order) => Motion::Move(order.clone(), permit),
            OpKind::Path(order) => Motion::Path(order.clone(), permit),
            _ => return self.then(),
        };
        Action::Prepare { at, motion }
    }

    /// The op whose motion is to be prepared next, if one is.
    fn next_to_prepare(&self) -> Option<usize> {
        let (from, _) = self.then.as_ref()?;
        // Never round the program more than once: a motion's step is prepared once.
        let room =
            self.ahead.len() < self.ops.len() && self.ahead.back().is_none_or(|(_, p)| !p.moves);
        if !room {
            return None;
        }
        let after = self.ahead.back().map_or(*from, |(at, _)| *at);
        let at = self.next_motion(after)?;
        let fresh = at != *from && !self.ahead.iter().any(|(a, _)| *a == at);
        fresh.then_some(at)
    }

    /// What follows the moves prepared.
    fn then(&mut self) -> Action<G> {
        match self.then.take().map(|(_, then)| then) {
            Some(Then::Follow(ids)) => Action::Follow(ids),
            Some(Then::Dwell(d)) => Action::Dwell(d),
            Some(Then::Wait) => match &self.ops[self.pc].kind {
                OpKind::Wait { until, timeout, .. } => Action::Wait {
                    at: self.ops[self.pc].at.clone(),
                    until: until.clone(),
                    timeout: *timeout,
                },
                _ => Action::Stand,
            },
            None => Action::Stand,
        }
    }

    /// The next motion the cycle comes to after op `pc` through outputs, waits and dwells only
    /// (round to the first op when another cycle follows, on through a loop that always goes
    /// back): its op, if it can be prepared: a move to a pose, a position or joints (not `by`
    /// an offset), or a path op (a `path` step, a run of blended moves; not a pallet's way,
    /// whose slot is known only at its step). It begins where the motion before it is
    /// planned to end: that one is queued (or prepared) before this is asked for.
    fn next_motion(&self, pc: usize) -> Option<usize> {
        let ops = &self.ops;
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
                OpKind::Path(_) if at != pc => return Some(at),
                _ => return None,
            }
        }
        None
    }
}
