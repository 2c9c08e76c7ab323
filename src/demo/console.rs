//! `linterpd demo --console`, and the rig of the console's tests: the seed's robot on a mock
//! FP-X in process behind an emulated serial line, in the simulated press cell
//! (`config/examples/cells/press.toml`, its cycle program `press-load`), the daemon with its live
//! stream, and the console on a TCP listener with one user per role.
//!
//! ```text
//!  MockPlc (press cell, pulse trace) <-MEWTOCOL-COM, emulated 115200-baud line-> worker
//!  LiveHub (one publisher) -> Console (page, WebSocket, API behind the guard) on `listen`
//! ```

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::PathBuf;

use tokio_util::sync::CancellationToken;

use super::press::{press_cell, press_robot, write_programs};
use super::rig::{self, Rig};
use super::{DEFAULT_BAUD, DemoError, DemoLink, P1};
use crate::config::{CellSettings, ConsoleSettings, ConsoleUser, RobotConsoleSettings, Secret};
use crate::console::Role;
use crate::daemon::api::Api;
use crate::daemon::console::{Console, LiveHub, SnapshotSetup, hash_password};
use crate::daemon::{Daemon, DaemonOptions, RobotHandle};
use crate::mock::SharedMock;
use crate::plc::exchange::ContractSettings;
use crate::robot::seed_robot;

/// The demo's users, as `(name, role, password)`: one per role.
pub const USERS: [(&str, Role, &str); 3] = [
    ("operator", Role::Operator, "operator-demo"),
    ("viewer", Role::Viewer, "viewer-demo"),
    ("admin", Role::Admin, "admin-demo"),
];

/// How the console rig runs.
#[derive(Debug, Clone)]
pub struct ConsoleOptions {
    /// Where the console listens (port 0: any free port).
    pub listen: SocketAddr,
    /// The emulated line's speed (`None`: as fast as the pipe).
    pub baud: Option<u32>,
    /// Pages on other origins allowed (`[console] origins`).
    pub origins: Vec<String>,
    /// The robot's manual speed, mm/s.
    pub manual_speed_mm_s: f64,
}

impl Default for ConsoleOptions {
    fn default() -> Self {
        Self {
            listen: "127.0.0.1:8470".parse().expect("an address"),
            baud: Some(DEFAULT_BAUD),
            origins: Vec::new(),
            manual_speed_mm_s: crate::console::DEFAULT_MANUAL_SPEED_MM_S,
        }
    }
}

/// The running rig.
pub struct ConsoleRig {
    /// The mock PLC (its pulse trace, its cell's inputs).
    pub mock: SharedMock,
    /// The robot's handle.
    pub handle: RobotHandle,
    /// Where the console listens.
    pub addr: SocketAddr,
    /// The live streams.
    pub hub: LiveHub,
    daemon: Option<Daemon>,
    closing: CancellationToken,
    rig: Option<Rig>,
    dir: PathBuf,
}

impl std::fmt::Debug for ConsoleRig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConsoleRig")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl ConsoleRig {
    /// Starts the mock, the daemon and the console; returns once the daemon has read the PLC.
    ///
    /// # Panics
    /// Never: the demo's ranges and address are written here and parse.
    pub async fn start(options: ConsoleOptions) -> Result<Self, DemoError> {
        let robot = seed_robot();
        let rig = Rig::start(&robot, P1, robot.motion.frequency_model)?;
        let dir = std::env::temp_dir().join(format!(
            "linterpd-console-{}-{}",
            std::process::id(),
            rig.mock.now_s().to_bits()
        ));
        write_programs(&dir)?;
        let cell = press_cell(&rig, &dir)?;
        let connect = rig.connector(options.baud, DemoLink::Mewtocol { long_frames: false });
        let setup = press_robot(&robot, ContractSettings::default(), connect, cell.clone())?;
        let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
        let handle = daemon
            .robot(&robot.name)
            .cloned()
            .ok_or_else(|| DemoError::Rig("the daemon has no robot".into()))?;
        rig::connected(&handle).await?;
        let (hub, addr, closing) = serve_console(&options, &daemon, &robot.name, cell).await?;
        Ok(Self {
            mock: rig.mock.clone(),
            handle,
            addr,
            hub,
            daemon: Some(daemon),
            closing,
            rig: Some(rig),
            dir,
        })
    }

    /// The console's address as a page's origin, `http://127.0.0.1:PORT`.
    #[must_use]
    pub fn origin(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// Stops the console, the daemon and the mock.
    pub async fn stop(mut self) {
        self.closing.cancel();
        if let Some(daemon) = self.daemon.take() {
            daemon.shut_down().await;
        }
        if let Some(rig) = self.rig.take() {
            rig.stop();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The live streams and the console over `daemon`'s robot `name`, served on `options.listen`:
/// the hub, the address it listens on and the token that closes it.
async fn serve_console(
    options: &ConsoleOptions,
    daemon: &Daemon,
    name: &str,
    cell: CellSettings,
) -> Result<(LiveHub, SocketAddr, CancellationToken), DemoError> {
    let api = Api::new(daemon.robots().clone());
    let closing = api.closing();
    let setups = BTreeMap::from([(
        name.to_owned(),
        SnapshotSetup {
            cell: cell.clone(),
            inputs: Some(crate::contract::Layout::default().inputs),
        },
    )]);
    let hub = LiveHub::start(daemon.robots(), &setups, &closing);
    let api = api.with_live(hub.clone());
    let settings = settings(options)?;
    let per_robot = BTreeMap::from([(
        name.to_owned(),
        RobotConsoleSettings {
            manual_speed_mm_s: options.manual_speed_mm_s,
        },
    )]);
    let cells = BTreeMap::from([(name.to_owned(), cell)]);
    let console = Console::new(
        &settings,
        &per_robot,
        &cells,
        daemon.robots(),
        hub.clone(),
        api,
        &closing,
    )
    .map_err(|e| DemoError::Rig(e.to_string()))?;
    let listener = tokio::net::TcpListener::bind(options.listen)
        .await
        .map_err(|e| DemoError::Rig(format!("cannot listen on {}: {e}", options.listen)))?;
    let addr = listener
        .local_addr()
        .map_err(|e| DemoError::Rig(e.to_string()))?;
    tokio::spawn(crate::daemon::console::serve(
        listener,
        console.router(),
        Vec::new(),
        closing.clone().cancelled_owned(),
    ));
    Ok((hub, addr, closing))
}

/// The console's settings: the demo's users, their passwords hashed now.
fn settings(options: &ConsoleOptions) -> Result<ConsoleSettings, DemoError> {
    let mut users = BTreeMap::new();
    for (name, role, password) in USERS {
        let hash = hash_password(password).map_err(DemoError::Rig)?;
        users.insert(
            name.to_owned(),
            ConsoleUser {
                role,
                secret: Secret::PasswordHash(hash),
            },
        );
    }
    Ok(ConsoleSettings {
        listen: options.listen,
        allow: Vec::new(),
        origins: options.origins.clone(),
        session: std::time::Duration::from_secs(3600),
        users,
    })
}
