//! Following a move to its end: its progress feed (bars on a terminal, `bars.rs`), the robot's state read
//! beside it (a link that goes down is said once on stderr, with what the move waits for), and
//! the deadline of [`super::wait`].

use std::time::{Duration, Instant};

use anyhow::anyhow;
use hyper::Method;
use serde_json::Value;

use super::bars::Bars;
use super::wait::{Deadline, link_down, waiting_for};
use crate::cli::Failure;
use crate::cli::client::{Client, Feed};

/// How often the robot's state is read while a move is followed.
const STATE_POLL: Duration = Duration::from_millis(500);

/// Stages after which nothing more happens to a move.
pub(super) fn is_final(stage: &str) -> bool {
    matches!(stage, "done" | "stopped" | "failed" | "cancelled")
}

/// A move being followed.
pub(super) struct Follow<'a> {
    /// The daemon.
    pub client: &'a Client,
    /// The robot.
    pub robot: &'a str,
    /// The move.
    pub id: u64,
    /// `--timeout`.
    pub timeout: Option<Duration>,
    /// No progress bar (`--json`).
    pub quiet: bool,
}

/// Follows move `id` to its final report ([`Follow::run`]).
pub(super) async fn to_end(
    client: &Client,
    robot: &str,
    id: u64,
    timeout: Option<Duration>,
    quiet: bool,
) -> Result<Value, Failure> {
    let follow = Follow {
        client,
        robot,
        id,
        timeout,
        quiet,
    };
    follow.run().await
}

impl Follow<'_> {
    /// Follows the move to a final report; a deadline that runs out, or a feed that ends first,
    /// is a failure saying what the move was waiting for.
    pub(super) async fn run(&self) -> Result<Value, Failure> {
        let mut feed = self.open_feed().await?;
        let mut bars = Bars::new(self.quiet);
        let mut deadline = Deadline::new(Instant::now(), self.timeout);
        let (mut last, mut state) = (Value::Null, Value::Null);
        let mut polls = tokio::time::interval(STATE_POLL);
        polls.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            let give_up = tokio::time::Instant::from_std(deadline.at());
            tokio::select! {
                line = feed.next() => {
                    let report = self.feed_line(line, &last)?;
                    deadline.report(&report, Instant::now());
                    bars.show(&report);
                    last = report;
                    if is_final(last["stage"].as_str().unwrap_or("")) {
                        bars.clear();
                        return Ok(last);
                    }
                }
                _ = polls.tick() => {
                    let Some(now_state) = self.read_state().await else { continue };
                    deadline.state(&now_state, self.id, Instant::now());
                    if link_down(&now_state) && !link_down(&state) {
                        let waiting = waiting_for(&last, &now_state);
                        bars.say(&format!("move {}: waiting for {waiting}", self.id));
                    }
                    state = now_state;
                }
                () = tokio::time::sleep_until(give_up) => {
                    bars.clear();
                    return Err(Failure::NotDone(anyhow!(
                        "move {} did not end within {}: it was {}, waiting for {}; it was not \
                         stopped (`linterpd stop` stops it)",
                        self.id,
                        deadline.describe(),
                        last["stage"].as_str().unwrap_or("not reported yet"),
                        waiting_for(&last, &state)
                    )));
                }
            }
        }
    }

    async fn open_feed(&self) -> Result<Feed, Failure> {
        let path = format!("/v1/robots/{}/moves/{}/events", self.robot, self.id);
        match self.client.feed(&path).await {
            Ok(Ok(feed)) => Ok(feed),
            Ok(Err(answer)) => Err(Failure::from_status(
                answer.status,
                anyhow!("{}", answer.error()),
            )),
            Err(e) => Err(Failure::from_client(e)),
        }
    }

    /// The report a feed line holds; a feed that ended or broke before a final report means the
    /// daemon went away.
    fn feed_line(
        &self,
        line: anyhow::Result<Option<Value>>,
        last: &Value,
    ) -> Result<Value, Failure> {
        let lost = |why: String| {
            Failure::Unreachable(anyhow!(
                "{why} before move {} ended (last seen {}): is the daemon shutting down?",
                self.id,
                last["stage"].as_str().unwrap_or("not reported yet")
            ))
        };
        match line {
            Ok(Some(report)) => Ok(report),
            Ok(None) => Err(lost("the daemon ended the progress feed".to_owned())),
            Err(e) => Err(lost(format!("the progress feed broke ({e:#})"))),
        }
    }

    /// The robot's state, or `None` when it cannot be read now (the feed tells when the daemon
    /// is gone).
    async fn read_state(&self) -> Option<Value> {
        let path = format!("/v1/robots/{}", self.robot);
        let answer = self.client.call(Method::GET, &path, None).await.ok()?;
        answer.status.is_success().then_some(answer.body)
    }
}
