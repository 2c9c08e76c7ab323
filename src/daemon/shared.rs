//! What a robot's owner (its worker task) publishes, and what its handles read: one snapshot of
//! the robot ([`Snapshot`]: the state the API shows, why an order would be refused, where the
//! last accepted order ends, when the status block was last read, the PLC's incidents), sent on
//! a `watch` by the worker alone; the move reports, written by the worker alone and read by
//! every handle; and the few signals a handle raises for the worker between two of its
//! exchanges.
//!
//! ```text
//!  worker --Publisher (watch::Sender<Snapshot>)--> handles, API, cycle, console (Receivers)
//!  worker --Moves (writes)--> handles (reads: a report, a move's feed)
//!  handle --stop_pending, inputs_watched, read_soon--> worker
//!  cycle owner, cycle driver --CycleOut (watch)--> handles (the cycle's status)
//!  cell owner --watch::Sender<CellView>--> handles (the mode, the cell face)
//! ```

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use tokio::sync::watch;

use super::ids::MoveIds;
use super::metrics::RobotMetrics;
use super::report::Moves;
use crate::cell::Mode;
use crate::cell::face::Face;
use crate::contract::machine::Blocker;
use crate::kinematics::JOINTS;
use crate::plc::exchange::Beat;
use crate::wire::{CycleStatus, MoveId, RobotState};

/// What made the PLC untrustworthy under the host, counted ([`Publisher::incident`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Incidents {
    /// How many so far.
    pub count: u64,
    /// The last one, in words.
    pub last: Option<String>,
    /// How many of them were restarts of the PLC (its outputs and non-hold relays went off: a
    /// gripper let go).
    pub restarts: u64,
}

/// One robot as its worker last published it.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The state the API shows (but the cycle, the mode and the cell face, which have owners
    /// of their own).
    pub state: RobotState,
    /// Why a new order would be refused now (`None`: it would be queued).
    pub refusal: Option<Blocker>,
    /// Where the last order accepted is planned to end, per joint, while it is queued or runs
    /// (the next order is planned from there).
    pub planned_end: Option<[i64; JOINTS]>,
    /// When the last status block was read (tokio's clock; `None`: never, or the link was lost
    /// since).
    pub read_at: Option<tokio::time::Instant>,
    /// Counts the status blocks read and the links lost: a cycle's wait decides on each.
    pub reads: u64,
    /// What made the PLC untrustworthy under the host (it restarted, stalled, went to PROG
    /// mode, or the link was lost past a move's end): a cycle faults on each, whatever its
    /// step, and what it asked for before one is refused after it.
    pub incidents: Incidents,
}

impl Snapshot {
    fn new(name: &str) -> Self {
        Self {
            state: RobotState {
                name: name.to_owned(),
                ..RobotState::default()
            },
            refusal: Some(Blocker::LinkDown),
            planned_end: None,
            read_at: None,
            reads: 0,
            incidents: Incidents::default(),
        }
    }

    /// How long ago the last status block was read.
    #[must_use]
    pub fn since_read(&self) -> Option<std::time::Duration> {
        self.read_at.map(|at| at.elapsed())
    }
}

/// The robot's cell as its owner (`daemon/cell`) last published it.
#[derive(Debug, Clone)]
pub struct CellView {
    /// Who drives the robot.
    pub mode: Mode,
    /// The cell face's command side (`None`: the robot has none).
    pub face: Option<Face>,
}

impl CellView {
    /// Whether the face holds every motion: remote mode with move-enable off.
    #[must_use]
    pub fn holds_motion(&self) -> bool {
        self.mode == Mode::Remote && self.face.as_ref().is_some_and(|f| !f.enabled())
    }
}

/// What a robot's cycle owner and the cycle's driver publish its status on (`None`: no cycle
/// ran since the daemon started).
pub(crate) type CycleOut = Arc<watch::Sender<Option<CycleStatus>>>;

/// The status blocks a robot's worker reads, one after another: what a cycle's wait decides
/// on.
#[derive(Debug, Clone)]
pub struct Reads {
    snapshots: watch::Receiver<Snapshot>,
    /// The reads counted when last waited for (or when this was made).
    seen: u64,
}

impl Reads {
    /// Waits for the next status block read (or link lost) after the last one seen; `Err` once
    /// the worker is gone.
    pub async fn next(&mut self) -> Result<(), watch::error::RecvError> {
        let seen = self.seen;
        let reads = self.snapshots.wait_for(|s| s.reads != seen).await?.reads;
        self.seen = reads;
        Ok(())
    }
}

/// The worker's side of the snapshot: the one sender.
#[derive(Debug)]
pub(super) struct Publisher(watch::Sender<Snapshot>);

impl Publisher {
    /// The robot's state, changed by `f` and published (its readers woken only when it
    /// changed).
    pub(super) fn state<T>(&self, f: impl FnOnce(&mut RobotState) -> T) -> T {
        let mut out = None;
        self.0.send_if_modified(|s| {
            let before = s.state.clone();
            out = Some(f(&mut s.state));
            s.state != before
        });
        out.expect("send_if_modified runs its closure")
    }

    /// The snapshot as published.
    pub(super) fn get(&self) -> watch::Ref<'_, Snapshot> {
        self.0.borrow()
    }

    /// A status block was read now.
    pub(super) fn fresh_read(&self) {
        self.0.send_modify(|s| {
            s.read_at = Some(tokio::time::Instant::now());
            s.reads = s.reads.wrapping_add(1);
        });
    }

    /// The link was lost: no read is fresh.
    pub(super) fn no_read(&self) {
        self.0.send_modify(|s| {
            s.read_at = None;
            s.reads = s.reads.wrapping_add(1);
        });
    }

    /// The PLC restarted, stalled or went to PROG mode, or the link was lost past a move's end
    /// (`why`): counted, and every watcher woken.
    pub(super) fn incident(&self, why: String, restart: bool) {
        self.0.send_modify(|s| {
            s.incidents.count += 1;
            s.incidents.last = Some(why);
            s.incidents.restarts += u64::from(restart);
        });
    }

    /// The incidents so far.
    pub(super) fn incidents(&self) -> Incidents {
        self.0.borrow().incidents.clone()
    }

    /// Why a new order would be refused now.
    pub(super) fn set_refusal(&self, refusal: Option<Blocker>) {
        self.0.send_if_modified(|s| {
            let changed = s.refusal != refusal;
            s.refusal = refusal;
            changed
        });
    }

    /// Where the last order accepted ends.
    pub(super) fn set_planned_end(&self, end: Option<[i64; JOINTS]>) {
        self.0.send_if_modified(|s| {
            let changed = s.planned_end != end;
            s.planned_end = end;
            changed
        });
    }
}

/// What a robot's worker and its handles hold together.
#[derive(Debug)]
pub(super) struct Shared {
    /// The worker's snapshot, as published.
    published: watch::Receiver<Snapshot>,
    /// The cycle's status, as its owner and driver publish it.
    pub cycle: watch::Receiver<Option<CycleStatus>>,
    /// The mode and the cell face, as the cell's owner publishes them.
    pub cell: watch::Receiver<CellView>,
    /// The move reports: written by the worker alone.
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
    /// When the worker last made progress (went round its loop, or an exchange of an upload).
    pub beat: Arc<Beat>,
    /// The robot's lifetime counters and histograms.
    pub metrics: RobotMetrics,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere leaves plain data behind: keep serving it.
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Shared {
    /// What robot `name`'s worker and handles hold, and the worker's publisher. `cycle` and
    /// `cell`: what the cycle's and the cell's owners publish.
    pub(super) fn new(
        name: &str,
        (ids, metrics): (Arc<MoveIds>, RobotMetrics),
        cycle: watch::Receiver<Option<CycleStatus>>,
        cell: watch::Receiver<CellView>,
    ) -> (Self, Publisher) {
        let (tx, published) = watch::channel(Snapshot::new(name));
        let shared = Self {
            published,
            cycle,
            cell,
            moves: Mutex::new(Moves::default()),
            stop_pending: Arc::new(AtomicBool::new(false)),
            inputs_watched: AtomicBool::new(false),
            read_soon: tokio::sync::Notify::new(),
            ids,
            beat: Arc::new(Beat::default()),
            metrics,
        };
        (shared, Publisher(tx))
    }

    /// The robot as its worker last published it.
    pub(super) fn snapshot(&self) -> Snapshot {
        self.published.borrow().clone()
    }

    /// A reader of the snapshot: wakes on every change.
    pub(super) fn watch(&self) -> watch::Receiver<Snapshot> {
        self.published.clone()
    }

    /// The status reads from now on ([`Reads::next`]).
    pub(super) fn reads(&self) -> Reads {
        Reads {
            seen: self.published.borrow().reads,
            snapshots: self.published.clone(),
        }
    }

    /// The moves' reports (changed by the worker alone).
    pub(super) fn moves<T>(&self, f: impl FnOnce(&mut Moves) -> T) -> T {
        f(&mut lock(&self.moves))
    }

    pub(super) fn next_id(&self) -> MoveId {
        self.ids.next()
    }

    /// How long ago the worker last made progress (`None` before the first time).
    pub(super) fn since_loop_beat(&self) -> Option<std::time::Duration> {
        self.beat.since()
    }
}
