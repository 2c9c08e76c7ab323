//! `linterpd stop`: stop every channel of a robot now, cancelling its queued moves.

use clap::Args;

use super::{DaemonArgs, Failure};

/// Arguments of `linterpd stop`.
#[derive(Debug, Args)]
pub struct StopArgs {
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd stop`.
pub fn run(args: &StopArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    super::robot_command(&args.daemon, args.robot.as_deref(), "stop", "stopped", out)
}
