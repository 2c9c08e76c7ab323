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

use anyhow::Context;
use clap::Args;
use serde_json::Value;

use super::super::client::{Client, Received};
use super::super::{DaemonArgs, Failure};
use super::{FollowFlags, MotionFlags, bars, follow, post, stop_robot, summary, verdict};
use crate::config::PathDoc;
use crate::daemon::{MoveReport, PathAccepted, PathOrder};

/// Arguments of `linterpd run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The path file (config/examples/pick-and-place.toml shows every key). Without a `start`
    /// it begins where the robot is (or where the move before it ends); with one, the robot
    /// must be there. A regular file of at most 1 MiB (anything else is refused unread).
    pub file: PathBuf,
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// Speed, acceleration, method, period and tolerance.
    #[command(flatten)]
    pub motion: MotionFlags,
    /// How long to follow it, and what Ctrl-C does.
    #[command(flatten)]
    pub follow: FollowFlags,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// The API's path order: the file (checked here first, naming the key) and the flags.
fn order(args: &RunArgs) -> anyhow::Result<PathOrder> {
    let text = crate::config::files::read_regular(&args.file)?;
    PathDoc::from_toml(&text).with_context(|| args.file.display().to_string())?;
    let path: Value = toml::from_str(&text).with_context(|| args.file.display().to_string())?;
    Ok(PathOrder {
        path,
        motion: args.motion.order_motion()?,
        permit: args.motion.permit.clone(),
    })
}

/// Runs `linterpd run`.
pub fn run(args: &RunArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let order = order(args).map_err(Failure::BadInput)?;
    let timeout = args.follow.timeout()?;
    args.daemon.block_on(async {
        let mut interrupt = args.follow.interrupt()?;
        let client = Client::new(&args.daemon.socket);
        let (robot, accepted) = post(&client, args.robot.as_deref(), "paths", &order).await?;
        let accepted: Received<PathAccepted> =
            Received::read(accepted, "a path accepted").map_err(Failure::Runtime)?;
        let ids = &accepted.value.ids;
        if args.follow.no_wait {
            let list: Vec<String> = ids.iter().map(u64::to_string).collect();
            return super::super::print(
                out,
                args.daemon.json,
                &accepted.json,
                &format!("path accepted: moves {}", list.join(", ")),
            );
        }
        let labels = start_labels(&accepted.value.reports, ids.len());
        let work = async {
            let mut finals = Vec::with_capacity(ids.len());
            let mut outcome = Ok(());
            for (&id, label) in ids.iter().zip(&labels) {
                let last = follow::to_end(&client, &robot, id, timeout, args.daemon.json).await?;
                if !args.daemon.json {
                    let elements = bars::elements(&last.value)
                        .map(|e| format!(" (element {e})"))
                        .unwrap_or_default();
                    writeln!(out, "{label}{elements}: {}", summary(&last.value))
                        .map_err(|e| Failure::Runtime(e.into()))?;
                }
                outcome = outcome.and(verdict(&last.value));
                finals.push(last.json);
            }
            if args.daemon.json {
                super::super::print(out, true, &Value::Array(finals), "")?;
            }
            outcome
        };
        let running = "the path goes on (`linterpd stop` stops it)";
        let stop = async || stop_robot(&client, &robot, "the path").await;
        match &mut interrupt {
            Some(interrupt) => interrupt.attached(work, running, stop).await,
            None => work.await,
        }
    })
}

/// What each of a path's `starts` moves runs, from the reports the daemon accepted it with:
/// `section 1/2` for a section run in one start, `section 1/2, part 2/3` for one of the parts
/// a section is cut into (chained at speed). Without a section in every report (a daemon that
/// gives none), the starts are counted as sections.
fn start_labels(reports: &[MoveReport], starts: usize) -> Vec<String> {
    let sections: Option<Vec<(usize, usize)>> = reports
        .iter()
        .map(|r| r.section.as_ref().map(|s| (s.number, s.of)))
        .collect();
    let Some(sections) = sections.filter(|s| s.len() == starts) else {
        return (1..=starts)
            .map(|n| format!("section {n}/{starts}"))
            .collect();
    };
    sections
        .iter()
        .enumerate()
        .map(|(i, &(number, of))| {
            let parts = sections.iter().filter(|s| s.0 == number).count();
            let part = sections[..=i].iter().filter(|s| s.0 == number).count();
            if parts > 1 {
                format!("section {number}/{of}, part {part}/{parts}")
            } else {
                format!("section {number}/{of}")
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::{MoveOrder, SectionReport};

    fn report(number: usize, of: usize) -> MoveReport {
        MoveReport {
            section: Some(SectionReport {
                number,
                of,
                pieces: Vec::new(),
            }),
            ..plain()
        }
    }

    fn plain() -> MoveReport {
        MoveReport::new(1, "r", MoveOrder::default())
    }

    #[test]
    fn a_section_cut_into_parts_is_counted_as_one_section_not_as_its_starts() {
        // Two sections, the first cut into three parts: six starts before, two sections now.
        let reports = [report(1, 2), report(1, 2), report(1, 2), report(2, 2)];
        assert_eq!(
            start_labels(&reports, 4),
            [
                "section 1/2, part 1/3",
                "section 1/2, part 2/3",
                "section 1/2, part 3/3",
                "section 2/2",
            ]
        );
    }

    #[test]
    fn sections_of_one_start_each_are_numbered_alone() {
        assert_eq!(
            start_labels(&[report(1, 2), report(2, 2)], 2),
            ["section 1/2", "section 2/2"]
        );
    }

    #[test]
    fn reports_without_sections_count_the_starts() {
        assert_eq!(start_labels(&[plain()], 2), ["section 1/2", "section 2/2"]);
    }
}
