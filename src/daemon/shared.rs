//! What a robot's worker and its handle share: the robot's state as last read, the move
//! reports, the flag a stop raises before it is taken, and why a new order would be refused now.
//! Neither side owns the other: both hold this.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use super::ids::MoveIds;
use super::metrics::RobotMetrics;
use super::report::Moves;
use crate::contract::machine::Blocker;
use crate::kinematics::JOINTS;
use crate::plc::exchange::Beat;
use crate::wire::{MoveId, RobotState};

/// State shared by a robot's worker and its handle.
#[derive(Debug)]
pub(super) struct Shared {
    state: Mutex<RobotState>,
    moves: Mutex<Moves>,
    /// Set when a stop is asked for: an upload in progress gives up at its next write.
    pub stop_pending: Arc<AtomicBool>,
    /// Set while a cycle waits on the inputs: the worker reads the status block at its busy
    /// pace, so the wait reacts within one poll interval.
    pub inputs_watched: AtomicBool,
    /// Wakes the worker to read the status block at once (a wait began: it is decided on a
    /// fresh block, not one an idle poll away).
    pub read_soon: tokio::sync::Notify,
    ids: Arc<MoveIds>,
    /// Where the last accepted order is planned to end, per joint (for checking the next).
    planned_end: Mutex<Option<[i64; JOINTS]>>,
    /// Why a new order would be refused now (`None`: it would be queued).
    refusal: Mutex<Option<Blocker>>,
    /// When the worker last made progress (went round its loop, or an exchange of an upload).
    pub beat: Arc<Beat>,
    /// The robot's lifetime counters and histograms.
    pub metrics: RobotMetrics,
    /// Counts the status blocks read (and the links lost): a cycle's `wait` wakes on each.
    reads: tokio::sync::watch::Sender<u64>,
    /// When the last status block was read (tokio's clock).
    read_at: Mutex<Option<tokio::time::Instant>>,
    /// Counts what made the PLC untrustworthy under the host (it restarted, stalled, went to
    /// PROG mode, or the link was lost past a move's end): a cycle faults on each, whatever its
    /// step, and what it asked for before one is refused after it.
    incidents: tokio::sync::watch::Sender<Incidents>,
}

/// What made the PLC untrustworthy under the host, counted ([`Shared::incident`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Incidents {
    /// How many so far.
    pub count: u64,
    /// The last one, in words.
    pub last: Option<String>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere leaves plain data behind: keep serving it.
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Shared {
    pub(super) fn new(name: &str, ids: Arc<MoveIds>, metrics: RobotMetrics) -> Self {
        Self {
            state: Mutex::new(RobotState {
                name: name.to_owned(),
                ..RobotState::default()
            }),
            moves: Mutex::new(Moves::default()),
            stop_pending: Arc::new(AtomicBool::new(false)),
            inputs_watched: AtomicBool::new(false),
            read_soon: tokio::sync::Notify::new(),
            ids,
            planned_end: Mutex::new(None),
            refusal: Mutex::new(Some(Blocker::LinkDown)),
            beat: Arc::new(Beat::default()),
            metrics,
            reads: tokio::sync::watch::Sender::new(0),
            read_at: Mutex::new(None),
            incidents: tokio::sync::watch::Sender::new(Incidents::default()),
        }
    }

    /// How long ago the last status block was read (`None`: never, or the link was lost since).
    pub(super) fn since_read(&self) -> Option<std::time::Duration> {
        lock(&self.read_at).map(|at| at.elapsed())
    }

    /// A status block was read, or the link lost: what [`Self::watch_reads`] wakes on.
    pub(super) fn status_read(&self) {
        self.reads.send_modify(|n| *n = n.wrapping_add(1));
    }

    /// A status block was read now.
    pub(super) fn fresh_read(&self) {
        *lock(&self.read_at) = Some(tokio::time::Instant::now());
        self.status_read();
    }

    /// The link was lost: no read is fresh.
    pub(super) fn no_read(&self) {
        *lock(&self.read_at) = None;
        self.status_read();
    }

    /// The PLC restarted, stalled or went to PROG mode, or the link was lost past a move's end
    /// (`why`): counted, and every watcher woken.
    pub(super) fn incident(&self, why: String) {
        self.incidents.send_modify(|i| {
            i.count += 1;
            i.last = Some(why);
        });
    }

    /// The incidents so far.
    pub(super) fn incidents(&self) -> Incidents {
        self.incidents.borrow().clone()
    }

    /// Wakes on every incident.
    pub(super) fn watch_incidents(&self) -> tokio::sync::watch::Receiver<Incidents> {
        self.incidents.subscribe()
    }

    /// Wakes on every status block read (and every link lost).
    pub(super) fn watch_reads(&self) -> tokio::sync::watch::Receiver<u64> {
        self.reads.subscribe()
    }

    pub(super) fn state<T>(&self, f: impl FnOnce(&mut RobotState) -> T) -> T {
        f(&mut lock(&self.state))
    }

    pub(super) fn moves<T>(&self, f: impl FnOnce(&mut Moves) -> T) -> T {
        f(&mut lock(&self.moves))
    }

    pub(super) fn planned_end(&self) -> Option<[i64; JOINTS]> {
        *lock(&self.planned_end)
    }

    pub(super) fn set_planned_end(&self, end: Option<[i64; JOINTS]>) {
        *lock(&self.planned_end) = end;
    }

    /// Forgets where queued orders were planned to end (after a move that will not get there).
    pub(super) fn forget_planned_end(&self) {
        self.set_planned_end(None);
    }

    pub(super) fn refusal(&self) -> Option<Blocker> {
        *lock(&self.refusal)
    }

    pub(super) fn set_refusal(&self, refusal: Option<Blocker>) {
        *lock(&self.refusal) = refusal;
    }

    pub(super) fn next_id(&self) -> MoveId {
        self.ids.next()
    }

    /// How long ago the worker last made progress (`None` before the first time).
    pub(super) fn since_loop_beat(&self) -> Option<std::time::Duration> {
        self.beat.since()
    }
}
