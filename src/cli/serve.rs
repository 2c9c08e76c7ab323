//! `linterpd serve`: run the daemon for a config file until SIGTERM or SIGINT. The work is
//! [`crate::daemon::service::serve`]; this reads the config and the arguments.
//!
//! ```text
//!  stderr / journal:  tracing log (journald fields under systemd)
//!  exit:              0 after a signal; 2 for a bad config; 1 when serving fails (another
//!                     daemon holds the socket, a listener fails, a robot's worker dies)
//! ```

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::{Failure, bad_input};
use crate::config::Config;
use crate::daemon::notify::Notifier;
use crate::daemon::service::{self, ServeError};

/// Arguments of `linterpd serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The config file (robots, their `[robots.NAME.plc]` links, `[daemon]`).
    #[arg(long)]
    pub config: PathBuf,
    /// The API's Unix socket, instead of the config's `[daemon] socket`.
    #[arg(long)]
    pub socket: Option<PathBuf>,
}

/// Runs the daemon until a signal.
pub fn run(args: &ServeArgs) -> Result<(), Failure> {
    let config = Config::load(&args.config).map_err(bad_input)?;
    let mut settings = config.daemon.clone();
    if let Some(socket) = &args.socket {
        settings.socket.clone_from(socket);
    }
    service::robots_from_config(&config).map_err(bad_input)?;
    let notifier = Notifier::from_env();
    let runtime = tokio::runtime::Runtime::new()
        .context("cannot start the async runtime")
        .map_err(Failure::Runtime)?;
    runtime
        .block_on(async {
            let shutdown = service::shutdown_signal();
            service::serve(&config, Some(&args.config), &settings, notifier, shutdown).await
        })
        .map_err(|e| match e {
            ServeError::NoLink { .. } | ServeError::Token(_) => bad_input(e),
            other => Failure::Runtime(other.into()),
        })
}
