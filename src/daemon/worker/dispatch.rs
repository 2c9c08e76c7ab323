//! PURE. The worker's decisions about the moves it was given, apart from the link: the queue
//! (whose turn, how long a turn may wait), one record per move given to the PLC ([`InFlight`]:
//! when it was seen starting, its permit, the start to write again, the moves that end with it,
//! the counts its report waits for), the sequence numbers and banks, and the contract's
//! [`Machine`]. It reads no clock (`now` is an argument), makes no exchange and publishes
//! nothing: what it decides comes back as values ([`Finish`], [`Turn`]) that the worker carries
//! out over its session and into the reports.
//!
//! ```text
//!   accept -> queue --turn--> Turn { mode: FromRest | Chained | Gated }
//!     --Activity: Uploading -> (Holding ->) Proving--start_written--> InFlight
//!   expire / cancel / drop_shut / in_place / settled / finished -> Finish (a report's end)
//! ```

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::contract::machine::{Blocker, Machine, Outcome, Planned, Status};
use crate::contract::{CHANNELS, Fault, Permit};
use crate::daemon::gate::{Gate, GateState};
use crate::order::{CheckedOrder, SectionOrder};
use crate::plc::exchange::{Preload, Upload, VerifiedBank, describe_outcome};
use crate::wire::{EndReason, MoveId, Stage};

mod next;
use next::Retry;
pub(super) use next::{Action, PollPace, Seen};

/// How a prepared move cancelled before its start begins its report's error: the cycle then runs
/// it as any move, after its wait.
pub(super) const PREPARED_CANCELLED: &str = "cancelled before its start";

/// Why a prepared move whose gate shut before its start was not started.
pub(super) const CYCLE_WENT_ON: &str =
    "its cycle went another way (a fault, a stop, a pause, a timeout)";

/// Why the moves queued behind one that did not start are cancelled.
const BEHIND_NOT_STARTED: &str = "cancelled: the move before it did not start";

/// The longest a stopped move's report waits for a block that shows the channels still.
const SETTLE_LIMIT: Duration = Duration::from_secs(1);

/// A stop asked for this recently stopped the moves that end stopped.
const STOP_ASKED_WINDOW: Duration = Duration::from_secs(2);

/// An order waiting its turn.
#[derive(Debug)]
pub(super) struct Queued {
    pub id: MoveId,
    pub order: CheckedOrder,
    pub gate: Option<Gate>,
    /// The incidents counted when its cycle asked for it (a cycle's move only).
    pub epoch: Option<u64>,
    pub accepted: Instant,
    /// Its tables, written and read back ahead of its turn (a part of a path chained at speed):
    /// the bank, where, and the words its start must match.
    pub preload: Option<Preloaded>,
    /// The first part of a path section cut into parts: whether it may begin behind the start
    /// running ([`Lead`]).
    pub lead: Lead,
}

/// Whether the first part of a path section cut into parts (its parts chained at speed) may
/// begin behind the start running, judged against that start by the worker
/// ([`Dispatcher::lead_to_judge`]). From rest, its parts are preloaded into both banks and the
/// link's pace measured before it starts (and refused if a part could not be ready in time);
/// behind a running start, the part before it is still in a bank, so every later part is
/// written at its turn, while the part before it runs, as the link has shown it can.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum Lead {
    /// Not judged: it waits for rest (judged when a start runs ahead of it).
    #[default]
    Unjudged,
    /// Judged behind start `seq`: only from rest (no pace known yet on this link, a part that
    /// could not be written while the part before it runs, a part that does not plan). Its
    /// second part may be preloaded meanwhile into the bank that start does not use
    /// ([`Dispatcher::ahead_due`]), itself to follow into the bank that start ran from.
    FromRest {
        /// The start it was judged behind.
        seq: u16,
        /// Whether its second part's preload was begun.
        ahead: bool,
    },
    /// Judged behind start `seq`: at the pace this link showed, each later part can be written,
    /// read back and started while the part before it runs; it begins behind that start.
    Behind {
        /// The start it was judged behind.
        seq: u16,
    },
}

impl Queued {
    /// Why a cycle's move is not begun: its cycle asked for it before the PLC restarted,
    /// stalled or was lost (`incidents` counted now, the `last` one in words).
    pub(super) fn stale(&self, incidents: u64, last: Option<&str>) -> Option<String> {
        self.epoch.filter(|&e| e != incidents).map(|_| {
            format!(
                "cancelled: {} since its cycle asked for it",
                last.unwrap_or_default()
            )
        })
    }
}

/// Tables written and read back ahead of their turn ([`Queued::preload`]).
#[derive(Debug)]
pub(super) struct Preloaded {
    /// The bank, where, and the words.
    pub tables: Preload,
    /// How long its exchanges took (the link's pace, for the parts after it).
    pub took: Duration,
}

/// A path's second part, preloaded into the bank the start running does not use while that
/// start runs, ahead of its first part's turn from rest ([`Dispatcher::ahead_due`]): one
/// exchange a step, the running start watched between them.
#[derive(Debug)]
pub(super) struct Ahead {
    /// The part.
    pub id: MoveId,
    /// Its exchanges.
    pub upload: Upload,
    /// What is preloaded once the last exchange is made.
    pub preload: Preload,
    /// How long its exchanges took so far.
    pub took: Duration,
    /// How often the status block is read between two of them.
    pub every: Duration,
}

/// A path's second part to preload ahead ([`Dispatcher::ahead_due`]).
#[derive(Debug)]
pub(super) struct AheadDue {
    /// The second part's id.
    pub id: MoveId,
    /// The first part's order (its section's plans give the second's tables).
    pub first: CheckedOrder,
    /// The start running, the first part follows from rest.
    pub behind: Planned,
}

/// A part of a path section queued: its id and order.
pub(super) type Part = (MoveId, CheckedOrder);

/// How a move whose turn came is started.
#[derive(Debug, Clone)]
pub(super) enum StartMode {
    /// Nothing runs: planned from the counts the PLC reports, started from rest.
    FromRest,
    /// Behind the running start: planned from its targets, into the other bank, and started
    /// while it runs (the PLC takes it at that one's end).
    Chained(Planned),
    /// A cycle's prepared move: uploaded (behind `ahead` when a start runs, planned from its
    /// targets), held until `gate` opens, then started from rest.
    Gated {
        /// The start gate.
        gate: Gate,
        /// The start running when its turn came.
        ahead: Option<Planned>,
    },
}

impl StartMode {
    /// The start it is planned behind (its `from`, its bank's other), if any.
    pub(super) fn ahead(&self) -> Option<&Planned> {
        match self {
            Self::FromRest => None,
            Self::Chained(ahead) => Some(ahead),
            Self::Gated { ahead, .. } => ahead.as_ref(),
        }
    }

    /// The gate it is held behind, if any.
    pub(super) fn gate(&self) -> Option<&Gate> {
        match self {
            Self::Gated { gate, .. } => Some(gate),
            Self::FromRest | Self::Chained(_) => None,
        }
    }
}

/// A queued move whose turn came: what it is, how it starts, and the counts per channel it
/// begins from.
#[derive(Debug)]
pub(super) struct Turn {
    pub id: MoveId,
    pub order: CheckedOrder,
    pub mode: StartMode,
    pub from: [i32; CHANNELS],
    /// Its tables, if preloaded ahead of its turn.
    pub preload: Option<Preloaded>,
}

/// What became of the head of the queue when its turn was asked for.
#[derive(Debug)]
pub(super) enum TurnDecision {
    /// It begins.
    Begin(Box<Turn>),
    /// It stays at the head of the queue (the PLC does not take a start now, or it waits for
    /// the running move to end).
    Wait,
    /// Nothing planned or written: its permit does not hold (the host's own check, for a clear
    /// message; the PLC's check at the start is the one that counts).
    PermitNotMet(MoveId, Blocker),
    /// A part of a path that begins at speed, with nothing running to chain behind.
    NothingToChainBehind(MoveId),
}

/// What the worker is doing with the move whose turn came: one step of it each round of the
/// worker's loop, between which nothing else is taken (a stop aborts an upload between two of
/// its exchanges through the contract; a held bank takes in requests and serves the gateway).
#[derive(Debug, Default)]
pub(super) enum Activity {
    /// No move between its turn and its start: the loop serves requests, the queue, the status
    /// reads and the gateway.
    #[default]
    Idle,
    /// Its bank written and read back, one exchange a step, the start the PLC runs watched.
    Uploading(Box<Uploading>),
    /// A prepared move's bank, verified, held until its gate opens.
    Holding(Box<Uploaded>),
    /// A path's second part preloaded ahead of its first part's turn, one exchange a step.
    Preloading(Box<Ahead>),
    /// Its bank verified: reading the status block until the PLC may take its start (the
    /// heartbeat seen moving, the counts at its `from`); the next read not before this.
    Proving(Box<Uploaded>, Option<Instant>),
}

/// A move whose bank is being written.
#[derive(Debug)]
pub(super) struct Uploading {
    pub turn: Turn,
    pub planned: Planned,
    pub upload: Upload,
    /// When its turn's upload began (the preloads of a section's parts count).
    pub began: Instant,
    /// How often the status block is read between two of the upload's exchanges.
    pub every: Duration,
    /// Whether nothing ran when its turn came: it keeps the parts preloaded around it.
    pub from_rest: bool,
}

/// A move whose bank is written and verified, not yet started.
#[derive(Debug)]
pub(super) struct Uploaded {
    pub turn: Turn,
    pub planned: Planned,
    pub bank: VerifiedBank,
    /// How long its upload took, s.
    pub upload_s: f64,
}

/// What a held bank's step does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Hold {
    /// Start it: its gate opened and nothing runs ahead of it.
    Release,
    /// Cancel it before its start, for this reason.
    Cancel(&'static str),
    /// Hold it on.
    Wait,
}

impl Hold {
    /// A held bank whose gate is `gate` while a start `runs_ahead` of it: started from rest only,
    /// never chained behind the move still running ahead of it (the steps between, outputs and
    /// waits, come after that one's end).
    pub(super) fn on_gate(gate: GateState, runs_ahead: bool) -> Self {
        match gate {
            GateState::Open if !runs_ahead => Self::Release,
            GateState::Shut => Self::Cancel(CYCLE_WENT_ON),
            GateState::Open | GateState::Closed => Self::Wait,
        }
    }

    /// A held bank once the worker took in what was sent: anything but the gateway and the
    /// status reads cancels it.
    pub(super) fn on_requests(shutting_down: bool, stopping: bool, commands: bool) -> Self {
        if shutting_down {
            Self::Cancel("the daemon is shutting down")
        } else if stopping {
            Self::Cancel("a stop was asked for")
        } else if commands {
            Self::Cancel("a command came (home, clear-fault)")
        } else {
            Self::Wait
        }
    }
}

/// A move with no motion of its own queued behind a running start (its lead): it ends with
/// that start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Follower {
    /// The move.
    id: MoveId,
    /// Its targets per channel: the lead's.
    targets: [i32; CHANNELS],
}

/// A move that stopped short, waiting for the status block that shows where the PLC stopped it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Settling {
    stage: Stage,
    why: String,
    /// The heartbeat of the block that showed its end.
    beat: u16,
    /// When that block was read.
    since: Instant,
}

/// One move given to the PLC (its start written, or found running), until its report ends.
#[derive(Debug, Default)]
pub(super) struct InFlight {
    id: MoveId,
    /// When it was seen starting; cleared when it ends.
    started: Option<Instant>,
    /// Its permit ([`Permit::NONE`]: it has none), to name the input that held it.
    permit: Permit,
    /// Its bank, for writing its start again after a lost reply: the last start written only.
    start: Option<VerifiedBank>,
    /// The moves with no motion of their own that end with it.
    followers: Vec<Follower>,
    /// It ended short; its report waits for the counts the PLC stopped at.
    settling: Option<Settling>,
}

/// A move's report to end: its stage, why, and its error to its targets per channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Finish {
    pub id: MoveId,
    pub stage: Stage,
    pub error: Option<String>,
    pub final_error: Option<[i64; CHANNELS]>,
    /// Why it ended, where the report says more than its stage (a prepared move cancelled
    /// before its start).
    pub end: Option<EndReason>,
}

impl Finish {
    fn new(id: MoveId, stage: Stage, error: impl Into<String>) -> Self {
        Self {
            id,
            stage,
            error: Some(error.into()),
            final_error: None,
            end: None,
        }
    }
}

/// A stopped move whose report can end now: its counts are the block's (`None`: last read).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Settled {
    pub id: MoveId,
    pub stage: Stage,
    pub why: String,
}

/// The worker's decisions (module docs).
#[derive(Debug)]
pub(super) struct Dispatcher {
    /// What every status block means.
    pub machine: Machine,
    queue: VecDeque<Queued>,
    /// Since when the head of the queue could have been given to the PLC but for a problem.
    room_since: Option<Instant>,
    /// How long a move may wait for its turn once the PLC has room for it.
    start_within: Duration,
    flights: Vec<InFlight>,
    next_seq: u16,
    next_bank: u16,
    /// When the last stop was asked for (a move stopped soon after was stopped by request).
    stop_asked: Option<Instant>,
    /// What is done with the move whose turn came.
    pub activity: Activity,
    /// How often the status block is read.
    pace: PollPace,
    /// When the status block is next to be read (`None`: now).
    next_poll: Option<Instant>,
    /// Whether a gateway exchange goes before the next status read, if both are due.
    gateway_turn: bool,
    /// Whether the PLC's mode is to be read (a poll found the robot at rest, its mode old).
    mode_due: bool,
    /// Whether the status block was just read (a held bank is checked on it).
    just_polled: bool,
    /// While the link is down: when it is next opened.
    retry: Retry,
}

impl Dispatcher {
    /// Nothing queued or in flight; `machine` knows nothing of the PLC yet; the status block
    /// read at `pace`.
    pub(super) fn new(machine: Machine, start_within: Duration, pace: PollPace) -> Self {
        Self {
            machine,
            queue: VecDeque::new(),
            room_since: None,
            start_within,
            flights: Vec::new(),
            next_seq: 1,
            next_bank: 0,
            stop_asked: None,
            activity: Activity::Idle,
            pace,
            next_poll: None,
            gateway_turn: false,
            mode_due: false,
            just_polled: false,
            retry: Retry::Now,
        }
    }

    /// How long a move may wait for its turn once the PLC has room for it.
    pub(super) fn start_within(&self) -> Duration {
        self.start_within
    }

    /// The queue, its head first.
    #[cfg(test)]
    pub(super) fn queue(&self) -> &VecDeque<Queued> {
        &self.queue
    }

    /// Queues `queued` behind the rest.
    pub(super) fn push(&mut self, queued: Queued) {
        self.queue.push_back(queued);
    }

    /// Queues one order's `starts` behind the rest, in order, accepted at `now` under `epoch`:
    /// only the first waits for `gate` (a cycle's motion prepared ahead); the starts behind it
    /// (a path's parts and sections) follow it as the path's own, and go with it if it never
    /// starts.
    pub(super) fn push_order(
        &mut self,
        starts: Vec<(MoveId, CheckedOrder)>,
        mut gate: Option<Gate>,
        epoch: Option<u64>,
        now: Instant,
    ) {
        for (id, order) in starts {
            self.push(Queued {
                id,
                order,
                gate: gate.take(),
                epoch,
                accepted: now,
                preload: None,
                lead: Lead::Unjudged,
            });
        }
    }

    /// Puts `queued` back at the head of the queue: its turn has not come.
    pub(super) fn push_front(&mut self, queued: Queued) {
        self.queue.push_front(queued);
    }

    /// Why a new order would not be given to the PLC now (`link_up`: a session is open).
    pub(super) fn blocker(&self, link_up: bool, now: Instant) -> Option<Blocker> {
        if link_up {
            self.machine.blocker(now)
        } else {
            Some(Blocker::LinkDown)
        }
    }

    /// Whether the head of the queue can begin now: the PLC takes a start, and the head does
    /// not wait for the running move to end ([`Self::waits_for_rest`]).
    pub(super) fn has_room(&self, now: Instant) -> bool {
        let Some(head) = self.queue.front() else {
            return false;
        };
        self.machine.blocker(now).is_none() && !self.waits_for_rest(head)
    }

    /// Whether `queued` must wait for the running move to end: the first part of a section cut
    /// into parts begins from rest (its parts preloaded and paced before it starts), unless it
    /// was judged able to begin behind the start running ([`Lead::Behind`]).
    pub(super) fn waits_for_rest(&self, queued: &Queued) -> bool {
        queued.order.leads_parts()
            && self
                .machine
                .chain_behind()
                .is_some_and(|running| queued.lead != Lead::Behind { seq: running.seq })
    }

    /// The head of the queue, when it is the first part of a section cut into parts, not yet
    /// judged against the start running, and the PLC would take it: its id and the start it is
    /// to be judged behind (the worker plans its parts from that start's targets and weighs
    /// them against the link's pace, [`Self::judged`]).
    pub(super) fn lead_to_judge(&self, now: Instant) -> Option<(MoveId, Planned)> {
        let head = self.queue.front().filter(|q| q.order.leads_parts())?;
        let running = self.machine.chain_behind()?;
        let judged = match head.lead {
            Lead::Unjudged => None,
            Lead::FromRest { seq, .. } | Lead::Behind { seq } => Some(seq),
        };
        (judged != Some(running.seq) && self.machine.blocker(now).is_none())
            .then(|| (head.id, running.clone()))
    }

    /// The second part of the path whose first part heads the queue, to be preloaded now, while
    /// the start running runs, into the bank it does not use (the first part to follow from
    /// rest into the bank it ran from): when the first part waits for rest behind that start
    /// ([`Lead::FromRest`]), nothing is written behind it, and the second part was neither
    /// preloaded nor tried behind it. The first part is marked tried.
    pub(super) fn ahead_due(&mut self, now: Instant) -> Option<AheadDue> {
        let running = self.machine.chain_behind()?;
        if self.machine.uploading_behind().is_some() || self.machine.blocker(now).is_some() {
            return None;
        }
        let (head, second) = (self.queue.front()?, self.queue.get(1)?);
        let same = |q: &Queued| {
            q.order
                .section()
                .zip(head.order.section())
                .is_some_and(|(a, b)| Arc::ptr_eq(a, b))
        };
        let due = head.order.leads_parts()
            && head.lead
                == (Lead::FromRest {
                    seq: running.seq,
                    ahead: false,
                })
            && second.order.begins_at_speed()
            && same(second)
            && second.preload.is_none();
        if !due {
            return None;
        }
        let due = AheadDue {
            id: second.id,
            first: head.order.clone(),
            behind: running.clone(),
        };
        self.queue[0].lead = Lead::FromRest {
            seq: running.seq,
            ahead: true,
        };
        Some(due)
    }

    /// Queued move `id` (a section's first part) was judged: `lead`.
    pub(super) fn judged(&mut self, id: MoveId, lead: Lead) {
        if let Some(q) = self.queue.iter_mut().find(|q| q.id == id) {
            q.lead = lead;
        }
    }

    /// Whether `queued`, just taken from the head of the queue, begins now and how (the status
    /// block last read is fresh). One that does not begin now is put back at the head.
    pub(super) fn turn(&mut self, queued: Queued, now: Instant) -> TurnDecision {
        if self.machine.blocker(now).is_some() || self.waits_for_rest(&queued) {
            // Its parts are preloaded and paced from rest ([`Self::has_room`] waits for it).
            self.queue.push_front(queued);
            return TurnDecision::Wait;
        }
        let inputs = self
            .machine
            .last()
            .map(|s| s.block.inputs)
            .unwrap_or_default();
        // A gated move's permit is for when its gate opens: the PLC and `may_start` check it
        // then.
        if queued.gate.is_none() && !queued.order.permit.holds(&inputs) {
            let permit = queued.order.permit;
            return TurnDecision::PermitNotMet(queued.id, Blocker::PermitNotMet { permit, inputs });
        }
        let ahead = self.machine.chain_behind().cloned();
        if queued.order.begins_at_speed() && ahead.is_none() {
            return TurnDecision::NothingToChainBehind(queued.id);
        }
        let from = match (&ahead, self.machine.last()) {
            (Some(running), _) => running.targets.expect("chained only behind known targets"),
            (None, Some(last)) => last.block.elapsed,
            (None, None) => unreachable!("no blocker without a status block"),
        };
        let mode = match (queued.gate, ahead) {
            (Some(gate), ahead) => StartMode::Gated { gate, ahead },
            (None, Some(ahead)) => StartMode::Chained(ahead),
            (None, None) => StartMode::FromRest,
        };
        TurnDecision::Begin(Box::new(Turn {
            id: queued.id,
            order: queued.order,
            mode,
            from,
            preload: queued.preload,
        }))
    }

    /// Fails the head of the queue once it could not start for `start_within` after its turn
    /// came (its turn comes when the PLC has room for it; the time a move ahead of it runs does
    /// not count), and cancels the rest behind it.
    pub(super) fn expire(&mut self, link_up: bool, now: Instant) -> Vec<Finish> {
        let blocker = self.blocker(link_up, now);
        let behind_a_move = self.queue.front().is_some_and(|q| self.waits_for_rest(q));
        if matches!(blocker, Some(Blocker::Full | Blocker::Stopping)) || behind_a_move {
            self.room_since = None;
            return Vec::new();
        }
        let room = *self.room_since.get_or_insert(now);
        let Some(head) = self.queue.front() else {
            return Vec::new();
        };
        let turn = head.accepted.max(room);
        if now.saturating_duration_since(turn) <= self.start_within {
            return Vec::new();
        }
        let id = head.id;
        self.queue.pop_front();
        let why = format!(
            "did not start within {:.0} s{}",
            self.start_within.as_secs_f64(),
            blocker.map(|b| format!(": {b}")).unwrap_or_default()
        );
        let mut ends = vec![Finish::new(id, Stage::Failed, why)];
        ends.extend(self.cancel_queue(BEHIND_NOT_STARTED));
        ends
    }

    /// Cancels every queued move (never given to the PLC).
    pub(super) fn cancel_queue(&mut self, why: &str) -> Vec<Finish> {
        std::mem::take(&mut self.queue)
            .into_iter()
            .map(|q| Finish::new(q.id, Stage::Cancelled, why))
            .collect()
    }

    /// Ends the queued prepared moves whose gate shut before their turn (their cycle went
    /// another way), and every move queued behind one (planned from where it would have ended).
    pub(super) fn drop_shut(&mut self) -> Vec<Finish> {
        let shut = |q: &Queued| {
            q.gate
                .as_ref()
                .is_some_and(|g| g.state() == GateState::Shut)
        };
        let Some(at) = self.queue.iter().position(shut) else {
            return Vec::new();
        };
        let prepared = format!("{PREPARED_CANCELLED}: {CYCLE_WENT_ON}");
        self.queue
            .split_off(at)
            .into_iter()
            .enumerate()
            .map(|(k, q)| {
                if k == 0 {
                    Finish {
                        end: Some(EndReason::CancelledBeforeStart),
                        ..Finish::new(q.id, Stage::Cancelled, prepared.as_str())
                    }
                } else {
                    Finish::new(q.id, Stage::Cancelled, BEHIND_NOT_STARTED)
                }
            })
            .collect()
    }

    /// The parts of a path section chained at speed queued at the head (the first part's turn
    /// just came): the section, and each part's id and order, in order.
    pub(super) fn section_behind(&self) -> Option<(Arc<SectionOrder>, Vec<Part>)> {
        let section = self
            .queue
            .front()
            .filter(|q| q.order.begins_at_speed())
            .and_then(|q| q.order.section().cloned())?;
        let behind = self
            .queue
            .iter()
            .take_while(|q| {
                q.order.begins_at_speed()
                    && q.order.section().is_some_and(|s| Arc::ptr_eq(s, &section))
            })
            .map(|q| (q.id, q.order.clone()))
            .collect();
        Some((section, behind))
    }

    /// The head of the queue when it is the first part of a path section cut into parts: its
    /// order, and whether every part of the section is queued behind it.
    pub(super) fn lead_section(&self) -> Option<(CheckedOrder, bool)> {
        let head = self.queue.front().filter(|q| q.order.leads_parts())?;
        let section = head.order.section()?;
        let queued = self
            .queue
            .iter()
            .take_while(|q| q.order.section().is_some_and(|s| Arc::ptr_eq(s, section)))
            .count();
        let all = queued == head.order.parts();
        Some((head.order.clone(), all))
    }

    /// Forgets every preload: a bank written whole may lie over them.
    pub(super) fn forget_preloads(&mut self) {
        for q in &mut self.queue {
            q.preload = None;
        }
    }

    /// Forgets every preload but one made ahead ([`Self::ahead_due`]) for the part at the head
    /// of the queue, behind a start from rest into `bank` (its path's first part): that part's,
    /// in the other bank, which the first part's upload does not touch.
    pub(super) fn forget_preloads_but_ahead(&mut self, bank: u16) {
        let mut queue = self.queue.iter_mut();
        if let Some(head) = queue.next()
            && !(head.order.begins_at_speed()
                && head
                    .preload
                    .as_ref()
                    .is_some_and(|p| p.tables.bank() != bank))
        {
            head.preload = None;
        }
        for q in queue {
            q.preload = None;
        }
    }

    /// Queued move `id`'s tables were preloaded, their exchanges taking `took`.
    pub(super) fn preloaded(&mut self, id: MoveId, preload: Preload, took: Duration) {
        if let Some(q) = self.queue.iter_mut().find(|q| q.id == id) {
            q.preload = Some(Preloaded {
                tables: preload,
                took,
            });
        }
    }

    /// What queued move `id` has preloaded, if anything.
    pub(super) fn preload_of(&self, id: MoveId) -> Option<&Preloaded> {
        self.queue
            .iter()
            .find(|q| q.id == id)
            .and_then(|q| q.preload.as_ref())
    }

    /// The sequence number for the next start: never the PLC's latched one, which it would take
    /// for a start already acted on.
    pub(super) fn next_seq(&self) -> u16 {
        let latched = self.machine.last().map(|s| s.block.seq);
        if latched == Some(self.next_seq) {
            self.next_seq.wrapping_add(1).max(1)
        } else {
            self.next_seq
        }
    }

    /// The bank for a start planned behind the one in `running_bank`: always the bank that is
    /// not running. From rest, the next in turn, or, when the part behind it at the head of the
    /// queue was preloaded ahead (its path's second part, [`Self::ahead_due`]), the other bank
    /// than that part's.
    pub(super) fn next_bank(&self, running_bank: Option<u16>) -> u16 {
        if let Some(b) = running_bank {
            return 1 - b;
        }
        self.queue
            .front()
            .filter(|q| q.order.begins_at_speed())
            .and_then(|q| q.preload.as_ref())
            .map_or(self.next_bank, |p| 1 - p.tables.bank())
    }

    /// A start in `bank` with `seq` was written (or found running): whatever became of it, its
    /// sequence number is spent and the next start goes into the other bank.
    pub(super) fn spent(&mut self, seq: u16, bank: u16) {
        self.next_seq = seq.wrapping_add(1).max(1);
        self.next_bank = 1 - bank.min(1);
    }

    fn flight(&mut self, id: MoveId) -> &mut InFlight {
        if let Some(at) = self.flights.iter().position(|f| f.id == id) {
            return &mut self.flights[at];
        }
        self.flights.push(InFlight {
            id,
            ..InFlight::default()
        });
        self.flights.last_mut().expect("just pushed")
    }

    /// Move `id`'s start was written into `bank` with `permit`: the one start written again
    /// after a lost reply.
    pub(super) fn start_written(&mut self, id: MoveId, permit: Permit, bank: VerifiedBank) {
        self.forget_starts();
        let flight = self.flight(id);
        flight.permit = permit;
        flight.start = Some(bank);
    }

    /// No start is written again (the PLC restarted).
    pub(super) fn forget_starts(&mut self) {
        for f in &mut self.flights {
            f.start = None;
        }
    }

    /// The bank of move `id`'s start, if it is the last start written.
    pub(super) fn start_of(&self, id: MoveId) -> Option<&VerifiedBank> {
        self.flights
            .iter()
            .find(|f| f.id == id)
            .and_then(|f| f.start.as_ref())
    }

    /// Move `id` was seen starting at `now`.
    pub(super) fn started(&mut self, id: MoveId, now: Instant) {
        self.flight(id).started = Some(now);
    }

    /// When move `id` was seen starting, while it runs.
    pub(super) fn started_at(&self, id: MoveId) -> Option<Instant> {
        self.flights
            .iter()
            .find(|f| f.id == id)
            .and_then(|f| f.started)
    }

    /// Move `id` ended (it runs no more): when it was seen starting.
    pub(super) fn ran(&mut self, id: MoveId) -> Option<Instant> {
        self.flights
            .iter_mut()
            .find(|f| f.id == id)
            .and_then(|f| f.started.take())
    }

    /// Move `id`'s permit, if it was written with one.
    pub(super) fn permit(&self, id: MoveId) -> Option<&Permit> {
        self.flights
            .iter()
            .find(|f| f.id == id)
            .map(|f| &f.permit)
            .filter(|p| !p.is_none())
    }

    /// A stop was written at `now`.
    pub(super) fn stop_asked(&mut self, now: Instant) {
        self.stop_asked = Some(now);
    }

    /// Whether a stop was asked for so recently that a move stopped now was stopped by it.
    pub(super) fn stopped_by_request(&self, now: Instant) -> bool {
        self.stop_asked
            .is_some_and(|t| now.saturating_duration_since(t) < STOP_ASKED_WINDOW)
    }

    /// Move `id`, whose `targets` are within a pulse of `from`, where it begins: nothing to
    /// start. With nothing running (`lead` none) the robot is at `from` now and it ends done;
    /// behind the running start `lead` it is not there yet, and it ends with that start (done
    /// only if that one ends done, [`follower_ends`]): `None`.
    pub(super) fn in_place(
        &mut self,
        id: MoveId,
        from: [i32; CHANNELS],
        targets: [i32; CHANNELS],
        lead: Option<MoveId>,
    ) -> Option<Finish> {
        if let Some(lead) = lead {
            self.flight(lead).followers.push(Follower { id, targets });
            return None;
        }
        Some(Finish {
            id,
            stage: Stage::Done,
            error: None,
            final_error: Some(std::array::from_fn(|c| {
                i64::from(from[c]) - i64::from(targets[c])
            })),
            end: None,
        })
    }

    /// Move `id` ended short (`stage`, `why`) on the block with heartbeat `beat`, read at
    /// `now`: its report waits for the counts the PLC stopped at ([`Self::settled`]).
    pub(super) fn settling(
        &mut self,
        id: MoveId,
        stage: Stage,
        why: String,
        beat: u16,
        now: Instant,
    ) {
        self.flight(id).settling = Some(Settling {
            stage,
            why,
            beat,
            since: now,
        });
    }

    /// Whether a stopped move's report waits for its counts.
    pub(super) fn any_settling(&self) -> bool {
        self.flights.iter().any(|f| f.settling.is_some())
    }

    /// The stopped moves whose reports end now: once `status` (read a scan after their end)
    /// shows the robot's channels (`mask`) still, or they waited too long. `None`: the PLC can
    /// no longer tell (the link, a restart, a stall); all of them.
    pub(super) fn settled(
        &mut self,
        status: Option<&Status>,
        mask: u16,
        now: Instant,
    ) -> Vec<Settled> {
        let late = |s: &Settling| now.saturating_duration_since(s.since) > SETTLE_LIMIT;
        self.take_settled(|s| match status {
            Some(b) => (b.block.heartbeat != s.beat && b.block.busy & mask == 0) || late(s),
            None => true,
        })
    }

    /// The stopped moves that waited too long for a block that shows their channels still
    /// (the link is down).
    pub(super) fn settled_late(&mut self, now: Instant) -> Vec<Settled> {
        self.take_settled(|s| now.saturating_duration_since(s.since) > SETTLE_LIMIT)
    }

    fn take_settled(&mut self, done: impl Fn(&Settling) -> bool) -> Vec<Settled> {
        let mut settled = Vec::new();
        for f in &mut self.flights {
            if f.settling.as_ref().is_some_and(&done) {
                let s = f.settling.take().expect("checked");
                settled.push(Settled {
                    id: f.id,
                    stage: s.stage,
                    why: s.why,
                });
            }
        }
        settled
    }

    /// Move `id`'s report ends: its record goes, and the moves that were to end with it.
    pub(super) fn finished(&mut self, id: MoveId) -> Vec<Follower> {
        match self.flights.iter().position(|f| f.id == id) {
            Some(at) => self.flights.remove(at).followers,
            None => Vec::new(),
        }
    }

    /// Every move waiting to end with a start (the daemon shuts down).
    pub(super) fn take_followers(&mut self) -> Vec<MoveId> {
        self.flights
            .iter_mut()
            .flat_map(|f| std::mem::take(&mut f.followers))
            .map(|f| f.id)
            .collect()
    }
}

/// How a move the PLC ended other than done is reported: its stage and why. `held`: why the
/// PLC held it (its permit stopped holding), when it was written with a permit and stopped for
/// it; `asked`: a stop was asked for just before; `start`: the start's name in words.
pub(super) fn end_of(
    outcome: Outcome,
    held: Option<String>,
    asked: bool,
    start: &str,
) -> (Stage, String) {
    match (outcome, held) {
        (Outcome::Stopped { fault }, _) if fault == Fault::StoppedFromOutside.word() => {
            (Stage::Stopped, "stopped by the e-stop input".to_owned())
        }
        // The fault word outlives a stop until a clear fault: only a move with a permit was
        // held by it.
        (Outcome::Stopped { .. }, Some(held)) => (Stage::Stopped, held),
        (Outcome::Stopped { .. }, None) if asked => {
            (Stage::Stopped, "stopped by request".to_owned())
        }
        (Outcome::Stopped { .. }, None) => (
            Stage::Stopped,
            "stopped by the PLC (PROG mode, or its program)".to_owned(),
        ),
        (Outcome::Dropped, _) if asked => (Stage::Cancelled, "cancelled by a stop request".into()),
        (Outcome::Dropped, _) => (
            Stage::Cancelled,
            format!("{start} {}", describe_outcome(&outcome)),
        ),
        _ => (
            Stage::Failed,
            format!("{start} {}", describe_outcome(&outcome)),
        ),
    }
}

/// Whether a move that ended `outcome` may have moved the robot: its report then waits for the
/// counts the PLC stopped at ([`Dispatcher::settling`]).
pub(super) fn moved(outcome: Outcome) -> bool {
    matches!(
        outcome,
        Outcome::Stopped { .. }
            | Outcome::Faulted { .. }
            | Outcome::OutsideEnvelope { .. }
            | Outcome::Overrun { .. }
            | Outcome::WentIdle
    )
}

/// How `followers` of move `lead` end, which ended `stage` (`why`) with its report's counts
/// (`None`: its end was learnt from the start the PLC took behind it, with no counts read at
/// it) and targets (`at`): done at their targets only when it ended done on the same targets,
/// their final error its own (none without counts), else cancelled with the reason.
pub(super) fn follower_ends(
    lead: MoveId,
    followers: &[Follower],
    stage: Stage,
    why: Option<&str>,
    at: Option<(Option<[i64; CHANNELS]>, [i64; CHANNELS])>,
) -> Vec<Finish> {
    let at = at.filter(|_| stage == Stage::Done);
    followers
        .iter()
        .map(|f| {
            let targets = f.targets.map(i64::from);
            match at {
                Some((counts, lead_targets)) if lead_targets == targets => Finish {
                    id: f.id,
                    stage: Stage::Done,
                    error: None,
                    final_error: counts
                        .map(|counts| std::array::from_fn(|c| counts[c] - targets[c])),
                    end: None,
                },
                _ => Finish::new(
                    f.id,
                    Stage::Cancelled,
                    format!(
                        "cancelled: it had no motion of its own and was to end with move {lead}, \
                         which ended {}{}",
                        stage.name(),
                        why.map(|w| format!(" ({w})")).unwrap_or_default()
                    ),
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
