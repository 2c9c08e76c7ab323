//! The operator's console's server (docs/CONSOLE.md): the page, a WebSocket per browser, the
//! API behind a session, and per robot a publisher (the live stream) and a control task (the
//! seat and the jog lease). The decisions are the pure `crate::console`'s; this is their shell.
//!
//! ```text
//! publish.rs  LiveHub: one publisher per robot, snapshot() in one place, pushed once to all
//! control.rs  Control: one task per robot owning its seat and its jog lease
//! session.rs  users (argon2 hashes, tokens), sessions, the cookie, the login limiter
//! server.rs   the routes, the guard (session, Origin, seat and role) in front of the API
//! ws.rs       the WebSocket: the stream out, jog and seat requests in
//! listen.rs   the TCP listener, its allow list, connections with upgrades
//! assets.rs   the page and its libraries, embedded
//! ```

mod assets;
mod control;
mod listen;
mod server;
mod session;
mod ws;

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::Arc;

use axum::Router;
use axum::routing::{get, post};
use serde::Serialize;
use tokio_util::sync::CancellationToken;

pub use super::stream::{
    CAPACITY, Frame, LiveHub, RobotStream, SnapshotSetup, Subscription, snapshot,
};
pub use assets::{ASSETS, Asset, INDEX, page_files};
pub use control::{Control, Request as ControlRequest, Who};
pub use listen::{admits, serve};
pub use session::{COOKIE, HashError, Sessions, UsersError, hash_password};

use super::RobotHandle;
use super::api::Api;
use crate::config::{CellSettings, ConsoleSettings, RobotConsoleSettings};
use crate::console::{LEASE, PIECE};
use crate::kinematics::Kinematics;

/// The client's address, put on every request by the listener.
#[derive(Debug, Clone, Copy)]
pub struct Peer(pub SocketAddr);

/// What every console route sees.
#[derive(Debug)]
pub struct ConsoleState {
    sessions: Sessions,
    controls: BTreeMap<String, Control>,
    hub: LiveHub,
    origins: Vec<String>,
    infos: Vec<RobotInfo>,
    /// Each robot's cycle programs' directory.
    programs: BTreeMap<String, Option<std::path::PathBuf>>,
    handles: BTreeMap<String, RobotHandle>,
    closing: CancellationToken,
}

/// A robot as the page draws it: what does not change while the daemon runs.
#[derive(Debug, Clone, Serialize)]
pub struct RobotInfo {
    /// Its name.
    pub name: String,
    /// Its kinematic model (`cylindrical`, `cartesian`, `scara`) and dimensions, mm.
    pub kinematics: serde_json::Value,
    /// Its joints: name, unit (`deg` or `mm`), limits.
    pub joints: Vec<serde_json::Value>,
    /// The jog's speed cap, mm/s.
    pub manual_speed_mm_s: f64,
    /// The lease and a piece, ms.
    pub lease_ms: u64,
    /// One piece's motion, ms.
    pub piece_ms: u64,
    /// Whether it has a cell face (remote mode possible).
    pub face: bool,
    /// Its cycle programs' directory, if any.
    pub programs: bool,
}

/// The console: its state and its routes.
#[derive(Debug, Clone)]
pub struct Console {
    state: Arc<ConsoleState>,
    api: Api,
}

impl Console {
    /// The console of `robots` (their stream in `hub`, the API `api` behind its guard), with a
    /// control task per robot, running until `closing`.
    pub fn new(
        settings: &ConsoleSettings,
        per_robot: &BTreeMap<String, RobotConsoleSettings>,
        cells: &BTreeMap<String, CellSettings>,
        robots: &BTreeMap<String, RobotHandle>,
        hub: LiveHub,
        api: Api,
        closing: &CancellationToken,
    ) -> Result<Self, UsersError> {
        let sessions = Sessions::new(settings)?;
        let mut controls = BTreeMap::new();
        let mut infos = Vec::new();
        let mut dirs = BTreeMap::new();
        for (name, handle) in robots {
            let manual = per_robot.get(name).copied().unwrap_or_default();
            if let Some(stream) = hub.robot(name) {
                controls.insert(
                    name.clone(),
                    Control::start(
                        handle.clone(),
                        stream,
                        manual.manual_speed_mm_s,
                        closing.clone(),
                    ),
                );
            }
            let programs = cells.get(name).and_then(|c| c.programs.clone());
            infos.push(info(handle, manual.manual_speed_mm_s, programs.is_some()));
            dirs.insert(name.clone(), programs);
        }
        Ok(Self {
            state: Arc::new(ConsoleState {
                sessions,
                controls,
                hub,
                origins: settings.origins.clone(),
                infos,
                programs: dirs,
                handles: robots.clone(),
                closing: closing.clone(),
            }),
            api,
        })
    }

    /// The routes: the page, login, the WebSocket, and the API behind the guard.
    pub fn router(&self) -> Router {
        let guarded = self
            .api
            .router(None)
            .layer(axum::middleware::from_fn_with_state(
                Arc::clone(&self.state),
                server::guard,
            ));
        Router::new()
            .route("/", get(server::index))
            .route("/assets/{*file}", get(server::asset))
            .route("/console/login", post(server::login))
            .route("/console/logout", post(server::logout))
            .route("/console/session", get(server::session))
            .route("/console/robots", get(server::robots))
            .route("/console/robots/{name}/programs", get(server::programs))
            .route("/console/ws", get(ws::upgrade))
            .with_state(Arc::clone(&self.state))
            .fallback_service(guarded)
    }
}

fn info(handle: &RobotHandle, manual_speed_mm_s: f64, programs: bool) -> RobotInfo {
    let robot = handle.robot();
    let params: serde_json::Map<String, serde_json::Value> = robot
        .kinematics
        .params()
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.into()))
        .collect();
    let joints = robot
        .joints
        .iter()
        .map(|j| {
            serde_json::json!({
                "name": j.name,
                "unit": if j.kind == crate::kinematics::JointKind::Revolute { "deg" } else { "mm" },
                "min": j.user(j.min),
                "max": j.user(j.max),
            })
        })
        .collect();
    RobotInfo {
        name: robot.name.clone(),
        kinematics: serde_json::json!({"type": robot.kinematics.name(), "params": params}),
        joints,
        manual_speed_mm_s,
        lease_ms: LEASE.as_millis() as u64,
        piece_ms: PIECE.as_millis() as u64,
        face: handle.face_settings().is_some(),
        programs,
    }
}
