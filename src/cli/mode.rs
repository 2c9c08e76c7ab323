//! `linterpd mode`: who drives a robot, local (the CLI and the API) or remote (the line's PLC
//! or HMI through the cell face).
//!
//! ```text
//! linterpd mode            -> press-loader: local
//! linterpd mode remote     -> press-loader: remote (the cell face drives it; `linterpd stop` still works)
//! ```
//! The mode changes only while no cycle is under way and no move is queued or running.

use clap::Args;
use hyper::Method;

use super::client::Client;
use super::{DaemonArgs, Failure};
use crate::cell::Mode;
use crate::daemon::api::mode::ModeBody;

/// Arguments of `linterpd mode`.
#[derive(Debug, Args)]
pub struct ModeArgs {
    /// `local` or `remote`; without it, the mode is shown.
    #[arg(value_parser = parse_mode)]
    pub mode: Option<Mode>,
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

fn parse_mode(text: &str) -> Result<Mode, crate::cell::ModeError> {
    text.parse()
}

/// Runs `linterpd mode`.
pub fn run(args: &ModeArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let daemon = &args.daemon;
    daemon.block_on(async {
        let client = Client::new(&daemon.socket);
        let robot = client
            .robot(args.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let path = format!("/v1/robots/{robot}/mode");
        let answer = match args.mode {
            Some(mode) => {
                let body = serde_json::to_value(ModeBody { mode })
                    .map_err(|e| Failure::Runtime(e.into()))?;
                client.expect(Method::PUT, &path, Some(&body)).await?
            }
            None => client.expect(Method::GET, &path, None).await?,
        };
        let body: ModeBody = serde_json::from_value(answer.clone())
            .map_err(|e| Failure::Runtime(anyhow::anyhow!("the daemon's mode: {e}")))?;
        super::print(out, daemon.json, &answer, &describe(&robot, body.mode))
    })
}

fn describe(robot: &str, mode: Mode) -> String {
    match mode {
        Mode::Local => format!("{robot}: local (the CLI and the API drive it)"),
        Mode::Remote => {
            format!("{robot}: remote (the cell face drives it; `linterpd stop` still works)")
        }
    }
}
