//! The daemon's live stream as the CLI reads it (`GET /v1/live`, `GET /v1/robots/{name}/live`):
//! each robot's whole snapshot, then merge patches applied to it here
//! ([`crate::console::patch::apply`]), so each message gives the robot's [`Live`] state whole.

use std::collections::BTreeMap;

use anyhow::{Context, anyhow};
use serde_json::Value;

use super::{Answer, Client, Feed};
use crate::console::patch;
use crate::wire::Live;

/// A live stream being read.
#[derive(Debug)]
pub struct LiveFeed {
    feed: Feed,
    robots: BTreeMap<String, (u64, Value)>,
}

/// One message read: the robot, its snapshot after it, and the line as the daemon sent it.
#[derive(Debug)]
pub struct LiveUpdate {
    /// The robot.
    pub robot: String,
    /// Its snapshot now.
    pub live: Live,
    /// The message as sent.
    pub line: Value,
}

impl Client {
    /// Opens the live stream of `robot`, or of every robot.
    pub async fn live(&self, robot: Option<&str>) -> anyhow::Result<Result<LiveFeed, Answer>> {
        let path = robot.map_or("/v1/live".to_owned(), |r| format!("/v1/robots/{r}/live"));
        Ok(self.feed(&path).await?.map(|feed| LiveFeed {
            feed,
            robots: BTreeMap::new(),
        }))
    }
}

impl LiveFeed {
    /// The next message, applied; `None` once the stream has ended (the daemon closed it, or
    /// this reader fell behind: open it again).
    pub async fn next(&mut self) -> anyhow::Result<Option<LiveUpdate>> {
        let Some(line) = self.feed.next().await? else {
            return Ok(None);
        };
        let kind = line["type"].as_str().unwrap_or_default().to_owned();
        let robot = line["robot"].as_str().unwrap_or_default().to_owned();
        let seq = line["seq"].as_u64().unwrap_or_default();
        let value = match kind.as_str() {
            "full" => line["live"].clone(),
            "patch" => {
                let (last, value) = self
                    .robots
                    .get_mut(&robot)
                    .ok_or_else(|| anyhow!("a change of robot {robot} before its snapshot"))?;
                if seq != *last + 1 {
                    return Err(anyhow!(
                        "the live stream of {robot} skipped from message {last} to {seq}"
                    ));
                }
                patch::apply(value, &line["patch"]);
                value.clone()
            }
            "lagged" => return Ok(None),
            other => return Err(anyhow!("a live stream message of type {other:?}")),
        };
        self.robots.insert(robot.clone(), (seq, value.clone()));
        let live: Live = serde_json::from_value(value).context("a robot's live state")?;
        Ok(Some(LiveUpdate { robot, live, line }))
    }
}
