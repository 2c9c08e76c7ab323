//! The conversation with systemd while the daemon serves: `STATUS=` whenever the one-line
//! summary changes, and `WATCHDOG=1` every watchdog interval, but only while every robot's worker
//! makes progress: a worker that hangs (or died) stops the pings, and systemd restarts the daemon.

use std::collections::BTreeMap;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use super::log_notify;
use crate::daemon::notify::Notifier;
use crate::daemon::{RobotHandle, RobotState};

/// How often the status line is recomputed (sent only when it changed).
const STATUS_POLL: Duration = Duration::from_millis(500);
/// The watchdog timer's period when systemd runs no watchdog (the timer is then never awaited).
const IDLE_WATCHDOG: Duration = Duration::from_secs(3600);
/// A worker whose last progress is older than this makes the daemon unhealthy. It goes round
/// its loop at least every reconnection backoff (5 s) plus a connect timeout, and marks progress
/// between the exchanges of an upload.
pub(super) const STUCK: Duration = Duration::from_secs(15);

/// Whether every worker made progress within `limit`.
#[must_use]
pub fn healthy(robots: &BTreeMap<String, RobotHandle>, limit: Duration) -> bool {
    robots
        .values()
        .all(|r| r.since_worker_beat().is_some_and(|d| d <= limit))
}

/// Sends `STATUS=` on change and `WATCHDOG=1` while healthy, until `closing`.
pub(super) async fn supervise(
    robots: BTreeMap<String, RobotHandle>,
    notifier: Notifier,
    closing: CancellationToken,
) {
    let mut status = tokio::time::interval(STATUS_POLL);
    let mut watchdog = tokio::time::interval(notifier.watchdog_interval().unwrap_or(IDLE_WATCHDOG));
    let mut last = String::new();
    let mut was_healthy = true;
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
                let now_healthy = healthy(&robots, STUCK);
                if now_healthy {
                    log_notify(notifier.watchdog(), "WATCHDOG=1");
                } else if was_healthy {
                    tracing::error!("a robot's worker makes no progress: the watchdog pings stop");
                }
                was_healthy = now_healthy;
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
        (None, None) if !s.homed => "not homed".to_owned(),
        (None, None) => "idle".to_owned(),
    };
    format!("{}: connected, {activity}", s.name)
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
            homed: true,
            ..RobotState::default()
        };
        a.link.connected = true;
        let b = RobotState {
            name: "b".into(),
            ..RobotState::default()
        };
        let mut c = RobotState {
            name: "c".into(),
            ..RobotState::default()
        };
        c.link.connected = true;
        assert_eq!(
            status_line(&[a, b, c]),
            "a: connected, moving (move 3, 1 queued); b: disconnected; c: connected, not homed"
        );
    }
}
