//! The daemon: per robot, its worker (the link's owner), its cycle's owner and its cell's
//! owner, spawned together with the handle that sends them requests; it watches that the
//! workers make progress and shuts them down.

use std::collections::BTreeMap;
use std::sync::Arc;

use tokio::sync::{mpsc, watch};
use tokio::task::JoinSet;

use super::handle::{RobotHandle, Senders};
use super::ids::MoveIds;
use super::live::{Live, LiveSettings};
use super::metrics::RobotMetrics;
use super::setup::{DaemonOptions, RobotSetup};
use super::shared::Shared;
use super::worker::{Channels, Worker};

/// The daemon: a worker, a cycle owner and a cell owner per robot.
#[derive(Debug)]
pub struct Daemon {
    robots: BTreeMap<String, RobotHandle>,
    shutdown: watch::Sender<bool>,
    workers: JoinSet<String>,
}

impl Daemon {
    /// Spawns a worker, a cycle owner and a cell owner for each robot.
    #[must_use]
    pub fn spawn(robots: Vec<RobotSetup>, options: &DaemonOptions) -> Self {
        let (shutdown, _) = watch::channel(false);
        let mut handles = BTreeMap::new();
        let mut workers = JoinSet::new();
        let metrics = super::metrics::Metrics::new();
        for setup in robots {
            let name = setup.robot.name.clone();
            let shared = (Arc::clone(&options.ids), metrics.robot(&name));
            let (handle, worker) = spawn_robot(setup, options, shared, &shutdown);
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

/// The handle of robot `setup`, sending `to` its owners and reading `shared`.
fn handle_of(
    setup: &RobotSetup,
    options: &DaemonOptions,
    to: Senders,
    shared: Arc<Shared>,
) -> RobotHandle {
    let live = Live::new(LiveSettings {
        gateway: setup.gateway.clone(),
        cell: setup.cell.clone(),
    });
    RobotHandle::new(
        setup.robot.clone(),
        to,
        shared,
        (
            live,
            Arc::clone(&options.positions),
            options.journal.clone(),
            Arc::clone(&options.pallets),
        ),
        setup.settings.layout.inputs,
        setup.cell.face.clone(),
    )
}

/// One robot's handle and worker, its cycle's and its cell's owners spawned.
fn spawn_robot(
    setup: RobotSetup,
    options: &DaemonOptions,
    ids_and_metrics: (Arc<MoveIds>, RobotMetrics),
    shutdown: &watch::Sender<bool>,
) -> (RobotHandle, Worker) {
    let (cycle_out, cycle) = watch::channel(None);
    let (cell_owner, cell) = super::cell::start(&setup.cell);
    let (shared, publisher) = Shared::new(&setup.robot.name, ids_and_metrics, cycle, cell);
    let shared = Arc::new(shared);
    let (requests, requests_rx) = mpsc::unbounded_channel();
    let (stops, stops_rx) = mpsc::unbounded_channel();
    let (gateway, gateway_rx) = mpsc::unbounded_channel();
    let (cycles, cycles_rx) = mpsc::unbounded_channel();
    let (cell_tx, cell_rx) = mpsc::unbounded_channel();
    let to = Senders {
        requests,
        stops,
        gateway,
        cycles,
        cell: cell_tx,
    };
    let handle = handle_of(&setup, options, to, Arc::clone(&shared));
    tokio::spawn(super::cycle::own(Arc::new(cycle_out), cycles_rx));
    let cell_requests = (cell_rx, shutdown.subscribe());
    tokio::spawn(super::cell::own(cell_owner, handle.clone(), cell_requests));
    let channels = Channels {
        requests: requests_rx,
        stops: stops_rx,
        gateway: gateway_rx,
        shutdown: shutdown.subscribe(),
    };
    let worker = Worker::new(setup, options, channels, shared, publisher);
    (handle, worker)
}
