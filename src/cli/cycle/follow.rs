//! `linterpd cycle run --follow`: the cycle's status from the daemon's live stream (`GET
//! /v1/robots/{name}/live`, the console's stream: a change each status read the daemon makes,
//! no request of its own) and a line printed each
//! time it moves on (the cycle, the step, what it waits for), until the count is done (exit 0),
//! or it faults or is stopped (exit 3, naming the step and the wait or the reason). A pause (a
//! hold, `cycle pause`) is said and followed on: `cycle resume` goes on. The lines are decided
//! by [`Watch`], a pure function of the statuses seen. A daemon without the stream (an older
//! one: 404), or a stream that ends, is read every [`POLL`] instead.
//!
//! ```text
//! press-load: cycle 1 of 3, step 1 (pick): move to [-926.57, 535.03, 130.0]
//! press-load: cycle 1 of 3, step 2: wait for part_present (X2): waiting for part_present (X2)
//! ...
//! press-load: done, 3 of 3 cycles, last cycle 6.27 s (1.02 s of it waiting)
//! ```

use std::fmt::Write as _;
use std::time::Duration;

use anyhow::anyhow;
use hyper::Method;
use serde_json::Value;

use crate::cli::Failure;
use crate::cli::client::{Client, Received};
use crate::daemon::{CycleState, CycleStatus};

/// How often the status is read.
pub(super) const POLL: Duration = Duration::from_millis(100);

/// The follower's memory: the last line said.
#[derive(Debug, Default)]
pub(super) struct Watch {
    last: Option<String>,
}

/// How a followed cycle ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum End {
    /// The count is done.
    Done,
    /// Faulted or stopped: why, naming the step.
    NotDone(String),
}

impl Watch {
    /// The line to say for `status`, if it differs from the last one said.
    pub(super) fn see(&mut self, status: &CycleStatus) -> Option<String> {
        let line = line(status)?;
        if self.last.as_ref() == Some(&line) {
            return None;
        }
        self.last = Some(line.clone());
        Some(line)
    }
}

/// Where a cycle stands, in one line: `None` between steps (nothing to say yet).
fn line(s: &CycleStatus) -> Option<String> {
    let cycle = match s.count {
        Some(n) => format!("cycle {} of {n}", (s.done + 1).min(n)),
        None => format!("cycle {}", s.done + 1),
    };
    let at = s.step.as_ref().map(|step| {
        let label = step
            .label
            .as_ref()
            .map(|l| format!(" ({l})"))
            .unwrap_or_default();
        let program = if step.program == s.program {
            String::new()
        } else {
            format!(" of {}", step.program)
        };
        format!("step {}{label}{program}: {}", step.step, step.does)
    });
    let mut text = format!("{}: ", s.program);
    match s.state {
        CycleState::Running => {
            let _ = write!(text, "{cycle}, {}", at?);
        }
        CycleState::Waiting => {
            let what = s.waiting_for.as_deref().unwrap_or("its condition");
            let _ = write!(text, "{cycle}, {}: waiting for {what}", at?);
        }
        CycleState::Paused => {
            let where_ = at.map(|a| format!(" at {a}")).unwrap_or_default();
            let why = s
                .reason
                .as_ref()
                .map(|r| format!(": {r}"))
                .unwrap_or_default();
            let _ = write!(
                text,
                "{cycle}, PAUSED{where_}{why} (`linterpd cycle resume` goes on)"
            );
        }
        CycleState::Done | CycleState::Faulted | CycleState::Stopped => {
            return Some(super::describe(s));
        }
    }
    Some(text)
}

/// How the cycle ended, once it has: `None` while it goes on.
pub(super) fn end(s: &CycleStatus) -> Option<End> {
    let at = || {
        s.step
            .as_ref()
            .map(|step| {
                let label = step
                    .label
                    .as_ref()
                    .map(|l| format!(" ({l})"))
                    .unwrap_or_default();
                format!(
                    " at step {}{label} of {}: {}",
                    step.step, step.program, step.does
                )
            })
            .unwrap_or_default()
    };
    let why = || {
        s.reason
            .as_ref()
            .map(|r| format!("; {r}"))
            .unwrap_or_default()
    };
    let done = match s.count {
        Some(n) => format!("{} of {n} cycles done", s.done),
        None => format!("{} cycles done", s.done),
    };
    match s.state {
        CycleState::Done => Some(End::Done),
        CycleState::Faulted => Some(End::NotDone(format!(
            "{} faulted{}{}; {done} (`linterpd clear-fault`, then `linterpd cycle resume`)",
            s.program,
            at(),
            why()
        ))),
        CycleState::Stopped => Some(End::NotDone(format!(
            "{} stopped{}{}; {done}",
            s.program,
            at(),
            why()
        ))),
        CycleState::Running | CycleState::Waiting | CycleState::Paused => None,
    }
}

/// Follows the robot's cycle from `first` (the status its run was answered with) to its end,
/// printing a line each time it moves on (with `json`, each status the API gives).
pub(super) async fn follow(
    client: &Client,
    robot: &str,
    first: Received<CycleStatus>,
    json: bool,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let mut watch = Watch::default();
    let path = format!("/v1/robots/{robot}/cycles");
    let mut status = first;
    let mut stream = client.live(Some(robot)).await.ok().and_then(Result::ok);
    let mut ticks = tokio::time::interval(POLL);
    ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        say(&mut watch, &status, json, out)?;
        if let Some(end) = end(&status.value) {
            return match end {
                End::Done => Ok(()),
                End::NotDone(why) => Err(Failure::NotDone(anyhow!(why))),
            };
        }
        if let Some(feed) = &mut stream {
            match feed.next().await {
                Ok(Some(update)) => {
                    // The whole snapshot first may predate the run (it is as old as the last
                    // status read): only what was published after the stream opened counts.
                    let fresh = update.line["type"] == "patch";
                    if let Some(cycle) = update.live.state.cycle.filter(|_| fresh) {
                        let json = serde_json::to_value(&cycle).unwrap_or_default();
                        status = Received { value: cycle, json };
                    }
                    continue;
                }
                // Ended (the daemon closed it, or this reader fell behind): poll from here.
                Ok(None) | Err(_) => stream = None,
            }
        }
        ticks.tick().await;
        let answer: Value = client.expect(Method::GET, &path, None).await?;
        status = Received::read(answer, "a cycle's status").map_err(Failure::Runtime)?;
    }
}

fn say(
    watch: &mut Watch,
    status: &Received<CycleStatus>,
    json: bool,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let Some(line) = watch.see(&status.value) else {
        return Ok(());
    };
    let written = if json {
        writeln!(out, "{}", status.json)
    } else {
        writeln!(out, "{line}")
    };
    written
        .and_then(|()| out.flush())
        .map_err(|e| Failure::Runtime(e.into()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::StepAt;

    fn at(step: usize, label: Option<&str>, does: &str) -> StepAt {
        StepAt {
            program: "press-load".into(),
            step,
            label: label.map(str::to_owned),
            does: does.into(),
            called_from: Vec::new(),
        }
    }

    #[test]
    fn follow_says_each_step_once_with_the_cycle_and_what_it_waits_for() {
        let mut watch = Watch::default();
        let mut s = CycleStatus::starting("press-load", Some(3));
        assert_eq!(watch.see(&s), None, "nothing to say before the first step");
        s.step = Some(at(1, Some("pick"), "move to [-926.57, 535.03, 130.0]"));
        assert_eq!(
            watch.see(&s).as_deref(),
            Some("press-load: cycle 1 of 3, step 1 (pick): move to [-926.57, 535.03, 130.0]")
        );
        assert_eq!(watch.see(&s), None, "the same step is said once");
        s.state = CycleState::Waiting;
        s.step = Some(at(6, Some("before-press"), "wait for press_open (X5)"));
        s.waiting_for = Some("press_open (X5)".into());
        s.waiting_s = Some(0.4);
        s.done = 1;
        assert_eq!(
            watch.see(&s).as_deref(),
            Some(
                "press-load: cycle 2 of 3, step 6 (before-press): wait for press_open (X5): \
                 waiting for press_open (X5)"
            )
        );
        s.waiting_s = Some(0.9);
        assert_eq!(watch.see(&s), None, "the time waited is no news");
        s.state = CycleState::Paused;
        s.reason = Some("held by the PLC: X5 is off".into());
        assert!(watch.see(&s).unwrap().contains(
            "PAUSED at step 6 (before-press): wait for press_open (X5): held by the PLC"
        ));
        assert_eq!(end(&s), None, "a pause is followed on");
    }

    #[test]
    fn follow_ends_zero_when_the_count_is_done_and_names_the_wait_of_a_fault() {
        let mut s = CycleStatus::starting("press-load", Some(3));
        s.state = CycleState::Done;
        s.done = 3;
        assert_eq!(end(&s), Some(End::Done));
        s.state = CycleState::Faulted;
        s.done = 0;
        s.step = Some(at(
            6,
            Some("before-press"),
            "wait for press_open (X5) & !press_moving (X6)",
        ));
        s.reason = Some("wait timed out after 2 s".into());
        let Some(End::NotDone(why)) = end(&s) else {
            panic!()
        };
        assert_eq!(
            why,
            "press-load faulted at step 6 (before-press) of press-load: wait for press_open (X5) \
             & !press_moving (X6); wait timed out after 2 s; 0 of 3 cycles done (`linterpd \
             clear-fault`, then `linterpd cycle resume`)"
        );
        s.state = CycleState::Stopped;
        s.step = None;
        s.reason = None;
        assert_eq!(
            end(&s),
            Some(End::NotDone(
                "press-load stopped; 0 of 3 cycles done".into()
            ))
        );
    }
}
