//! `linterpd clear-fault`: clear a fault latched on a robot's PLC
//! (`POST /v1/robots/{name}/clear-fault`). Refused (exit 3) when the PLC reports no fault, or
//! while a move or the home routine runs.

use clap::Args;

use super::{DaemonArgs, Failure};

/// Arguments of `linterpd clear-fault`.
#[derive(Debug, Args)]
pub struct ClearFaultArgs {
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd clear-fault`.
pub fn run(args: &ClearFaultArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    super::robot_command(
        &args.daemon,
        args.robot.as_deref(),
        "clear-fault",
        "fault cleared",
        out,
    )
}
