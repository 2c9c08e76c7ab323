//! The daemon on a mock PLC in process with its API on a Unix socket, as the end-to-end tests of
//! moves, jogs, positions and paths use it.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use hyper::StatusCode;
use linterpd::daemon::api::Api;
use linterpd::daemon::{
    Connector, Daemon, DaemonOptions, MoveReport, RobotHandle, TaughtPositions,
};
use linterpd::kinematics::JOINTS;
use linterpd::mock::SharedMock;
use linterpd::plc::exchange::ContractSettings;
use serde_json::Value;
use tokio::net::UnixListener;

use super::daemon::{duplex_connector, spawn_with};
use super::http::{Answer, Endpoint};

/// How long a move may take in these tests.
pub const LIMIT: Duration = Duration::from_secs(15);
/// The seed robot's API path.
pub const ROBOT: &str = "/v1/robots/press-loader";

/// The daemon on `shared`, its positions in `state` (in memory without one), its API on a Unix
/// socket in `dir`.
pub struct Served {
    pub daemon: Daemon,
    pub handle: RobotHandle,
    pub api: Endpoint,
}

impl Served {
    pub async fn start(
        shared: &SharedMock,
        state: Option<&Path>,
        dir: &Path,
        socket: &str,
    ) -> Self {
        Self::start_on(duplex_connector(shared, None), shared, state, dir, socket).await
    }

    /// [`Self::start`] over `connect`'s links to `shared`.
    pub async fn start_on(
        connect: Connector,
        shared: &SharedMock,
        state: Option<&Path>,
        dir: &Path,
        socket: &str,
    ) -> Self {
        let positions =
            state.map_or_else(TaughtPositions::in_memory, TaughtPositions::in_state_dir);
        let options = DaemonOptions {
            positions: Arc::new(positions),
            ..DaemonOptions::default()
        };
        Self::start_with(connect, shared, &options, dir, socket).await
    }

    /// [`Self::start_on`] with the daemon's `options`.
    pub async fn start_with(
        connect: Connector,
        shared: &SharedMock,
        options: &DaemonOptions,
        dir: &Path,
        socket: &str,
    ) -> Self {
        let (daemon, handle) =
            spawn_with(connect, ContractSettings::default(), options, [0; JOINTS]);
        let path = dir.join(socket);
        let listener = UnixListener::bind(&path).unwrap();
        let api = Api::new(daemon.robots().clone());
        let hub = linterpd::daemon::console::LiveHub::start(
            daemon.robots(),
            &std::collections::BTreeMap::new(),
            &api.closing(),
        );
        let router = api.with_live(hub).router(None);
        tokio::spawn(linterpd::daemon::api::serve(
            listener,
            router,
            std::future::pending(),
        ));
        wait_connected(&handle, shared).await;
        Self {
            daemon,
            handle,
            api: Endpoint::unix(&path),
        }
    }

    /// Posts a path (`POST .../paths`) and returns the ids of its moves, one per start.
    #[allow(dead_code)] // not every test binary posts paths
    pub async fn post_path(&self, body: &Value) -> Vec<u64> {
        let answer = self
            .api
            .post(&format!("{ROBOT}/paths"), &body.to_string())
            .await;
        assert_eq!(answer.status, StatusCode::ACCEPTED, "{}", answer.text());
        answer.json()["ids"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect()
    }

    /// Posts an order and waits for its end.
    pub async fn run(&self, order: &Value) -> MoveReport {
        let answer = self
            .api
            .post(&format!("{ROBOT}/moves"), &order.to_string())
            .await;
        assert_eq!(answer.status, StatusCode::ACCEPTED, "{}", answer.text());
        let id = answer.json()["id"].as_u64().unwrap();
        self.handle.wait(id, LIMIT).await.unwrap()
    }

    pub async fn call(&self, method: &str, path: &str) -> Answer {
        self.api
            .call(method, &format!("{ROBOT}/{path}"), None, None)
            .await
    }
}

/// Until the daemon takes moves: connected, nothing refusing them, the mock's counts read.
pub async fn wait_connected(h: &RobotHandle, shared: &SharedMock) {
    for _ in 0..500 {
        let s = h.state();
        let counts = shared.with(|m| m.status().elapsed.map(i64::from));
        if s.link.connected
            && s.refuses.is_none()
            && s.counts == Some(counts)
            && s.phase == linterpd::daemon::RobotPhase::Idle
        {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("never connected: {:?}", h.state());
}
