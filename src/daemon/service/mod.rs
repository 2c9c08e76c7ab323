//! `linterpd serve` as a library function: a worker per configured robot on its PLC link, the API
//! on the Unix socket (and a TCP listener when configured), and the conversation with systemd.
//!
//! ```text
//! lock the socket -> bind socket(s), Modbus faces -> spawn Daemon -> READY=1 -> serve ...
//!   STATUS= on change, WATCHDOG=1 while every worker makes progress (supervise.rs)
//!   SIGHUP: the config is read again, checked and compared whole (reload.rs): the gateway's
//!     lists and the cell's signals and programs are applied; the rest is named, section and
//!     key, as needing a restart; a config that does not load is refused, the running one kept
//!   a worker that dies: the daemon exits non-zero (systemd restarts it)
//!   shutdown signal -> STOPPING=1 -> stop accepting, end event streams -> Daemon::shut_down
//! ```

mod reload;
mod socket;
mod supervise;

pub use reload::{Change, ReloadError, Reloaded, Running};
pub use socket::{bind_unix, lock, lock_path};
pub use supervise::{healthy, status_line};

use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use thiserror::Error;
use tokio::net::TcpListener;
use tokio::task::JoinSet;

use super::api::{self, Api, BearerToken, TokenError};
use super::console::{Console, LiveHub, SnapshotSetup, UsersError};
use super::modbus_face::ModbusFaceServer;
use super::notify::Notifier;
use super::pallets::{PalletCounters, Pallets};
use super::{Connector, Daemon, DaemonOptions, MoveIds, RobotSetup, TaughtPositions, host_word};
use crate::config::{Config, DaemonSettings};
use crate::contract::machine::WatchSettings;
use crate::journal::Journal;
use crate::pallet::RobotPallets;
use crate::plc::exchange::ContractSettings;
use crate::plc::{self, LinkSettings};
use crate::wire::journal::Kind;

/// Longest wait for open connections after the daemon has shut down.
const DRAIN: Duration = Duration::from_secs(3);

/// Why the daemon could not start or keep serving.
#[derive(Debug, Error)]
pub enum ServeError {
    /// A robot has no `[robots.NAME.plc]` table.
    #[error("robot {robot:?} has no [robots.{robot}.plc] table: the daemon cannot reach its PLC")]
    NoLink {
        /// The robot.
        robot: String,
    },
    /// The token file cannot be used.
    #[error(transparent)]
    Token(#[from] TokenError),
    /// A console user's token file cannot be used.
    #[error(transparent)]
    ConsoleUsers(#[from] UsersError),
    /// A socket could not be set up.
    #[error("cannot {operation} {}", target.display())]
    Socket {
        /// What was being done (`bind`, `remove the stale socket`, `set the mode of`).
        operation: &'static str,
        /// The socket path or address.
        target: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The socket's directory is missing and cannot be made.
    #[error(
        "cannot create the socket's directory {} ([daemon] socket = \"{}\"): set [daemon] socket \
         to a path in a directory you may write (config/try.toml: a user's directory), or run the \
         service, whose RuntimeDirectory= makes /run/linterpd",
        dir.display(),
        socket.display()
    )]
    SocketDir {
        /// The directory.
        dir: PathBuf,
        /// The socket, as configured.
        socket: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// Another daemon holds the socket's lock.
    #[error(
        "another linterpd daemon already serves {} (it holds {}): stop it first, or give this one \
         another socket",
        socket.display(),
        lock.display()
    )]
    AlreadyRunning {
        /// The socket.
        socket: PathBuf,
        /// Its lock file.
        lock: PathBuf,
    },
    /// The state directory is missing and cannot be made (or is not a directory).
    #[error(
        "cannot create the state directory {} ([daemon] state_dir) with mode 0750",
        path.display()
    )]
    StateDir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The journal cannot be opened in the state directory.
    #[error(transparent)]
    Journal(#[from] crate::journal::JournalError),
    /// A listener failed while serving.
    #[error("the API listener failed")]
    Serve(#[source] io::Error),
    /// A robot's worker ended (it panicked): the daemon cannot go on without it.
    #[error("{0}")]
    WorkerFailed(String),
}

/// The daemon's robots with their contract settings and link openers, from a config; every robot
/// needs a PLC link.
pub fn robots_from_config(config: &Config) -> Result<Vec<RobotSetup>, ServeError> {
    config
        .robots
        .iter()
        .map(|robot| {
            let link = config.link(&robot.name).ok_or_else(|| ServeError::NoLink {
                robot: robot.name.clone(),
            })?;
            if !link.read_back {
                tracing::warn!(
                    robot = %robot.name,
                    "read_back = false: uploads are not read back before their start; each write \
                     is trusted on the PLC's acknowledgement (its BCC or CRC check) alone"
                );
            }
            Ok(RobotSetup {
                robot: robot.clone(),
                settings: contract_settings(link),
                connect: connector(link.clone()),
                home_counts: link.home_counts,
                gateway: config.gateway(&robot.name).cloned().unwrap_or_default(),
                cell: config.cells.get(&robot.name).cloned().unwrap_or_default(),
            })
        })
        .collect()
}

/// What each robot's live snapshot needs from the config: its cell's signals and the input
/// words its PLC copies.
#[must_use]
pub fn snapshot_setups(config: &Config) -> std::collections::BTreeMap<String, SnapshotSetup> {
    config
        .robots
        .iter()
        .map(|r| {
            let setup = SnapshotSetup {
                cell: config.cells.get(&r.name).cloned().unwrap_or_default(),
                inputs: config.link(&r.name).map(|l| l.layout.inputs),
            };
            (r.name.clone(), setup)
        })
        .collect()
}

/// The contract settings a link implies: its layout, heartbeat timeout and read-back.
#[must_use]
pub fn contract_settings(link: &LinkSettings) -> ContractSettings {
    let defaults = ContractSettings::default();
    ContractSettings {
        layout: link.layout,
        verify: link.read_back,
        watch: WatchSettings {
            heartbeat_timeout: link.heartbeat_timeout,
            ..defaults.watch
        },
        scan_time: link.scan_time,
        ..defaults
    }
}

/// The daemon-wide options `settings` describe: move ids counted on in the state directory (from
/// the clock when it cannot be used), taught positions kept there, a fresh host word, the
/// journal, the robots' pallets (`pallet_sets`, the config's) with their counters kept there.
#[must_use]
pub fn daemon_options(
    settings: &DaemonSettings,
    journal: &Journal,
    pallet_sets: &std::collections::BTreeMap<String, RobotPallets>,
) -> DaemonOptions {
    let ids = match MoveIds::in_state_dir(&settings.state_dir) {
        Ok(ids) => ids,
        Err(e) => {
            tracing::warn!(
                state_dir = %settings.state_dir.display(),
                error = %e,
                "cannot keep move ids in the state directory; taking them from the clock"
            );
            MoveIds::from_clock()
        }
    };
    DaemonOptions {
        host: host_word(),
        ids: Arc::new(ids),
        start_within: settings.start_within,
        positions: Arc::new(TaughtPositions::in_state_dir(&settings.state_dir)),
        journal: journal.clone(),
        pallets: Arc::new(Pallets {
            sets: pallet_sets.clone(),
            counters: PalletCounters::in_state_dir(&settings.state_dir),
        }),
    }
}

/// The state directory's mode when the daemon creates it (systemd's `StateDirectory=` default).
const STATE_DIR_MODE: u32 = 0o750;

/// Makes the state directory (and its parents, mode 0750) when it is missing, as
/// `StateDirectory=` does under systemd, so a daemon started by hand keeps its move ids and
/// taught positions too; refuses at once when it cannot be made.
pub fn ensure_state_dir(dir: &Path) -> Result<(), ServeError> {
    use std::os::unix::fs::DirBuilderExt;
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(STATE_DIR_MODE)
        .create(dir)
        .map_err(|source| ServeError::StateDir {
            path: dir.to_owned(),
            source,
        })
}

/// Opens `link` anew on every call.
#[must_use]
pub fn connector(link: LinkSettings) -> Connector {
    let link = Arc::new(link);
    Box::new(move || {
        let link = Arc::clone(&link);
        Box::pin(async move { plc::connect(&link).await })
    })
}

async fn bind_tcp(address: SocketAddr) -> Result<TcpListener, ServeError> {
    TcpListener::bind(address)
        .await
        .map_err(|source| ServeError::Socket {
            operation: "bind",
            target: PathBuf::from(address.to_string()),
            source,
        })
}

/// Binds the Modbus face of every robot whose gateway has one.
async fn bind_modbus_faces(config: &Config) -> Result<Vec<(String, ModbusFaceServer)>, ServeError> {
    let mut faces = Vec::new();
    for robot in &config.robots {
        let Some(face) = config.gateway(&robot.name).and_then(|g| g.modbus.as_ref()) else {
            continue;
        };
        let server = ModbusFaceServer::bind(face)
            .await
            .map_err(|source| ServeError::Socket {
                operation: "bind the Modbus face on",
                target: PathBuf::from(face.listen.to_string()),
                source,
            })?;
        let allow: Vec<String> = face.allow.iter().map(ToString::to_string).collect();
        tracing::info!(
            robot = %robot.name,
            listen = %server.local_addr().unwrap_or(face.listen),
            allow = %if allow.is_empty() { "loopback".to_owned() } else { allow.join(", ") },
            "Modbus face listening"
        );
        faces.push((robot.name.clone(), server));
    }
    Ok(faces)
}

/// Runs the daemon for `config` with `settings` (the config's `[daemon]`, possibly overridden)
/// until `shutdown` completes, then shuts it down cleanly. `config_path` is read again on SIGHUP.
pub async fn serve(
    config: &Config,
    config_path: Option<&Path>,
    settings: &DaemonSettings,
    notifier: Notifier,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServeError> {
    // SIGHUP's default action ends the process: listened for before anything is bound.
    let hangups = hangup_signals();
    let robots = robots_from_config(config)?;
    let token = settings
        .token_file
        .as_deref()
        .map(BearerToken::read)
        .transpose()?;
    ensure_state_dir(&settings.state_dir)?;
    let _lock = lock(&settings.socket)?;
    let bound = Bound::bind(config, settings).await?;
    let journal = open_journal(settings)?;
    let mut daemon = Daemon::spawn(robots, &daemon_options(settings, &journal, &config.pallets));
    let api = Api::new(daemon.robots().clone()).with_journal(journal.clone());
    let closing = api.closing();
    super::journal::follow(daemon.robots(), &journal, &closing);
    let mut servers = spawn_servers(config, &daemon, (api, token), bound, &closing)?;
    let listen = settings.listen.map(tracing::field::display);
    tracing::info!(socket = %settings.socket.display(), listen, "API listening");
    log_notify(notifier.ready(), "READY=1");
    let supervisor = tokio::spawn(supervise::supervise(
        daemon.robots().clone(),
        notifier,
        closing.clone(),
    ));
    let reloads = (config_path, &journal, hangups);
    let failed = run_until(shutdown, &mut daemon, &mut servers, reloads).await;
    tracing::info!("shutting down");
    journal.record(None, Kind::DaemonStopping);
    log_notify(notifier.stopping(), "STOPPING=1");
    closing.cancel();
    daemon.shut_down().await;
    tracing::info!("workers stopped");
    let _ = supervisor.await;
    let _ = tokio::time::timeout(DRAIN, async {
        while servers.join_next().await.is_some() {}
    })
    .await;
    servers.abort_all();
    let _ = std::fs::remove_file(&settings.socket);
    journal.flush().await;
    failed.map_or(Ok(()), Err)
}

/// What `serve` binds before any worker starts: a port taken, a socket in the way or a bad
/// console users' file stops the start there.
struct Bound {
    unix: tokio::net::UnixListener,
    tcp: Option<TcpListener>,
    faces: Vec<(String, ModbusFaceServer)>,
    console: Option<TcpListener>,
}

impl Bound {
    async fn bind(config: &Config, settings: &DaemonSettings) -> Result<Self, ServeError> {
        let unix = bind_unix(&settings.socket, settings.socket_mode)?;
        let tcp = match settings.listen {
            Some(address) => Some(bind_tcp(address).await?),
            None => None,
        };
        Ok(Self {
            unix,
            tcp,
            faces: bind_modbus_faces(config).await?,
            console: bind_console(config).await?,
        })
    }
}

/// The API (on the socket, and on TCP with `token`), the console, the Modbus faces and the
/// mirrored cell faces, serving `daemon`'s robots until `closing`.
fn spawn_servers(
    config: &Config,
    daemon: &Daemon,
    (api, token): (Api, Option<BearerToken>),
    bound: Bound,
    closing: &tokio_util::sync::CancellationToken,
) -> Result<JoinSet<io::Result<()>>, ServeError> {
    let hub = LiveHub::start(daemon.robots(), &snapshot_setups(config), closing);
    let api = api.with_live(hub.clone());
    let mut servers = JoinSet::new();
    spawn_api(&mut servers, bound.unix, api.router(None), closing);
    if let Some(tcp) = bound.tcp {
        spawn_api(&mut servers, tcp, api.router(token), closing);
    }
    if let (Some(settings), Some(tcp)) = (&config.console, bound.console) {
        let robots = daemon.robots();
        let cells = (&config.robot_consoles, &config.cells);
        let console = Console::new(settings, cells.0, cells.1, robots, hub, api, closing)?;
        let stop = closing.clone();
        servers.spawn(serve_console(tcp, console, settings.clone(), stop));
    }
    spawn_faces(daemon, bound.faces, closing, &mut servers);
    Ok(servers)
}

/// The API served on `listener` by `router` until `closing`.
fn spawn_api<L: axum::serve::Listener>(
    servers: &mut JoinSet<io::Result<()>>,
    listener: L,
    router: axum::Router,
    closing: &tokio_util::sync::CancellationToken,
) where
    L::Io: api::PeerCaller,
{
    let stop = closing.clone();
    servers.spawn(async move {
        api::serve(listener, router, stop.cancelled_owned()).await;
        Ok(())
    });
}

/// Serves until `shutdown` completes, a server ends or a worker fails (what failed, if
/// anything did), reloading `config_path` on every SIGHUP (each reload journaled).
async fn run_until(
    shutdown: impl Future<Output = ()>,
    daemon: &mut Daemon,
    servers: &mut JoinSet<io::Result<()>>,
    (config_path, journal, mut hangups): (Option<&Path>, &Journal, Hangups),
) -> Option<ServeError> {
    let mut running = config_path.map(running_config);
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            () = &mut shutdown => break None,
            Some(done) = servers.join_next() => {
                break match done {
                    Ok(Err(e)) => Some(ServeError::Serve(e)),
                    _ => None,
                };
            }
            why = daemon.worker_failed() => {
                tracing::error!("{why}; the daemon exits");
                break Some(ServeError::WorkerFailed(why));
            }
            Some(()) = hangups.recv() => {
                reload(running.as_mut().zip(config_path), daemon.robots(), journal);
            }
        }
    }
}

/// The Modbus faces' servers and the mirrored cell faces, until `closing`.
fn spawn_faces(
    daemon: &Daemon,
    faces: Vec<(String, ModbusFaceServer)>,
    closing: &tokio_util::sync::CancellationToken,
    servers: &mut JoinSet<io::Result<()>>,
) {
    for (name, face) in faces {
        let Some(robot) = daemon.robot(&name).cloned() else {
            continue;
        };
        let stop = closing.clone();
        servers.spawn(async move { face.serve(robot, stop.cancelled_owned()).await });
    }
    for robot in daemon.robots().values() {
        if robot.face_settings().is_some_and(|f| f.plc.is_some()) {
            let (robot, stop) = (robot.clone(), closing.clone());
            servers.spawn(async move {
                super::mirror_face(robot, stop.cancelled_owned()).await;
                Ok(())
            });
        }
    }
}

/// The console's listener, when the config has a console; its users' token files are read
/// first, so a bad one stops the start before any worker.
async fn bind_console(config: &Config) -> Result<Option<TcpListener>, ServeError> {
    let Some(console) = &config.console else {
        return Ok(None);
    };
    super::console::Sessions::new(console)?;
    Ok(Some(bind_tcp(console.listen).await?))
}

/// Serves the console on `tcp` until `closing`.
async fn serve_console(
    tcp: TcpListener,
    console: Console,
    settings: crate::config::ConsoleSettings,
    closing: tokio_util::sync::CancellationToken,
) -> io::Result<()> {
    tracing::info!(
        listen = %tcp.local_addr().map_or(settings.listen, |a| a),
        users = settings.users.len(),
        "console listening"
    );
    super::console::serve(
        tcp,
        console.router(),
        settings.allow,
        closing.cancelled_owned(),
    )
    .await;
    Ok(())
}

/// SIGHUP as a stream (nothing comes if its handler cannot be installed).
/// Each SIGHUP, as it comes.
type Hangups = tokio::sync::mpsc::Receiver<()>;

fn hangup_signals() -> Hangups {
    let (tx, rx) = tokio::sync::mpsc::channel(1);
    match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::hangup()) {
        Ok(mut hup) => {
            tokio::spawn(async move {
                while hup.recv().await.is_some() {
                    if tx.send(()).await.is_err() {
                        return;
                    }
                }
            });
        }
        Err(e) => tracing::warn!(error = %e, "cannot handle SIGHUP"),
    }
    rx
}

/// The config file as the daemon starts with it, to compare a reload with (as good as empty
/// when it cannot be read again: every key is then named as changed, needing a restart).
fn running_config(path: &Path) -> Running {
    Running::read(path).unwrap_or_else(|e| {
        tracing::warn!(config = %path.display(), error = %e, "the config cannot be read again: a reload will name every key as needing a restart");
        Running::default()
    })
}

/// SIGHUP: reads the config file again, applies what may change live and logs every change
/// (see `reload.rs`).
fn reload(
    running: Option<(&mut Running, &Path)>,
    robots: &std::collections::BTreeMap<String, super::RobotHandle>,
    journal: &Journal,
) {
    let Some((running, path)) = running else {
        tracing::info!("SIGHUP: no config file to read again");
        return;
    };
    let result = running.reload(path, robots);
    journal.record(None, reload::journaled(&result));
    reload::log(path, &result);
}

/// Opens the journal in the state directory and journals the daemon's start.
fn open_journal(settings: &DaemonSettings) -> Result<Journal, ServeError> {
    let journal = Journal::open(
        &settings.state_dir.join(crate::journal::DIR),
        &settings.journal,
    )?;
    journal.record(
        None,
        Kind::DaemonStarted {
            version: env!("CARGO_PKG_VERSION").to_owned(),
        },
    );
    Ok(journal)
}

fn log_notify(result: io::Result<()>, what: &str) {
    if let Err(e) = result {
        tracing::warn!(error = %e, "cannot tell systemd {what}");
    }
}

/// Completes on SIGTERM or SIGINT, both listened for from this call on, not from the first
/// poll: made before anything is bound or systemd is told READY=1, a SIGTERM sent as soon as
/// the daemon says it listens ends it cleanly (exit 0) instead of killing it. Call it inside
/// the runtime.
///
/// # Panics
/// If the handlers cannot be installed (no signal support in this process, or no runtime).
pub fn shutdown_signal() -> impl Future<Output = ()> + use<> {
    use tokio::signal::unix::{SignalKind, signal};
    let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
    let mut int = signal(SignalKind::interrupt()).expect("SIGINT handler");
    async move {
        tokio::select! {
            _ = term.recv() => tracing::info!("SIGTERM"),
            _ = int.recv() => tracing::info!("SIGINT"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::testing::fresh_dir as temp;

    #[test]
    fn a_missing_state_dir_is_created_0750_so_the_first_pos_save_can_write() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp("state-dir-made");
        let state = dir.join("var/lib/linterpd");
        ensure_state_dir(&state).unwrap();
        let mode = std::fs::metadata(&state).unwrap().permissions().mode() & 0o777;
        // The umask may take bits away, never add them.
        assert_eq!(mode & !STATE_DIR_MODE, 0, "{mode:o}");
        assert!(mode & 0o700 == 0o700, "{mode:o}");
        // There already: nothing to do.
        ensure_state_dir(&state).unwrap();
        std::fs::write(state.join("positions.json"), "{}").unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_state_dir_that_cannot_be_made_is_refused_at_start_naming_the_key() {
        let dir = temp("state-dir-file");
        let file = dir.join("not-a-dir");
        std::fs::write(&file, "").unwrap();
        let e = ensure_state_dir(&file.join("state")).unwrap_err();
        assert!(
            e.to_string().starts_with(&format!(
                "cannot create the state directory {}/state ([daemon] state_dir)",
                file.display()
            )),
            "{e}"
        );
        assert!(
            std::error::Error::source(&e).is_some(),
            "the OS error is kept"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
