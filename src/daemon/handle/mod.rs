//! The daemon's face to the rest of the program: one handle per robot (submit a move, stop, home,
//! clear a fault, read state and reports, follow a move's progress, teach positions) and the
//! daemon that spawns a worker per robot, watches that they make progress, and shuts them down.

mod submit;

use super::cell::Cell;
use super::cycle::CycleSlot;
use super::request::ConflictReason;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use thiserror::Error;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::JoinSet;

use super::gateway::{self, GatewayError, Job, Values};
use super::live::{Live, LiveSettings};
use super::positions::{Position, PositionError, TaughtPositions, check_name, unix_now_s};
use super::request::{CommandError, Reply, Request};
use super::setup::{DaemonOptions, RobotSetup};
use super::shared::Shared;
use super::worker::{Channels, Worker};
use crate::contract::CHANNELS;
use crate::contract::machine::Blocker;
use crate::gateway::{Address, GatewaySettings, Range};
use crate::kinematics::JOINTS;
use crate::order::OrderError;
use crate::plan::PlanError;
use crate::robot::Robot;
use crate::wire::{MoveId, MoveReport, RobotPhase, RobotState};

/// Why a move was not accepted.
#[derive(Debug, Error)]
pub enum SubmitError {
    /// A field of the order is wrong.
    #[error(transparent)]
    Order(#[from] OrderError),
    /// The move cannot be planned from where the robot is (or will be).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The robot cannot take a move now (link down, not homed, a fault...).
    #[error("{blocker}{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    NotNow {
        /// Why.
        blocker: Blocker,
        /// The link's last error, when that is why.
        detail: Option<String>,
    },
    /// The queue would hold more starts than it takes.
    #[error(
        "{queued} starts are queued or running and the order adds {adding}; at most {limit} \
         at once: wait for some to end"
    )]
    QueueFull {
        /// Starts queued or running now.
        queued: usize,
        /// Starts the order would add.
        adding: usize,
        /// The most, [`MAX_QUEUED_STARTS`].
        limit: usize,
    },
    /// The robot is in remote mode and the cell face's move-enable is off.
    #[error(
        "the cell face's move-enable is off (remote mode): no motion until the line turns it on"
    )]
    MoveEnableOff,
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// Asked for by a cycle before the PLC restarted, stalled or was lost: refused.
    #[error("{why} since the cycle asked for it")]
    Untrusted {
        /// What happened.
        why: String,
    },
}

/// The most starts a robot's queue holds, the running one included: an order that would pass
/// it is refused whole.
pub const MAX_QUEUED_STARTS: usize = 1_000;

/// One robot, as the API and the CLI see it.
#[derive(Debug, Clone)]
pub struct RobotHandle {
    pub(super) robot: Arc<Robot>,
    requests: mpsc::UnboundedSender<Request>,
    stops: mpsc::UnboundedSender<Reply>,
    gateway: mpsc::UnboundedSender<Job>,
    /// The gateway's lists and the cell's signals and programs: a reload changes them.
    pub(super) live: Live,
    pub(super) shared: Arc<Shared>,
    pub(super) positions: Arc<TaughtPositions>,
    pub(super) cell: Arc<Cell>,
    pub(super) cycles: Arc<CycleSlot>,
    /// Orders are taken one at a time, each planned from where the one before it ends.
    lane: Arc<tokio::sync::Mutex<()>>,
    /// The PLC's incident count this handle acts under (a cycle's): its moves and writes are
    /// refused once another incident came ([`Shared::incident`]); `None`: whenever.
    epoch: Option<u64>,
    /// The speed override, 1 to 100 %: every order checked after it is set is planned at it
    /// ([`Self::limits`]).
    speed_override: Arc<std::sync::atomic::AtomicU8>,
    /// The cell's journal (`DaemonOptions::journal`).
    journal: crate::journal::Journal,
}

/// A position saved from the robot's pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// The position.
    pub position: Position,
    /// Whether it replaced one of the same name.
    pub replaced: bool,
}

impl RobotHandle {
    /// The robot.
    #[must_use]
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The cell's journal: what the robot's cycle records into (a pallet's slot placed, a
    /// pallet full).
    #[must_use]
    pub fn journal(&self) -> &crate::journal::Journal {
        &self.journal
    }

    /// The speed override, 1 to 100 %.
    #[must_use]
    pub fn speed_override(&self) -> u8 {
        self.speed_override.load(Ordering::SeqCst)
    }

    /// Sets the speed override (`percent` clamped to 1 to 100): every move checked from now on
    /// is planned at that share of its speed; moves already accepted keep theirs. Returns the
    /// override set.
    #[must_use = "the override set, clamped to 1 to 100"]
    pub fn set_speed_override(&self, percent: u8) -> u8 {
        let percent = percent.clamp(1, 100);
        self.speed_override.store(percent, Ordering::SeqCst);
        percent
    }

    /// What an order is checked against: the robot's limits under the speed override.
    pub(super) fn limits(&self) -> crate::order::OrderLimits {
        crate::order::OrderLimits::of(&self.robot).overridden(self.speed_override())
    }

    /// The counts the PLC last reported, per joint.
    pub(super) fn counts_by_joint(&self) -> Option<[i64; JOINTS]> {
        self.joints_of(self.shared.snapshot().state.counts)
    }

    /// Per-joint counts of per-channel ones.
    fn joints_of(&self, counts: Option<[i64; CHANNELS]>) -> Option<[i64; JOINTS]> {
        let counts = counts?;
        Some(std::array::from_fn(|j| {
            counts[usize::from(self.robot.joints[j].channel)]
        }))
    }

    /// The robot's taught positions, by name.
    #[must_use]
    pub fn positions(&self) -> BTreeMap<String, Position> {
        self.positions.of(&self.robot.name)
    }

    /// One taught position.
    pub fn position(&self, name: &str) -> Result<Position, PositionError> {
        self.positions.get(&self.robot.name, name)
    }

    /// What went wrong with the positions file at start (set aside as corrupt, unreadable), if
    /// anything did.
    #[must_use]
    pub fn positions_warning(&self) -> Option<&str> {
        self.positions.warning()
    }

    /// Saves the robot's pose, from the counts the PLC last reported, as position `name`
    /// (replacing one of that name). Refused while the link is down or stalled, the robot is
    /// not homed or homing (its counts mean nothing), or a move runs or waits.
    pub fn save_position(&self, name: &str) -> Result<Saved, PositionError> {
        check_name(name)?;
        if let Some(
            blocker @ (Blocker::LinkDown | Blocker::Stalled | Blocker::NotHomed | Blocker::Homing),
        ) = self.shared.snapshot().refusal
        {
            return Err(PositionError::NotNow { blocker });
        }
        let state = self.state();
        if state.current_move.is_some()
            || !state.queued.is_empty()
            || state.phase != RobotPhase::Idle
        {
            return Err(PositionError::Busy {
                current: state
                    .current_move
                    .map_or_else(|| "-".to_owned(), |id| id.to_string()),
                queued: state.queued.len(),
            });
        }
        let joint_counts = self.counts_by_joint().ok_or(PositionError::NotNow {
            blocker: Blocker::LinkDown,
        })?;
        let position = Position {
            pose: self.robot.pose_of(&joint_counts).to_mm_deg(),
            joint_counts,
            saved_unix_s: unix_now_s(),
        };
        let replaced = self
            .positions
            .save(&self.robot.name, name, position.clone())?;
        tracing::info!(robot = %self.robot.name, position = name, pose = %position.pose.map(|v| format!("{v:.3}")).join(","), counts = %joint_counts.map(|c| c.to_string()).join(","), replaced, "position saved");
        Ok(Saved { position, replaced })
    }

    /// Deletes a taught position; returns it.
    pub fn delete_position(&self, name: &str) -> Result<Position, PositionError> {
        let removed = self.positions.delete(&self.robot.name, name)?;
        tracing::info!(robot = %self.robot.name, position = name, "position deleted");
        Ok(removed)
    }

    /// Stops every channel and cancels every queued move; returns once the stop is written.
    pub async fn stop(&self) -> Result<(), CommandError> {
        // A stop always works, whoever runs the robot: a cycle ends with it.
        self.cycles.robot_stopped();
        self.stop_robot().await
    }

    /// Stops every channel and cancels every queued move, leaving the robot's cycle as it is
    /// (the cycle's own stop, when it faults).
    pub(crate) async fn stop_robot(&self) -> Result<(), CommandError> {
        self.shared.stop_pending.store(true, Ordering::SeqCst);
        let (tx, rx) = oneshot::channel();
        self.stops
            .send(tx)
            .map_err(|_| CommandError::ShuttingDown)?;
        rx.await.map_err(|_| CommandError::ShuttingDown)?
    }

    /// Homes the robot: every joint's count is set to its home count at its home position.
    /// Returns once the PLC's home routine has ended.
    pub async fn home(&self) -> Result<(), CommandError> {
        self.command(Request::Home).await
    }

    /// Clears a latched fault on the PLC (refused while a move runs or when there is none,
    /// unless a cycle is faulted: then its fault is cleared, and it may be resumed).
    pub async fn clear_fault(&self) -> Result<(), CommandError> {
        let cycle_faulted = self
            .cycle()
            .is_some_and(|c| c.state == super::CycleState::Faulted);
        let cleared = match self.command(Request::ClearFault).await {
            Err(CommandError::Conflict {
                reason: ConflictReason::NoFault,
            }) if cycle_faulted => Ok(()),
            other => other,
        };
        // Only a clear that happened lets a faulted cycle be resumed.
        if cleared.is_ok() {
            self.cycles.fault_cleared(self.incidents().count);
        }
        cleared
    }

    async fn command(&self, request: fn(Reply) -> Request) -> Result<(), CommandError> {
        let (tx, rx) = oneshot::channel();
        self.requests
            .send(request(tx))
            .map_err(|_| CommandError::ShuttingDown)?;
        rx.await.map_err(|_| CommandError::ShuttingDown)?
    }

    /// The robot's gateway settings (its access list, its Modbus face) as they are now.
    #[must_use]
    pub fn gateway(&self) -> GatewaySettings {
        self.live.get().gateway.clone()
    }

    /// Reads `count` registers (DT words) or bits (X, Y, R) from `start`, if the access list
    /// allows, through the robot's link.
    pub async fn read_registers(&self, start: Address, count: u32) -> Result<Values, GatewayError> {
        let range = gateway::range(start, count)?;
        self.live.get().gateway.access.check_read(&range)?;
        self.gateway_job(range, None).await
    }

    /// Writes `values` from `start` (words to DT, bits to Y or R), if the access list allows.
    pub async fn write_registers(
        &self,
        start: Address,
        values: Values,
    ) -> Result<(), GatewayError> {
        gateway::check_values(start.area, &values)?;
        let range = gateway::range(start, values.len() as u32)?;
        self.live.get().gateway.access.check_write(&range)?;
        self.gateway_job(range, Some(values)).await.map(|_| ())
    }

    pub(super) async fn gateway_job(
        &self,
        range: Range,
        write: Option<Values>,
    ) -> Result<Values, GatewayError> {
        if let Some(why) = self.untrusted() {
            return Err(GatewayError::Untrusted { why });
        }
        let (tx, rx) = oneshot::channel();
        let mut job = Job::new(range, write, tx);
        job.epoch = self.epoch;
        self.gateway
            .send(job)
            .map_err(|_| GatewayError::ShuttingDown)?;
        rx.await.map_err(|_| GatewayError::ShuttingDown)?
    }

    /// The robot's state as last read.
    #[must_use]
    pub fn state(&self) -> RobotState {
        let mut state = self.shared.snapshot().state;
        state.cycle = self.cycles.status();
        state.mode = self.mode();
        state.face = self.face_state();
        state
    }

    /// A move's report.
    #[must_use]
    pub fn report(&self, id: MoveId) -> Option<MoveReport> {
        self.shared.moves(|m| m.get(id))
    }

    /// Every kept report.
    #[must_use]
    pub fn reports(&self) -> Vec<MoveReport> {
        self.shared.moves(|m| m.all())
    }

    /// The daemon's metrics (shared by every robot of one daemon).
    #[must_use]
    pub fn metrics(&self) -> &super::metrics::Metrics {
        self.shared.metrics.daemon()
    }

    /// A move's progress feed: every change of its report.
    #[must_use]
    pub fn subscribe(&self, id: MoveId) -> Option<watch::Receiver<MoveReport>> {
        self.shared.moves(|m| m.subscribe(id))
    }

    /// Waits until move `id` has ended (or `limit` passes) and returns its report.
    pub async fn wait(&self, id: MoveId, limit: Duration) -> Option<MoveReport> {
        let mut feed = self.subscribe(id)?;
        let _ = tokio::time::timeout(limit, feed.wait_for(|r| r.stage.is_final())).await;
        self.report(id)
    }

    /// Wakes on every status block the worker reads (and every link lost): what a cycle's wait
    /// decides on.
    #[must_use]
    pub fn watch_reads(&self) -> super::shared::Reads {
        self.shared.reads()
    }

    /// The robot as its worker last published it.
    #[must_use]
    pub fn snapshot(&self) -> super::shared::Snapshot {
        self.shared.snapshot()
    }

    /// How long ago the worker last read the status block (`None`: never since the link came).
    #[must_use]
    pub fn since_status_read(&self) -> Option<Duration> {
        self.shared.snapshot().since_read()
    }

    /// Whether a cycle waits on the inputs now: the worker then reads the status block at its
    /// busy pace.
    pub(crate) fn watch_inputs(&self, on: bool) {
        self.shared.inputs_watched.store(on, Ordering::Relaxed);
        if on {
            self.shared.read_soon.notify_one();
        }
    }

    /// Shuts `gate`, a prepared move's, and wakes the worker to end that move at once wherever
    /// it is (queued, uploading or held).
    pub(crate) fn shut_gate(&self, gate: &super::gate::Gate) {
        gate.shut();
        self.shared.read_soon.notify_one();
    }

    /// This handle acting under the PLC's incident count `epoch` (a cycle's, from its start or
    /// its last resume): what it asks for is refused, or not carried out, once another incident
    /// came.
    pub(crate) fn under(&self, epoch: u64) -> Self {
        Self {
            epoch: Some(epoch),
            ..self.clone()
        }
    }

    /// This handle with the gateway's lists and the cell's signals and programs as they are now,
    /// unchanged by a later reload (a cycle's, which runs as it was checked).
    pub(crate) fn pinned(&self) -> Self {
        Self {
            live: self.live.pinned(),
            ..self.clone()
        }
    }

    /// A reload's new gateway lists: the next register request and cycle check use them (the
    /// Modbus face stays as it was started).
    pub(crate) fn reload_access(&self, access: crate::gateway::AccessList) {
        self.live.set_access(access);
    }

    /// A reload's new cell signals, programs directory and `require_wait_timeout`: the next
    /// order and cycle use them (the cell face stays as it was started).
    pub(crate) fn reload_cell(&self, cell: crate::config::CellSettings) {
        self.live.set_cell(cell);
    }

    /// What happened since this handle's epoch, if anything did.
    fn untrusted(&self) -> Option<String> {
        let epoch = self.epoch?;
        let incidents = self.shared.snapshot().incidents;
        (incidents.count != epoch).then(|| incidents.last.unwrap_or_default())
    }

    /// The PLC's incidents so far (a restart, a stall or PROG mode, a link lost past a move's
    /// end): a cycle faults on every one, whatever its step.
    #[must_use]
    pub fn incidents(&self) -> super::shared::Incidents {
        self.shared.snapshot().incidents
    }

    /// The snapshot as the worker publishes it, waking on every change (every status read,
    /// every incident: [`Self::incidents`]).
    #[must_use]
    pub fn watch_snapshot(&self) -> watch::Receiver<super::shared::Snapshot> {
        self.shared.watch()
    }

    /// How long ago the robot's worker last went round its loop.
    #[must_use]
    pub fn since_worker_beat(&self) -> Option<Duration> {
        self.shared.since_loop_beat()
    }
}

/// The daemon: a worker per robot.
#[derive(Debug)]
pub struct Daemon {
    robots: BTreeMap<String, RobotHandle>,
    shutdown: watch::Sender<bool>,
    workers: JoinSet<String>,
}

impl Daemon {
    /// Spawns a worker for each robot.
    #[must_use]
    pub fn spawn(robots: Vec<RobotSetup>, options: &DaemonOptions) -> Self {
        let (shutdown, _) = watch::channel(false);
        let mut handles = BTreeMap::new();
        let mut workers = JoinSet::new();
        let metrics = super::metrics::Metrics::new();
        for setup in robots {
            let name = setup.robot.name.clone();
            let (shared, publisher) =
                Shared::new(&name, Arc::clone(&options.ids), metrics.robot(&name));
            let shared = Arc::new(shared);
            let (requests, requests_rx) = mpsc::unbounded_channel();
            let (stops, stops_rx) = mpsc::unbounded_channel();
            let (gateway, gateway_rx) = mpsc::unbounded_channel();
            let handle = RobotHandle {
                robot: Arc::new(setup.robot.clone()),
                requests,
                stops,
                gateway,
                live: Live::new(LiveSettings {
                    gateway: setup.gateway.clone(),
                    cell: setup.cell.clone(),
                }),
                shared: Arc::clone(&shared),
                positions: Arc::clone(&options.positions),
                cell: Arc::new(Cell::new(&setup.cell, setup.settings.layout.inputs)),
                cycles: Arc::new(CycleSlot::default()),
                lane: Arc::default(),
                epoch: None,
                speed_override: Arc::new(std::sync::atomic::AtomicU8::new(100)),
                journal: options.journal.clone(),
            };
            let worker = Worker::new(
                setup,
                options,
                Channels {
                    requests: requests_rx,
                    stops: stops_rx,
                    gateway: gateway_rx,
                    shutdown: shutdown.subscribe(),
                },
                shared,
                publisher,
            );
            let task_name = name.clone();
            workers.spawn(async move {
                worker.run().await;
                task_name
            });
            handles.insert(name, handle);
        }
        Self {
            robots: handles,
            shutdown,
            workers,
        }
    }

    /// The robots, by name.
    #[must_use]
    pub fn robots(&self) -> &BTreeMap<String, RobotHandle> {
        &self.robots
    }

    /// A robot by name.
    #[must_use]
    pub fn robot(&self, name: &str) -> Option<&RobotHandle> {
        self.robots.get(name)
    }

    /// Completes when a worker ends before shutdown (it panicked), with what happened.
    pub async fn worker_failed(&mut self) -> String {
        match self.workers.join_next().await {
            Some(Ok(name)) => format!("the worker of robot {name:?} ended"),
            Some(Err(e)) if e.is_panic() => format!("a robot's worker panicked: {e}"),
            Some(Err(e)) => format!("a robot's worker was cancelled: {e}"),
            None => std::future::pending().await,
        }
    }

    /// Shuts every worker down cleanly (no half-written bank, no start left waiting) and waits
    /// for them.
    pub async fn shut_down(mut self) {
        let _ = self.shutdown.send(true);
        while self.workers.join_next().await.is_some() {}
    }

    /// Ends every worker at once, as a killed process would (no withdrawal, nothing written):
    /// for tests of a daemon restart.
    pub async fn kill(mut self) {
        self.workers.abort_all();
        while self.workers.join_next().await.is_some() {}
    }
}
