//! Telling systemd how the daemon is doing (`sd_notify(3)`), through the `sd-notify` crate.
//!
//! Under `Type=notify` (deploy/linterpd.service) systemd waits for `READY=1` before it counts the
//! service as started, shows the latest `STATUS=` line in `systemctl status`, restarts the service
//! when `WATCHDOG=1` pings stop for longer than `WatchdogSec=`, and expects `STOPPING=1` when the
//! daemon begins to shut down. Each message is one datagram on the Unix socket named by
//! `NOTIFY_SOCKET`:
//! ```text
//! READY=1\n          startup finished
//! STATUS=<text>\n    free-form status line
//! WATCHDOG=1\n       still alive
//! STOPPING=1\n       shutting down
//! ```
//! Outside systemd (`NOTIFY_SOCKET` unset: a terminal, a test, another supervisor) every call is a
//! no-op, so the daemon calls these unconditionally.

use std::io;
use std::time::Duration;

use sd_notify::NotifyState;

/// The environment variable naming systemd's notification socket.
const NOTIFY_SOCKET: &str = "NOTIFY_SOCKET";

/// The daemon's line to systemd, fixed when the daemon starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Notifier {
    /// Whether `NOTIFY_SOCKET` was set at start: without it every call is a no-op.
    enabled: bool,
    /// The watchdog timeout systemd asked for (`WATCHDOG_USEC`), if any.
    watchdog_timeout: Option<Duration>,
}

impl Notifier {
    /// Reads `NOTIFY_SOCKET`, `WATCHDOG_USEC` and `WATCHDOG_PID` from the environment. Call it once,
    /// at start, in the daemon's main process.
    #[must_use]
    pub fn from_env() -> Self {
        let enabled = std::env::var_os(NOTIFY_SOCKET).is_some_and(|path| !path.is_empty());
        Self {
            enabled,
            // `None` unless WATCHDOG_USEC parses and WATCHDOG_PID, when set, is this process.
            watchdog_timeout: enabled.then(sd_notify::watchdog_enabled).flatten(),
        }
    }

    /// A notifier that never sends anything, for running outside systemd on purpose.
    #[must_use]
    pub fn disabled() -> Self {
        Self {
            enabled: false,
            watchdog_timeout: None,
        }
    }

    /// Whether systemd is listening (`NOTIFY_SOCKET` was set).
    #[must_use]
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// How often to call [`Notifier::watchdog`]: half of systemd's `WATCHDOG_USEC`, as
    /// `sd_watchdog_enabled(3)` recommends, or `None` when systemd runs no watchdog for this
    /// process (or does not listen at all).
    #[must_use]
    pub fn watchdog_interval(&self) -> Option<Duration> {
        self.watchdog_timeout.map(|timeout| timeout / 2)
    }

    /// Startup is finished: systemd counts the service as started (`READY=1`).
    pub fn ready(&self) -> io::Result<()> {
        self.send(&NotifyState::Ready)
    }

    /// A one-line status for `systemctl status` (`STATUS=...`). Line breaks in `status` are sent
    /// as spaces: a newline would end the message early.
    pub fn status(&self, status: &str) -> io::Result<()> {
        let one_line = status.replace(['\n', '\r'], " ");
        self.send(&NotifyState::Status(&one_line))
    }

    /// The daemon is alive (`WATCHDOG=1`). Call it every [`Notifier::watchdog_interval`], from the
    /// loop whose health it stands for, not from a timer of its own.
    pub fn watchdog(&self) -> io::Result<()> {
        self.send(&NotifyState::Watchdog)
    }

    /// The daemon is shutting down (`STOPPING=1`).
    pub fn stopping(&self) -> io::Result<()> {
        self.send(&NotifyState::Stopping)
    }

    fn send(&self, state: &NotifyState<'_>) -> io::Result<()> {
        if !self.enabled {
            return Ok(());
        }
        sd_notify::notify(std::slice::from_ref(state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disabled_notifier_sends_nothing_and_has_no_watchdog() {
        let n = Notifier::disabled();
        assert!(!n.enabled());
        assert_eq!(n.watchdog_interval(), None);
        n.ready().unwrap();
        n.status("idle").unwrap();
        n.watchdog().unwrap();
        n.stopping().unwrap();
    }

    #[test]
    fn watchdog_interval_is_half_the_timeout() {
        let n = Notifier {
            enabled: true,
            watchdog_timeout: Some(Duration::from_secs(10)),
        };
        assert_eq!(n.watchdog_interval(), Some(Duration::from_secs(5)));
    }
}
