//! `linterpd serve` as a library function: a worker per configured robot on its PLC link, the API
//! on the Unix socket (and a TCP listener when configured), and the conversation with systemd.
//!
//! ```text
//! bind socket(s) -> spawn Daemon -> READY=1 -> serve ... STATUS= on change, WATCHDOG=1 on time
//!   shutdown signal -> STOPPING=1 -> stop accepting, end event streams -> Daemon::shut_down
//! ```

use std::collections::BTreeMap;
use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use thiserror::Error;
use tokio::net::{TcpListener, UnixListener};
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use super::api::{Api, BearerToken, TokenError};
use super::notify::Notifier;
use super::{Connector, Daemon, RobotHandle, RobotState};
use crate::config::{Config, DaemonSettings};
use crate::plc::contract::ContractSettings;
use crate::plc::{self, LinkSettings};
use crate::robot::Robot;

/// How often the status line is recomputed (sent only when it changed).
const STATUS_POLL: Duration = Duration::from_millis(500);
/// The watchdog timer's period when systemd runs no watchdog (the timer is then never awaited).
const IDLE_WATCHDOG: Duration = Duration::from_secs(3600);
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
    /// A listener failed while serving.
    #[error("the API listener failed")]
    Serve(#[source] io::Error),
}

/// The daemon's robots with their contract settings and link openers, from a config; every robot
/// needs a PLC link.
pub fn robots_from_config(
    config: &Config,
) -> Result<Vec<(Robot, ContractSettings, Connector)>, ServeError> {
    config
        .robots
        .iter()
        .map(|robot| {
            let link = config.link(&robot.name).ok_or_else(|| ServeError::NoLink {
                robot: robot.name.clone(),
            })?;
            Ok((
                robot.clone(),
                contract_settings(link),
                connector(link.clone()),
            ))
        })
        .collect()
}

/// The contract settings a link implies: its layout and heartbeat timeout, verify on.
#[must_use]
pub fn contract_settings(link: &LinkSettings) -> ContractSettings {
    ContractSettings {
        layout: link.layout,
        heartbeat_timeout: link.heartbeat_timeout,
        verify: true,
        ..ContractSettings::default()
    }
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

/// Binds the API's Unix socket at `path` with permissions `mode`, replacing a stale socket file
/// (but no other kind of file).
pub fn bind_unix(path: &Path, mode: u32) -> Result<UnixListener, ServeError> {
    let fail = |operation| {
        move |source| ServeError::Socket {
            operation,
            target: path.to_owned(),
            source,
        }
    };
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_socket()) {
        std::fs::remove_file(path).map_err(fail("remove the stale socket"))?;
    }
    let listener = UnixListener::bind(path).map_err(fail("bind"))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(fail("set the mode of"))?;
    Ok(listener)
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

/// Runs the daemon for `config` with `settings` (the config's `[daemon]`, possibly overridden)
/// until `shutdown` completes, then shuts it down cleanly.
pub async fn serve(
    config: &Config,
    settings: &DaemonSettings,
    notifier: Notifier,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServeError> {
    let robots = robots_from_config(config)?;
    let token = settings
        .token_file
        .as_deref()
        .map(BearerToken::read)
        .transpose()?;
    let unix = bind_unix(&settings.socket, settings.socket_mode)?;
    let tcp = match settings.listen {
        Some(address) => Some(bind_tcp(address).await?),
        None => None,
    };
    let daemon = Daemon::spawn(robots);
    let api = Api::new(daemon.robots().clone());
    let closing = api.closing();
    let mut servers = JoinSet::new();
    let stop = closing.clone();
    let router = api.router(None);
    servers.spawn(async move {
        axum::serve(unix, router)
            .with_graceful_shutdown(stop.cancelled_owned())
            .await
    });
    if let Some(tcp) = tcp {
        let stop = closing.clone();
        let router = api.router(token);
        servers.spawn(async move {
            axum::serve(tcp, router)
                .with_graceful_shutdown(stop.cancelled_owned())
                .await
        });
    }
    tracing::info!(socket = %settings.socket.display(), listen = ?settings.listen, "API listening");
    log_notify(notifier.ready(), "READY=1");
    let supervisor = tokio::spawn(supervise(
        daemon.robots().clone(),
        notifier,
        closing.clone(),
    ));
    let failed = tokio::select! {
        () = shutdown => None,
        Some(done) = servers.join_next() => Some(done),
    };
    tracing::info!("shutting down");
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
    match failed {
        Some(Ok(Err(e))) => Err(ServeError::Serve(e)),
        _ => Ok(()),
    }
}

fn log_notify(result: io::Result<()>, what: &str) {
    if let Err(e) = result {
        tracing::warn!(error = %e, "cannot tell systemd {what}");
    }
}

/// Sends `STATUS=` when the summary changes and `WATCHDOG=1` every watchdog interval, for as
/// long as the runtime runs this task, until `closing`.
async fn supervise(
    robots: BTreeMap<String, RobotHandle>,
    notifier: Notifier,
    closing: CancellationToken,
) {
    let mut status = tokio::time::interval(STATUS_POLL);
    let mut watchdog = tokio::time::interval(notifier.watchdog_interval().unwrap_or(IDLE_WATCHDOG));
    let mut last = String::new();
    loop {
        tokio::select! {
            () = closing.cancelled() => return,
            _ = status.tick() => {
                let states: Vec<RobotState> = robots.values().map(RobotHandle::state).collect();
                let line = status_line(&states);
                if line != last {
                    tracing::info!(status = %line, "status");
                    log_notify(notifier.status(&line), "STATUS=");
                    last = line;
                }
            }
            _ = watchdog.tick(), if notifier.watchdog_interval().is_some() => {
                log_notify(notifier.watchdog(), "WATCHDOG=1");
            }
        }
    }
}

/// One line on every robot: `press-loader: connected, moving (move 3, 1 queued)`.
#[must_use]
pub fn status_line(states: &[RobotState]) -> String {
    let parts: Vec<String> = states.iter().map(robot_status).collect();
    parts.join("; ")
}

fn robot_status(s: &RobotState) -> String {
    if !s.link.connected {
        return format!("{}: disconnected", s.name);
    }
    let activity = match (s.current_move, s.fault) {
        (_, Some(fault)) => format!("fault {fault}"),
        (Some(id), None) => format!("moving (move {id}, {} queued)", s.queued.len()),
        (None, None) => "idle".to_owned(),
    };
    format!("{}: connected, {activity}", s.name)
}

/// Completes on SIGTERM or SIGINT.
///
/// # Panics
/// If the SIGTERM handler cannot be installed (no signal support in this process).
pub async fn shutdown_signal() {
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        .expect("SIGTERM handler");
    tokio::select! {
        _ = term.recv() => tracing::info!("SIGTERM"),
        _ = tokio::signal::ctrl_c() => tracing::info!("SIGINT"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_line_names_every_robot() {
        let mut a = RobotState {
            name: "a".into(),
            current_move: Some(3),
            queued: vec![4],
            ..RobotState::default()
        };
        a.link.connected = true;
        let b = RobotState {
            name: "b".into(),
            ..RobotState::default()
        };
        assert_eq!(
            status_line(&[a, b]),
            "a: connected, moving (move 3, 1 queued); b: disconnected"
        );
    }

    #[test]
    fn a_stale_socket_is_replaced_and_gets_its_mode() {
        let dir = std::env::temp_dir().join(format!("linterpd-sock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("api.sock");
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            drop(bind_unix(&path, 0o600).unwrap());
            let _again = bind_unix(&path, 0o640).unwrap();
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o640);
        });
        std::fs::write(dir.join("plain"), "x").unwrap();
        let e = rt.block_on(async { bind_unix(&dir.join("plain"), 0o600).unwrap_err() });
        assert!(e.to_string().starts_with("cannot bind"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
