//! The daemon's face to the rest of the program: one handle per robot, a thin sender of
//! requests to the owners of the robot's state (its worker: moves, stops, home, clear-fault,
//! register jobs; its cycle's owner; its cell's owner) and a reader of what they publish (the
//! worker's snapshot and move reports, the cycle's status, the mode and the cell face). It
//! holds none of their state: `daemon/cycle` and `daemon/cell` add their requests to it
//! (`impl RobotHandle` there), and it imports neither.
//!
//! ```text
//!  API, CLI, console, cell face, cycles --> RobotHandle --Request/stop/Job--> worker
//!                                                      --CycleRequest------> cycle owner
//!                                                      --CellRequest-------> cell owner
//!                                          <--Snapshot, Moves, cycle status, CellView (published)
//! ```

mod pallets;
mod submit;

pub use pallets::{PalletCommand, PalletOpError};

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};

use super::gateway::{self, GatewayError, Job, Values};
use super::live::Live;
use super::pallets::{PalletCounters, Pallets};
use super::positions::{Position, PositionError, TaughtPositions, check_name, unix_now_s};
use super::request::{CellRequest, CommandError, ConflictReason, CycleRequest, Reply, Request};
use super::shared::{CellView, Shared};
use crate::cell::Mode;
use crate::config::FaceSettings;
use crate::contract::machine::Blocker;
use crate::contract::{CHANNELS, INPUT_WORDS, InputWord};
use crate::gateway::{Address, GatewaySettings, Range};
use crate::kinematics::JOINTS;
use crate::robot::Robot;
use crate::wire::{
    CycleState, CycleStatus, FaceRefusal, FaceState, MoveId, MoveReport, RobotPhase, RobotState,
};

/// One robot, as the API and the CLI see it.
#[derive(Debug, Clone)]
pub struct RobotHandle {
    pub(super) robot: Arc<Robot>,
    /// The requests this handle sends: to the worker, the cycle's owner and the cell's.
    to: Senders,
    /// The gateway's lists and the cell's signals and programs: a reload changes them.
    pub(super) live: Live,
    /// What the owners publish: the worker's snapshot and reports, the cycle, the cell.
    pub(super) shared: Arc<Shared>,
    pub(super) positions: Arc<TaughtPositions>,
    /// The input words the PLC copies into the status block (the robot's layout).
    pub(super) inputs: [InputWord; INPUT_WORDS],
    /// The cell face's settings, as started (`None`: the robot has none).
    face: Option<Arc<FaceSettings>>,
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
    /// The robots' frames, pallets and counters (`DaemonOptions::pallets`).
    pallets: Arc<Pallets>,
}

/// Where a handle's requests go.
#[derive(Debug, Clone)]
pub(super) struct Senders {
    /// To the worker: moves, homes, clear-faults.
    pub requests: mpsc::UnboundedSender<Request>,
    /// To the worker: stops (they overtake its other requests).
    pub stops: mpsc::UnboundedSender<Reply>,
    /// To the worker: register gateway jobs.
    pub gateway: mpsc::UnboundedSender<Job>,
    /// To the cycle's owner.
    pub cycles: mpsc::UnboundedSender<CycleRequest>,
    /// To the cell's owner.
    pub cell: mpsc::UnboundedSender<CellRequest>,
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
    /// A handle sending to `to` and reading `shared`.
    pub(super) fn new(
        robot: Robot,
        to: Senders,
        shared: Arc<Shared>,
        (live, positions, journal, pallets): (
            Live,
            Arc<TaughtPositions>,
            crate::journal::Journal,
            Arc<Pallets>,
        ),
        inputs: [InputWord; INPUT_WORDS],
        face: Option<FaceSettings>,
    ) -> Self {
        Self {
            robot: Arc::new(robot),
            to,
            live,
            shared,
            positions,
            inputs,
            face: face.map(Arc::new),
            lane: Arc::default(),
            epoch: None,
            speed_override: Arc::new(std::sync::atomic::AtomicU8::new(100)),
            journal,
            pallets,
        }
    }

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

    /// The pallets' counters of every robot of the daemon (kept in the state directory).
    #[must_use]
    pub fn pallet_counters(&self) -> &PalletCounters {
        &self.pallets.counters
    }

    /// The robot's pallets laid out with its taught positions now, checked against its reach.
    ///
    /// # Errors
    /// The first pallet that cannot be laid out or reached, naming the pallet and the slot.
    pub fn pallet_patterns(
        &self,
    ) -> Result<BTreeMap<String, crate::pallet::Pattern>, crate::pallet::PalletError> {
        self.pallets_laid_out(&self.taught_world()?)
    }

    /// The robot's pallets laid out with `taught` (world positions).
    pub(crate) fn pallets_laid_out(
        &self,
        taught: &BTreeMap<String, Position>,
    ) -> Result<BTreeMap<String, crate::pallet::Pattern>, crate::pallet::PalletError> {
        self.pallets.patterns(&self.robot, taught)
    }

    /// The robot's taught positions as it reaches them now: one kept in a frame carried by the
    /// frame as its points are taught now (its pose and counts those of the world pose).
    ///
    /// # Errors
    /// A position kept in a frame that cannot be resolved or reached, naming it.
    pub fn taught_world(&self) -> Result<BTreeMap<String, Position>, crate::pallet::PalletError> {
        let taught = self.positions.of(&self.robot.name);
        let none = crate::pallet::RobotPallets::default();
        let set = self.pallets.sets.get(&self.robot.name).unwrap_or(&none);
        set.world_positions(&self.robot, &taught)
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
    /// (replacing one of that name), in world coordinates or kept in `frame` (re-teaching the
    /// frame's points then moves it). Refused while the link is down or stalled, the robot is
    /// not homed or homing (its counts mean nothing), or a move runs or waits.
    pub fn save_position(&self, name: &str, frame: Option<&str>) -> Result<Saved, PositionError> {
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
        let world = self.robot.pose_of(&joint_counts);
        let pose = match frame {
            None => world.to_mm_deg(),
            Some(frame) => {
                let taught = self.positions.of(&self.robot.name);
                let none = crate::pallet::RobotPallets::default();
                let set = self.pallets.sets.get(&self.robot.name).unwrap_or(&none);
                set.in_frame(name, frame, &world, &taught)
                    .map_err(|e| PositionError::Frame {
                        source: Box::new(e),
                    })?
            }
        };
        let position = Position {
            pose,
            joint_counts,
            saved_unix_s: unix_now_s(),
            frame: frame.map(str::to_owned),
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
        // A stop always works, whoever runs the robot: a cycle ends with it (its control says
        // so before the stop is written).
        let _ = self.ask_cycle(CycleRequest::RobotStopped).await;
        self.stop_robot().await
    }

    /// Stops every channel and cancels every queued move, leaving the robot's cycle as it is
    /// (the cycle's own stop, when it faults).
    pub(crate) async fn stop_robot(&self) -> Result<(), CommandError> {
        self.shared.stop_pending.store(true, Ordering::SeqCst);
        let (tx, rx) = oneshot::channel();
        self.to
            .stops
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
        let cycle_faulted = self.cycle().is_some_and(|c| c.state == CycleState::Faulted);
        let cleared = match self.command(Request::ClearFault).await {
            Err(CommandError::Conflict {
                reason: ConflictReason::NoFault,
            }) if cycle_faulted => Ok(()),
            other => other,
        };
        // Only a clear that happened lets a faulted cycle be resumed.
        if cleared.is_ok() {
            let incidents = self.incidents().count;
            let _ = self
                .ask_cycle(|reply| CycleRequest::FaultCleared { incidents, reply })
                .await;
        }
        cleared
    }

    async fn command(&self, request: fn(Reply) -> Request) -> Result<(), CommandError> {
        let (tx, rx) = oneshot::channel();
        self.to
            .requests
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
        self.to
            .gateway
            .send(job)
            .map_err(|_| GatewayError::ShuttingDown)?;
        rx.await.map_err(|_| GatewayError::ShuttingDown)?
    }

    /// The robot's state as last read.
    #[must_use]
    pub fn state(&self) -> RobotState {
        let mut state = self.shared.snapshot().state;
        state.cycle = self.cycle();
        let cell = self.cell();
        state.mode = cell.mode;
        state.face = face_state(&cell);
        state
    }

    /// The robot's cycle, as its owner and driver last published it (`None`: none ran since
    /// the daemon started).
    #[must_use]
    pub fn cycle(&self) -> Option<CycleStatus> {
        self.shared.cycle.borrow().clone()
    }

    /// The mode and the cell face, as the cell's owner last published them.
    pub(crate) fn cell(&self) -> CellView {
        self.shared.cell.borrow().clone()
    }

    /// Who drives the robot.
    #[must_use]
    pub fn mode(&self) -> Mode {
        self.shared.cell.borrow().mode
    }

    /// The robot's cell face settings, if it has one.
    #[must_use]
    pub fn face_settings(&self) -> Option<&FaceSettings> {
        self.face.as_deref()
    }

    /// Whether the face holds every motion: remote mode with move-enable off.
    pub(crate) fn face_holds_motion(&self) -> bool {
        self.shared.cell.borrow().holds_motion()
    }

    /// Asks the cycle's owner: its answer, `None` once it is gone.
    pub(crate) async fn ask_cycle<T>(
        &self,
        request: impl FnOnce(oneshot::Sender<T>) -> CycleRequest,
    ) -> Option<T> {
        let (tx, rx) = oneshot::channel();
        self.to.cycles.send(request(tx)).ok()?;
        rx.await.ok()
    }

    /// Asks the cell's owner: its answer, `None` once it is gone.
    pub(crate) async fn ask_cell<T>(
        &self,
        request: impl FnOnce(oneshot::Sender<T>) -> CellRequest,
    ) -> Option<T> {
        let (tx, rx) = oneshot::channel();
        self.to.cell.send(request(tx)).ok()?;
        rx.await.ok()
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

/// The cell face's command side as the robot's state shows it.
fn face_state(cell: &CellView) -> Option<FaceState> {
    let face = cell.face.as_ref()?;
    Some(FaceState {
        program: face.selected().map_or(0, |(n, _)| u16::from(n)),
        program_name: face.selected().map(|(_, name)| name.to_owned()),
        enabled: face.enabled(),
        commands: face.words()[crate::cell::face::command::BITS],
        refused: face.refused().map(|r| FaceRefusal {
            code: r.code(),
            meaning: r.meaning().to_owned(),
        }),
    })
}
