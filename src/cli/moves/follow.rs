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
use crate::cli::client::{Client, Feed, Received};
use crate::daemon::{MoveReport, RobotState};

/// How often the robot's state is read while a move is followed.
const STATE_POLL: Duration = Duration::from_millis(500);

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
) -> Result<Received<MoveReport>, Failure> {
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
    pub(super) async fn run(&self) -> Result<Received<MoveReport>, Failure> {
        let mut feed = self.open_feed().await?;
        let mut bars = Bars::new(self.quiet);
        let mut deadline = Deadline::new(Instant::now(), self.timeout);
        let (mut last, mut state) = (None::<MoveReport>, None::<RobotState>);
        let mut polls = tokio::time::interval(STATE_POLL);
        polls.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            let give_up = tokio::time::Instant::from_std(deadline.at());
            tokio::select! {
                line = feed.next() => {
                    let report = self.feed_line(line, last.as_ref())?;
                    deadline.report(&report.value, Instant::now());
                    bars.show(&report.value);
                    if report.value.stage.is_final() {
                        bars.clear();
                        return Ok(report);
                    }
                    last = Some(report.value);
                }
                _ = polls.tick() => {
                    let Some(now_state) = self.read_state().await else { continue };
                    deadline.state(&now_state, self.id, Instant::now());
                    if link_down(Some(&now_state)) && !link_down(state.as_ref()) {
                        let waiting = waiting_for(last.as_ref(), Some(&now_state));
                        bars.say(&format!("move {}: waiting for {waiting}", self.id));
                    }
                    state = Some(now_state);
                }
                () = tokio::time::sleep_until(give_up) => {
                    bars.clear();
                    return Err(Failure::NotDone(anyhow!(
                        "move {} did not end within {}: it was {}, waiting for {}; it was not \
                         stopped (`linterpd stop` stops it)",
                        self.id,
                        deadline.describe(),
                        stage_seen(last.as_ref()),
                        waiting_for(last.as_ref(), state.as_ref())
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

    /// The report a feed line holds; a feed that ended or broke (a line that is no move report
    /// included) before a final report means the daemon went away.
    fn feed_line(
        &self,
        line: anyhow::Result<Option<Value>>,
        last: Option<&MoveReport>,
    ) -> Result<Received<MoveReport>, Failure> {
        let lost = |why: String| {
            Failure::Unreachable(anyhow!(
                "{why} before move {} ended (last seen {}): is the daemon shutting down?",
                self.id,
                stage_seen(last)
            ))
        };
        match line.and_then(|l| {
            l.map(|json| Received::read(json, "a move report"))
                .transpose()
        }) {
            Ok(Some(report)) => Ok(report),
            Ok(None) => Err(lost("the daemon ended the progress feed".to_owned())),
            Err(e) => Err(lost(format!("the progress feed broke ({e:#})"))),
        }
    }

    /// The robot's state, or `None` when it cannot be read now (the feed tells when the daemon
    /// is gone).
    async fn read_state(&self) -> Option<RobotState> {
        let path = format!("/v1/robots/{}", self.robot);
        let answer = self.client.call(Method::GET, &path, None).await.ok()?;
        if !answer.status.is_success() {
            return None;
        }
        Received::read(answer.body, "a robot's state")
            .ok()
            .map(|r| r.value)
    }
}

/// The stage of the last report seen, in words.
fn stage_seen(last: Option<&MoveReport>) -> &'static str {
    last.map_or("not reported yet", |r| r.stage.name())
}
