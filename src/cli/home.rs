//! `linterpd home`: run the PLC's home routine (`POST /v1/robots/{name}/home`): every joint's
//! count is set to its home count (`home_counts` in the robot's `[robots.NAME.plc]`, default 0).
//! Answers when the routine has ended; refused (exit 3) while a move runs, while homing, or
//! with a fault latched.

use clap::Args;

use super::{DaemonArgs, Failure};

/// Arguments of `linterpd home`.
#[derive(Debug, Args)]
pub struct HomeArgs {
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd home`.
pub fn run(args: &HomeArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    super::robot_command(&args.daemon, args.robot.as_deref(), "home", "homed", out)
}
