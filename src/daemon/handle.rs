//! The daemon's face to the rest of the program: one handle per robot (submit a move, stop,
//! clear a fault, read state and reports, follow a move's progress) and the daemon that spawns a
//! worker per robot and shuts them down.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use thiserror::Error;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::JoinHandle;

use super::order::{MoveOrder, OrderError};
use super::report::{MoveId, MoveReport, Moves, RobotState};
use super::worker::{Connector, Request, Worker};
use crate::kinematics::JOINTS;
use crate::plan::PlanError;
use crate::plc::contract::ContractSettings;
use crate::robot::Robot;

/// State shared by a robot's worker and its handle.
#[derive(Debug)]
pub(super) struct Shared {
    state: Mutex<RobotState>,
    moves: Mutex<Moves>,
    /// Set when a stop is asked for: an upload in progress gives up at its next write.
    pub stop_pending: Arc<AtomicBool>,
    ids: Arc<AtomicU64>,
    /// Where the last accepted order is planned to end, per joint (for checking the next).
    planned_end: Mutex<Option<[i64; JOINTS]>>,
}

impl Shared {
    pub(super) fn state<T>(&self, f: impl FnOnce(&mut RobotState) -> T) -> T {
        f(&mut self.state.lock().expect("state lock"))
    }

    pub(super) fn moves<T>(&self, f: impl FnOnce(&mut Moves) -> T) -> T {
        f(&mut self.moves.lock().expect("moves lock"))
    }

    /// Forgets where queued orders were planned to end (after a move that will not get there).
    pub(super) fn forget_planned_end(&self) {
        *self.planned_end.lock().expect("lock") = None;
    }

    pub(super) fn next_id(&self) -> MoveId {
        self.ids.fetch_add(1, Ordering::SeqCst) + 1
    }
}

/// Why a move was not accepted.
#[derive(Debug, Error)]
pub enum SubmitError {
    /// A field of the order is wrong.
    #[error(transparent)]
    Order(#[from] OrderError),
    /// The move cannot be planned from where the robot is (or will be).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
}

/// Why a stop or clear-fault did not reach the PLC.
#[derive(Debug, Error)]
#[error("{0}")]
pub struct CommandError(pub String);

/// One robot, as the API and the CLI see it.
#[derive(Debug, Clone)]
pub struct RobotHandle {
    robot: Arc<Robot>,
    requests: mpsc::UnboundedSender<Request>,
    stops: mpsc::UnboundedSender<oneshot::Sender<Result<(), String>>>,
    shared: Arc<Shared>,
}

impl RobotHandle {
    /// The robot.
    #[must_use]
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Checks an order, plans it from where the robot will be when its turn comes (refusing it,
    /// with nothing queued, if that fails), and queues it.
    ///
    /// # Panics
    /// If a lock was poisoned by a panic elsewhere.
    pub fn submit(&self, order: MoveOrder) -> Result<MoveId, SubmitError> {
        let checked = order.check(self.robot.motion)?;
        let from = self.shared.planned_end.lock().expect("lock").or_else(|| {
            let counts = self.shared.state(|s| s.counts)?;
            Some(std::array::from_fn(|j| {
                counts[usize::from(self.robot.joints[j].channel)]
            }))
        });
        let mut end = None;
        if let Some(counts) = from {
            end = Some(super::worker::plan_order(&self.robot, &checked, counts)?.end_counts());
        }
        let id = self.shared.next_id();
        self.shared
            .moves(|m| m.insert(MoveReport::new(id, &self.robot.name, order)));
        self.shared.state(|s| s.queued.push(id));
        self.requests
            .send(Request::Move(id, checked))
            .map_err(|_| SubmitError::ShuttingDown)?;
        *self.shared.planned_end.lock().expect("lock") = end;
        Ok(id)
    }

    /// Stops every channel and cancels every queued move; returns once the stop is written.
    ///
    /// # Panics
    /// If a lock was poisoned by a panic elsewhere.
    pub async fn stop(&self) -> Result<(), CommandError> {
        self.shared.stop_pending.store(true, Ordering::SeqCst);
        *self.shared.planned_end.lock().expect("lock") = None;
        let (tx, rx) = oneshot::channel();
        self.stops
            .send(tx)
            .map_err(|_| CommandError("the daemon is shutting down".into()))?;
        rx.await
            .map_err(|_| CommandError("the daemon is shutting down".into()))?
            .map_err(CommandError)
    }

    /// Clears a latched fault on the PLC.
    pub async fn clear_fault(&self) -> Result<(), CommandError> {
        let (tx, rx) = oneshot::channel();
        self.requests
            .send(Request::ClearFault(tx))
            .map_err(|_| CommandError("the daemon is shutting down".into()))?;
        rx.await
            .map_err(|_| CommandError("the daemon is shutting down".into()))?
            .map_err(CommandError)
    }

    /// The robot's state as last read.
    #[must_use]
    pub fn state(&self) -> RobotState {
        self.shared.state(|s| s.clone())
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
}

/// The daemon: a worker per robot.
#[derive(Debug)]
pub struct Daemon {
    robots: BTreeMap<String, RobotHandle>,
    shutdown: watch::Sender<bool>,
    workers: Vec<JoinHandle<()>>,
}

impl Daemon {
    /// Spawns a worker for each robot with its link opener and contract settings.
    #[must_use]
    pub fn spawn(robots: Vec<(Robot, ContractSettings, Connector)>) -> Self {
        let (shutdown, _) = watch::channel(false);
        let ids = Arc::new(AtomicU64::new(0));
        let mut handles = BTreeMap::new();
        let mut workers = Vec::new();
        for (robot, settings, connect) in robots {
            let shared = Arc::new(Shared {
                state: Mutex::new(RobotState {
                    name: robot.name.clone(),
                    ..RobotState::default()
                }),
                moves: Mutex::new(Moves::default()),
                stop_pending: Arc::new(AtomicBool::new(false)),
                ids: Arc::clone(&ids),
                planned_end: Mutex::new(None),
            });
            let (requests, requests_rx) = mpsc::unbounded_channel();
            let (stops, stops_rx) = mpsc::unbounded_channel();
            let worker = Worker::new(
                robot.clone(),
                settings,
                connect,
                requests_rx,
                stops_rx,
                shutdown.subscribe(),
                Arc::clone(&shared),
            );
            workers.push(tokio::spawn(worker.run()));
            handles.insert(
                robot.name.clone(),
                RobotHandle {
                    robot: Arc::new(robot),
                    requests,
                    stops,
                    shared,
                },
            );
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

    /// Shuts every worker down cleanly (no half-written bank, no start left waiting) and waits
    /// for them.
    pub async fn shut_down(self) {
        let _ = self.shutdown.send(true);
        for w in self.workers {
            let _ = w.await;
        }
    }
}
