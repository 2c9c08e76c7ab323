//! `linterpd cycle`: run a cycle program on a robot, and stop, pause, resume or watch it.
//!
//! ```text
//! linterpd cycle run press-load --count 10   -> press-load: running, 0 of 10 done
//! linterpd cycle run press-load --count 3 --follow
//!                                            -> a line per step until done (exit 0), a fault or
//!                                               a stop (exit 3); Ctrl-C stops it now (exit 130)
//! linterpd cycle status                      -> press-load: waiting for press_open (X5) for 2.4 s
//!                                               at step 3 (load) of press-load; 4 of 10 done
//!                                               (exit 1 when the cycle is faulted)
//! linterpd cycle stop [--now]                -> press-load: stops at the end of step 3
//! linterpd cycle pause | resume
//! ```
//! The programs are the robot's `[robots.NAME.cell] programs` directory's `*.toml` files; the
//! daemon checks one whole (every step, every name, every position) before it runs anything.
//! `--json`, `--socket` and `--robot` go before or after the action.

mod follow;

use std::fmt::Write as _;

use clap::{Args, Subcommand};
use hyper::Method;
use serde_json::json;

use super::client::{Client, Received};
use super::interrupt::Interrupt;
use super::{DaemonArgs, EXIT_FAILURE, Failure};
use crate::daemon::{CycleState, CycleStatus};

/// Arguments of `linterpd cycle`.
#[derive(Debug, Args)]
pub struct CycleArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: CycleAction,
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// What `linterpd cycle` does.
#[derive(Debug, Subcommand)]
pub enum CycleAction {
    /// Run a program: `--count` cycles, or until stopped.
    Run {
        /// The program's name (its file's name without `.toml`).
        program: String,
        /// How many cycles (1 and up); without it the cycle repeats until stopped.
        #[arg(long)]
        count: Option<u64>,
        /// Follow it: a line each time it moves on (the cycle, the step, what it waits for);
        /// exit 0 once the count is done, 3 when it faults or is stopped (naming the step and
        /// the wait). Ctrl-C stops the cycle and the robot at once (exit 130).
        #[arg(long)]
        follow: bool,
        /// With --follow: Ctrl-C stops following and leaves the cycle running (exit 0).
        #[arg(long, requires = "follow")]
        detach: bool,
    },
    /// Stop the cycle at the end of the current step (`--now`: stop the robot at once).
    Stop {
        /// Stop the robot now, mid-step.
        #[arg(long)]
        now: bool,
    },
    /// Pause at the end of the current step.
    Pause,
    /// Go on after a pause, a hold, or a fault once it was cleared (`linterpd clear-fault`).
    Resume,
    /// The cycle's state, step, count and what it waits for; exit 1 when it is faulted.
    Status,
}

/// Runs `linterpd cycle`.
pub fn run(args: &CycleArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let daemon = &args.daemon;
    daemon.block_on(async {
        let (follow, detach) = match &args.action {
            CycleAction::Run { follow, detach, .. } => (*follow, *detach),
            _ => (false, false),
        };
        // Caught before the run is asked for: no Ctrl-C falls between the order and the watch.
        let mut interrupt = follow.then(|| Interrupt::catch(detach)).transpose()?;
        let client = Client::new(&daemon.socket);
        let robot = client
            .robot(args.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let base = format!("/v1/robots/{robot}/cycles");
        let answer = request(&client, &base, &args.action).await?;
        let status: Received<CycleStatus> =
            Received::read(answer, "a cycle's status").map_err(Failure::Runtime)?;
        if let Some(interrupt) = &mut interrupt {
            let program = status.value.program.clone();
            let work = follow::follow(&client, &robot, status, daemon.json, out);
            let running = format!("{program} goes on (`linterpd cycle stop` ends it)");
            let stop = async || {
                let body = json!({ "now": true });
                let path = format!("{base}/stop");
                client.expect(Method::POST, &path, Some(&body)).await?;
                Ok(format!("{program} stopped, the robot stopped at once"))
            };
            return interrupt.attached(work, &running, stop).await;
        }
        super::print(out, daemon.json, &status.json, &describe(&status.value))?;
        match (&args.action, status.value.state) {
            (CycleAction::Status, CycleState::Faulted) => Err(Failure::Quiet(EXIT_FAILURE)),
            _ => Ok(()),
        }
    })
}

/// Asks the daemon for `action` on the cycles at `base`; its answer (a cycle's status).
async fn request(
    client: &Client,
    base: &str,
    action: &CycleAction,
) -> Result<serde_json::Value, Failure> {
    let (method, path, body) = match action {
        CycleAction::Run { program, count, .. } => (
            Method::POST,
            base.to_owned(),
            Some(json!({ "program": program, "count": count })),
        ),
        CycleAction::Stop { now } => (
            Method::POST,
            format!("{base}/stop"),
            Some(json!({ "now": now })),
        ),
        CycleAction::Pause => (Method::POST, format!("{base}/pause"), None),
        CycleAction::Resume => (Method::POST, format!("{base}/resume"), None),
        CycleAction::Status => (Method::GET, base.to_owned(), None),
    };
    client.expect(method, &path, body.as_ref()).await
}

/// A cycle's status in one line.
#[must_use]
pub fn describe(s: &CycleStatus) -> String {
    let state = match s.state {
        CycleState::Running => "running".to_owned(),
        CycleState::Waiting => match (&s.waiting_for, s.waiting_s) {
            (Some(what), Some(for_s)) => format!("waiting for {what} for {for_s:.1} s"),
            (Some(what), None) => format!("waiting for {what}"),
            _ => "waiting".to_owned(),
        },
        CycleState::Paused => "paused".to_owned(),
        CycleState::Faulted => "FAULTED".to_owned(),
        CycleState::Stopped => "stopped".to_owned(),
        CycleState::Done => "done".to_owned(),
    };
    let mut text = format!("{}: {state}", s.program);
    if let Some(step) = &s.step {
        let label = step
            .label
            .as_ref()
            .map(|l| format!(" ({l})"))
            .unwrap_or_default();
        let _ = write!(text, " at step {}{label} of {}", step.step, step.program);
        for from in &step.called_from {
            let _ = write!(text, ", called from {from}");
        }
        let _ = write!(text, ": {}", step.does);
    }
    if let Some(why) = &s.reason {
        let _ = write!(text, "; {why}");
    }
    let _ = match s.count {
        Some(n) => write!(text, "; {} of {n} done", s.done),
        None => write!(text, "; {} done", s.done),
    };
    if let Some(t) = s.last_cycle_s {
        let _ = write!(text, ", last cycle {t:.2} s");
        if let Some(w) = s.last_cycle_waiting_s {
            let _ = write!(text, " ({w:.2} s of it waiting)");
        }
    }
    if s.stopping {
        text.push_str("; stops at the end of this step");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::StepAt;
    use clap::Parser;

    #[test]
    fn a_waiting_cycle_says_what_it_waits_for_where_and_how_far_it_got() {
        let mut s = CycleStatus::starting("press-load", Some(10));
        s.state = CycleState::Waiting;
        s.done = 4;
        s.waiting_for = Some("press_open (X5)".into());
        s.waiting_s = Some(2.44);
        s.step = Some(StepAt {
            program: "load".into(),
            step: 3,
            label: Some("in".into()),
            does: "wait for press_open (X5)".into(),
            called_from: vec!["press-load step 2".into()],
        });
        s.last_cycle_s = Some(7.123);
        s.last_cycle_waiting_s = Some(1.5);
        assert_eq!(
            describe(&s),
            "press-load: waiting for press_open (X5) for 2.4 s at step 3 (in) of load, called \
             from press-load step 2: wait for press_open (X5); 4 of 10 done, last cycle 7.12 s \
             (1.50 s of it waiting)"
        );
    }

    fn cycle(line: &[&str]) -> CycleArgs {
        let cli = crate::cli::Cli::try_parse_from(line).unwrap();
        let crate::cli::Command::Cycle(args) = cli.command else {
            panic!("not cycle")
        };
        args
    }

    #[test]
    fn cycle_run_accepts_json_after_the_subcommand() {
        let args = cycle(&[
            "linterpd",
            "cycle",
            "run",
            "press-load",
            "--count",
            "3",
            "--json",
        ]);
        assert!(args.daemon.json);
        assert!(matches!(
            args.action,
            CycleAction::Run { count: Some(3), .. }
        ));
        let args = cycle(&["linterpd", "cycle", "--json", "run", "press-load"]);
        assert!(args.daemon.json);
    }

    #[test]
    fn cycle_status_accepts_socket_and_robot_after_the_subcommand() {
        let args = cycle(&[
            "linterpd",
            "cycle",
            "status",
            "--socket",
            "/tmp/x.sock",
            "--robot",
            "r",
        ]);
        assert_eq!(args.daemon.socket, std::path::Path::new("/tmp/x.sock"));
        assert_eq!(args.robot.as_deref(), Some("r"));
    }

    #[test]
    fn cycle_run_detach_needs_follow() {
        let line = ["linterpd", "cycle", "run", "p", "--detach"];
        assert!(crate::cli::Cli::try_parse_from(line).is_err());
        let args = cycle(&["linterpd", "cycle", "run", "p", "--follow", "--detach"]);
        assert!(matches!(
            args.action,
            CycleAction::Run {
                follow: true,
                detach: true,
                ..
            }
        ));
    }

    #[test]
    fn a_faulted_cycle_says_why_and_a_stopping_one_says_when() {
        let mut s = CycleStatus::starting("press-load", None);
        s.state = CycleState::Faulted;
        s.reason = Some("wait for part_present (X2) timed out after 30 s".into());
        s.stopping = true;
        assert_eq!(
            describe(&s),
            "press-load: FAULTED; wait for part_present (X2) timed out after 30 s; 0 done; stops \
             at the end of this step"
        );
    }
}
