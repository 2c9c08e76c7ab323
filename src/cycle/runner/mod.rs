//! PURE. The cycle runner's decisions: a checked program's program counter, its loops, its
//! cycles, the motions it prepares ahead and what ends it, as a machine that takes what came of
//! its last action (an [`Event`]) with what it sees now ([`Seen`]: the control, the PLC's
//! incidents, the time) and returns the next [`Action`]. It does no IO and reads no clock;
//! `daemon`'s cycle driver carries the actions out through the robot's handle.
//!
//! ```text
//!            Event::Go
//!   Top ---- stop asked ------------------------------------------> End(stopped)
//!    |  ---- an incident since the epoch -------------------------> Fault -> Standing
//!    |  ---- pause or hold asked ---------------------------------> Pause -> Standing
//!    |  ---- past the last op: CycleDone -> Top (or End(done))
//!    v
//!   Step(at) -> the op: Submit / Release, Prepare*, Follow | Prepare*, Wait | Write |
//!               Prepare*, Dwell | Decide, Pace  -> Top at the next op, Pause (held), Fault, End (stopped now)
//!   Standing: a resume -> Top at the same op; a stop -> End; an incident -> Fault (named)
//! ```
//!
//! What ends a step other than done: a move held by the PLC pauses the cycle on that step (a
//! `by` move and a path fault instead: their target or course depended on where they began);
//! anything else faults it, and it goes on only after a resume, with that step again.
//!
//! The next motion is prepared ahead: while a move or a path runs, or a wait or a dwell
//! waits, the next move step or path op (a `path` step, a run of blended moves) the cycle
//! comes to through outputs, waits and dwells only (round to the next cycle) is uploaded
//! behind it and held; it is released when the runner reaches its step. It is asked for only
//! once the motion before it is queued (or there is none), so it is planned from where that
//! one is planned to end. (A move to where the robot will already be has no motion of its
//! own: the one after it is prepared too.) Anything else the cycle does first (another
//! motion, a fault, a hold, a pause, a stop, its end) unprepares it; a motion cancelled
//! before its start is run afresh at its step.

mod control;
mod steps;
#[cfg(test)]
mod tests;

use std::collections::{HashMap, VecDeque};
use std::time::{Duration, Instant};

pub use control::{Ask, Control, MotionEnd, WaitEnd};

use super::check::{Checked, Leg, Op, OpKind, PalletAct};
use super::condition::Condition;
use crate::contract::Permit;
use crate::gateway::{Address, Values};
use crate::order::{MoveOrder, PathOrder};
use crate::wire::{CycleState, MoveId, StepAt};

/// What the runner sees as it decides: the control asked for, the PLC's incidents, the time.
#[derive(Debug, Clone, PartialEq)]
pub struct Seen {
    /// The control now.
    pub control: Control,
    /// The PLC's incident count now (restarts, stalls and PROG mode, links lost past a move's
    /// end).
    pub incidents: u64,
    /// The last incident, in words.
    pub last_incident: Option<String>,
    /// How many of the incidents were restarts of the PLC (its outputs went off, a gripper
    /// let go wherever the robot was).
    pub restarts: u64,
    /// Now.
    pub now: Instant,
}

/// A motion prepared ahead: its starts, whether it moves the robot, and the driver's handle on
/// it (`G`: its start gate).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Prepared<G> {
    /// Its starts, in order: one for a move; a path's sections and their parts, the first
    /// held behind the gate and the rest queued behind it.
    pub ids: Vec<MoveId>,
    /// Whether it moves the robot (planned to end more than a pulse from where it begins).
    pub moves: bool,
    /// What releases it, or unprepares it.
    pub gate: G,
}

/// What the runner asks of its driver. Each is answered by the [`Event`] it names
/// ([`Event::Go`] where nothing is said).
#[derive(Debug, Clone, PartialEq)]
pub enum Action<G> {
    /// The cycle runs at this step (its status says so).
    Step(StepAt),
    /// Queue this motion: [`Event::Queued`] or [`Event::Refused`].
    Submit(Motion),
    /// Upload op `at`'s motion ahead, held behind its gate: [`Event::Prepared`].
    Prepare {
        /// Its op.
        at: usize,
        /// Its motion, with its permit: a move or a path, never a pallet's way.
        motion: Motion,
    },
    /// Release a move prepared ahead (its gate opens).
    Release(G),
    /// Follow every start to its end: [`Event::Followed`].
    Follow(Vec<MoveId>),
    /// Unprepare these moves (their gates shut) and wait for them to end.
    Unprepare(Vec<Prepared<G>>),
    /// Wait until the condition holds, at most `timeout`: [`Event::Waited`].
    Wait {
        /// The step (metrics).
        at: StepAt,
        /// The condition.
        until: Condition,
        /// The longest it may take.
        timeout: Option<Duration>,
    },
    /// Write these outputs, in order: [`Event::Written`].
    Write(Vec<(Address, Values)>),
    /// Sleep that long (a stop ends it): [`Event::Dwelt`].
    Dwell(Duration),
    /// Decide a loop's condition on a fresh status block: [`Event::Decided`].
    Decide(Condition),
    /// Change a pallet's counter, on disk before the answer: [`Event::Counted`].
    Pallet {
        /// The pallet.
        pallet: String,
        /// The change.
        act: PalletAct,
    },
    /// Let one status read pass before going round a loop whose steps take no time:
    /// [`Event::Paced`].
    Pace,
    /// A cycle ended (its status and metrics say so).
    CycleDone {
        /// Cycles done in all.
        done: u64,
        /// How long it took, s.
        took_s: f64,
        /// How long its waits waited, s.
        waited_s: f64,
    },
    /// Pause: the moves prepared ahead unprepared first; then stand, [`Event::Changed`].
    Pause {
        /// Why.
        why: String,
        /// The moves prepared ahead.
        unprepare: Vec<Prepared<G>>,
    },
    /// Fault: the robot stopped (`stop_robot`), the pallets' slots in progress made unsure
    /// (`interrupted`), the moves prepared ahead unprepared first; then stand,
    /// [`Event::Changed`].
    Fault {
        /// Why.
        why: String,
        /// Whether the robot is to be stopped (not when a standing cycle is faulted).
        stop_robot: bool,
        /// Whether the PLC restarted since the cycle began or last faulted: a place under way
        /// may have been cut short, so every pallet's slot in progress is unsure.
        interrupted: bool,
        /// The moves prepared ahead.
        unprepare: Vec<Prepared<G>>,
    },
    /// Stand as it is until the control changes ([`Event::Changed`]) or an incident comes
    /// since [`Runner::incident_mark`] ([`Event::Incident`]).
    Stand,
    /// The cycle has ended, in this state: the moves prepared ahead unprepared first.
    End {
        /// Its final state.
        state: CycleState,
        /// Why.
        why: Option<String>,
        /// The moves prepared ahead.
        unprepare: Vec<Prepared<G>>,
    },
}

/// A motion to queue.
#[derive(Debug, Clone, PartialEq)]
pub enum Motion {
    /// A move, with its permit (resolved when the program was checked).
    Move(MoveOrder, Permit),
    /// A path, with its permit (resolved when the program was checked).
    Path(PathOrder, Permit),
    /// The way into or out of a pallet's slot in progress, from where the robot is.
    Pallet {
        /// The pallet.
        pallet: String,
        /// Into the slot or out of it.
        leg: Leg,
        /// The speed where the pattern gives none, mm/s.
        speed_mm_s: Option<f64>,
    },
}

/// What came of the runner's last action.
#[derive(Debug, Clone, PartialEq)]
pub enum Event<G> {
    /// Begin, or an action that answers nothing was carried out.
    Go,
    /// The motion was queued: its starts.
    Queued(Vec<MoveId>),
    /// The motion was refused.
    Refused(String),
    /// The motion of op `at` was prepared (`None`: the robot refused it now; it runs at its
    /// step).
    Prepared(Option<Prepared<G>>),
    /// The starts followed ended so.
    Followed(MotionEnd),
    /// The wait ended so, after waiting `waited_s`.
    Waited {
        /// How.
        end: WaitEnd,
        /// How long, s.
        waited_s: f64,
    },
    /// The outputs were written (`Some`: one was not, why).
    Written(Option<String>),
    /// The dwell slept the whole time (`false`: a stop ended it).
    Dwelt(bool),
    /// The loop's condition: met or not (`None`: nothing more is read, the robot's worker is
    /// gone).
    Decided(Option<bool>),
    /// The pallet's counter changed and is on disk (`Some`: it did not, why).
    Counted(Option<String>),
    /// A status read passed (`false`: the robot's worker is gone).
    Paced(bool),
    /// An incident came since [`Runner::incident_mark`], in words.
    Incident(String),
    /// The control changed (while standing).
    Changed,
}

/// Where the runner is.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Phase {
    /// At the top of op `pc`: stops, incidents, pauses and the cycle's end looked at first.
    Top,
    /// Op `pc`'s step said: the op begins.
    Entered,
    /// Op `pc`'s motion, prepared ahead, was released (its starts): the next prepared, then
    /// followed.
    Released(Vec<MoveId>),
    /// Waiting for what came of op `pc`'s action.
    Op,
    /// The last cycle ended: the run ends done.
    Finished,
    /// Paused or faulted, until a resume.
    Standing,
    /// Ended.
    Ended,
}

/// What follows the moves prepared ahead.
#[derive(Debug, Clone, PartialEq)]
enum Then {
    /// Follow these starts.
    Follow(Vec<MoveId>),
    /// Begin op `pc`'s wait.
    Wait,
    /// Begin op `pc`'s dwell, this long.
    Dwell(Duration),
}

/// How an op ended.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Next {
    /// Go on at this op.
    Go(usize),
    /// Pause on this op.
    Hold(String),
    /// Stop the robot and fault on this op.
    Fault(String),
    /// A stop now: end.
    Stopped,
}

/// The cycle under way: its loops' counts, when it began, how long its waits waited.
#[derive(Debug, Clone)]
struct Round {
    loops: HashMap<usize, u64>,
    began: Instant,
    waited_s: f64,
}

/// The incident counts the runner acts under.
#[derive(Debug, Clone, Copy)]
struct Marks {
    /// The incident count the cycle acts under: from its start, or the fault clear it was
    /// resumed after. Any incident since faults it, whatever it is doing.
    epoch: u64,
    /// The incident count the status last named.
    reported: u64,
    /// Resumes taken.
    resumes: u64,
    /// The PLC's restarts when the cycle began or last faulted.
    restarts: u64,
}

/// A checked program run `count` times (or until stopped), one decision at a time.
#[derive(Debug, Clone)]
pub struct Runner<G> {
    ops: Vec<Op>,
    count: Option<u64>,
    pc: usize,
    done: u64,
    round: Round,
    /// The next motions, prepared ahead, in the order the cycle comes to them: one that moves,
    /// and before it any that do not; with the op each is for.
    ahead: VecDeque<(usize, Prepared<G>)>,
    /// What follows the moves being prepared, and the op they are prepared after.
    then: Option<(usize, Then)>,
    marks: Marks,
    phase: Phase,
}

impl<G> Runner<G> {
    /// A run of `program`, `count` times (or until stopped), beginning as `seen` shows (its
    /// time, and the PLC's incidents and restarts it acts under). Its first action comes from
    /// [`Event::Go`].
    #[must_use]
    pub fn new(program: Checked, count: Option<u64>, seen: &Seen) -> Self {
        Self {
            ops: program.ops,
            count,
            pc: 0,
            done: 0,
            round: Round {
                loops: HashMap::new(),
                began: seen.now,
                waited_s: 0.0,
            },
            ahead: VecDeque::new(),
            then: None,
            marks: Marks {
                epoch: seen.incidents,
                reported: seen.incidents,
                resumes: 0,
                restarts: seen.restarts,
            },
            phase: Phase::Top,
        }
    }

    /// The incident count the cycle acts under: what the robot refuses for it once another
    /// incident came.
    #[must_use]
    pub fn epoch(&self) -> u64 {
        self.marks.epoch
    }

    /// The incident count an incident is counted from: the epoch while the cycle runs, the
    /// count its status last named while it stands.
    #[must_use]
    pub fn incident_mark(&self) -> u64 {
        if self.phase == Phase::Standing {
            self.marks.reported
        } else {
            self.marks.epoch
        }
    }

    /// Whether the cycle has ended.
    #[must_use]
    pub fn ended(&self) -> bool {
        self.phase == Phase::Ended
    }

    /// The op the runner is at (0 at the start; the program's length past its last).
    #[must_use]
    pub fn pc(&self) -> usize {
        self.pc
    }

    /// What came of the last action, seen with `seen`: the next action.
    pub fn on(&mut self, event: Event<G>, seen: &Seen) -> Action<G> {
        match (self.phase.clone(), event) {
            (Phase::Ended, _) => self.end(CycleState::Stopped, None),
            (Phase::Standing, Event::Incident(why)) => {
                self.marks.reported = seen.incidents;
                Action::Fault {
                    why,
                    stop_robot: false,
                    interrupted: self.restarted(seen),
                    unprepare: Vec::new(),
                }
            }
            (Phase::Standing, _) => self.standing(seen),
            (Phase::Top, _) => self.top(seen),
            (Phase::Finished, _) => self.end(CycleState::Done, None),
            (Phase::Entered, _) => self.begin(seen),
            (Phase::Released(ids), _) => self.prepare(self.pc, Then::Follow(ids), seen),
            (Phase::Op, Event::Incident(why)) => self.next(Next::Fault(why), seen),
            (Phase::Op, event) => self.answer(event, seen),
        }
    }

    /// At the top of op `pc`.
    fn top(&mut self, seen: &Seen) -> Action<G> {
        let c = seen.control;
        if c.stops() {
            return self.end(CycleState::Stopped, Some("stopped by request"));
        }
        if seen.incidents != self.marks.epoch {
            let why = seen.last_incident.clone().unwrap_or_default();
            return self.fault(why, seen);
        }
        if let Some(why) = c.pause() {
            return self.pause(why.to_owned());
        }
        if self.pc == self.ops.len() {
            return self.cycle_done(seen.now);
        }
        let motion = matches!(self.ops[self.pc].kind, OpKind::Move(_) | OpKind::Path(_));
        if motion && self.ahead.front().is_some_and(|(at, _)| *at != self.pc) {
            return Action::Unprepare(self.unprepare());
        }
        self.phase = Phase::Entered;
        Action::Step(self.ops[self.pc].at.clone())
    }

    /// Past the last op: a cycle done, and the next begins (or the run ends done).
    fn cycle_done(&mut self, now: Instant) -> Action<G> {
        self.done += 1;
        let took_s = now
            .saturating_duration_since(self.round.began)
            .as_secs_f64();
        let waited_s = std::mem::take(&mut self.round.waited_s);
        if self.count.is_some_and(|n| self.done >= n) {
            self.phase = Phase::Finished;
        } else {
            self.pc = 0;
            self.round.loops.clear();
            self.round.began = now;
        }
        Action::CycleDone {
            done: self.done,
            took_s,
            waited_s,
        }
    }

    /// How op `pc` ended: on to the next, or a pause, a fault, the end.
    fn next(&mut self, next: Next, seen: &Seen) -> Action<G> {
        match next {
            Next::Go(at) => {
                self.pc = at;
                self.phase = Phase::Top;
                self.top(seen)
            }
            Next::Hold(why) => self.pause(why),
            Next::Fault(why) => self.fault(why, seen),
            Next::Stopped => self.end(CycleState::Stopped, Some("stopped now by request")),
        }
    }

    fn pause(&mut self, why: String) -> Action<G> {
        self.phase = Phase::Standing;
        Action::Pause {
            why,
            unprepare: self.unprepare(),
        }
    }

    fn fault(&mut self, why: String, seen: &Seen) -> Action<G> {
        self.phase = Phase::Standing;
        self.marks.reported = seen.incidents;
        Action::Fault {
            why,
            stop_robot: true,
            interrupted: self.restarted(seen),
            unprepare: self.unprepare(),
        }
    }

    /// Whether the PLC restarted since the cycle began or last faulted (counted from now on).
    fn restarted(&mut self, seen: &Seen) -> bool {
        std::mem::replace(&mut self.marks.restarts, seen.restarts) != seen.restarts
    }

    fn end(&mut self, state: CycleState, why: Option<&str>) -> Action<G> {
        self.phase = Phase::Ended;
        Action::End {
            state,
            why: why.map(str::to_owned),
            unprepare: self.unprepare(),
        }
    }

    /// Standing: a stop ends the cycle, a resume goes on at the op it stood at.
    fn standing(&mut self, seen: &Seen) -> Action<G> {
        let c = seen.control;
        if c.stops() {
            return self.end(CycleState::Stopped, Some("stopped by request"));
        }
        if c.resumes > self.marks.resumes {
            self.marks.resumes = c.resumes;
            if let Some(epoch) = c.epoch {
                // Resumed after a clear with no incident since: it acts under it now.
                self.marks.epoch = epoch;
                self.marks.reported = epoch;
            }
            self.phase = Phase::Top;
            return self.top(seen);
        }
        Action::Stand
    }

    /// Every move prepared ahead, taken out to be unprepared.
    fn unprepare(&mut self) -> Vec<Prepared<G>> {
        self.then = None;
        self.ahead.drain(..).map(|(_, p)| p).collect()
    }
}
