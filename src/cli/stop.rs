//! `linterpd stop`: stop every channel of a robot now, cancelling its queued moves.

use clap::Args;
use hyper::Method;

use super::client::Client;
use super::{DaemonArgs, Failure};

/// Arguments of `linterpd stop`.
#[derive(Debug, Args)]
pub struct StopArgs {
    /// The robot (needed when the daemon runs several).
    #[arg(long)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd stop`.
pub fn run(args: &StopArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let robot = client
            .robot(args.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let answer = client
            .expect(Method::POST, &format!("/v1/robots/{robot}/stop"), None)
            .await?;
        super::print(out, args.daemon.json, &answer, &format!("{robot}: stopped"))
    })
}
