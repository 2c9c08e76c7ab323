//! `linterpd run FILE`: send a path file (lines, arcs, blended corners) to the daemon, which
//! plans every section before anything moves and queues one move per section, then follow the
//! sections to their ends (on a terminal, a bar per section and one per element and blend of
//! it, `bars.rs`), one summary line each, naming the elements it ran.
//!
//! ```text
//!  stdout:  a line per section (or a JSON array of their final reports, --json); with
//!           --no-wait, the ids (or the 202 body)
//!  exit:    as `linterpd move`: 0 every section done; 2 a file or path the daemon refuses;
//!           3 refused for the robot's state, or a section ended other than done; 4 no daemon
//! ```

use std::path::PathBuf;

use anyhow::{Context, anyhow};
use clap::Args;
use serde_json::{Value, json};

use super::super::client::Client;
use super::super::{DaemonArgs, Failure};
use super::{MotionFlags, bars, follow, post, summary, timeout, verdict};
use crate::config::PathDoc;

/// Arguments of `linterpd run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The path file (config/examples/pick-and-place.toml shows every key). Without a `start`
    /// it begins where the robot is (or where the move before it ends); with one, the robot
    /// must be there. A regular file of at most 1 MiB (anything else is refused unread).
    pub file: PathBuf,
    /// The robot (needed when the daemon runs several).
    #[arg(long)]
    pub robot: Option<String>,
    /// Speed, acceleration, method, period and tolerance.
    #[command(flatten)]
    pub motion: MotionFlags,
    /// The longest to wait for each section's end, e.g. `30s` (default: the daemon's deadline).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "no_wait")]
    pub timeout: Option<String>,
    /// Return once the path is accepted, printing its sections' ids.
    #[arg(long)]
    pub no_wait: bool,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// The API's path order: the file (checked here first, naming the key) and the flags.
fn order(args: &RunArgs) -> anyhow::Result<Value> {
    let text = super::super::path_file::read(&args.file)?;
    PathDoc::from_toml(&text).with_context(|| args.file.display().to_string())?;
    let path: Value = toml::from_str(&text).with_context(|| args.file.display().to_string())?;
    let mut order = json!({ "path": path });
    args.motion.add_to(&mut order)?;
    Ok(order)
}

/// Runs `linterpd run`.
pub fn run(args: &RunArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let order = order(args).map_err(Failure::BadInput)?;
    let timeout = timeout(args.timeout.as_deref())?;
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let (robot, accepted) = post(&client, args.robot.as_deref(), "paths", &order).await?;
        let ids: Vec<u64> = accepted["ids"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_u64).collect())
            .ok_or_else(|| Failure::Runtime(anyhow!("the daemon gave no move ids")))?;
        if args.no_wait {
            let list: Vec<String> = ids.iter().map(u64::to_string).collect();
            return super::super::print(
                out,
                args.daemon.json,
                &accepted,
                &format!("path accepted: moves {}", list.join(", ")),
            );
        }
        let mut finals = Vec::with_capacity(ids.len());
        let mut outcome = Ok(());
        for (n, &id) in ids.iter().enumerate() {
            let last = follow::to_end(&client, &robot, id, timeout, args.daemon.json).await?;
            if !args.daemon.json {
                let elements = bars::elements(&last)
                    .map(|e| format!(" (element {e})"))
                    .unwrap_or_default();
                writeln!(
                    out,
                    "section {}/{}{elements}: {}",
                    n + 1,
                    ids.len(),
                    summary(&last)
                )
                .map_err(|e| Failure::Runtime(e.into()))?;
            }
            outcome = outcome.and(verdict(&last));
            finals.push(last);
        }
        if args.daemon.json {
            super::super::print(out, true, &Value::Array(finals), "")?;
        }
        outcome
    })
}
