//! The live stream on the API (`linterpd status --watch`, `cycle run --follow`): NDJSON, the
//! whole snapshot first, then a merge patch per change ([`crate::wire::LiveMessage`]), from the
//! same publisher as the console's `WebSocket`s. And the speed override, read and set.
//!
//! ```text
//! GET /v1/live                          every robot's stream, interleaved
//! GET /v1/robots/{name}/live            one robot's
//! GET /v1/robots/{name}/speed-override  {"percent": 100}
//! PUT /v1/robots/{name}/speed-override  {"percent": 50} -> {"percent": 50}
//! ```
//! A reader that falls [`crate::daemon::stream::CAPACITY`] messages behind is ended (its last
//! line is `{"type":"lagged",...}`); it reconnects and starts from a whole snapshot.

use std::convert::Infallible;

use axum::Json;
use axum::body::{Body, Bytes};
use axum::extract::{Path, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use tokio::sync::{broadcast, mpsc};

use super::Api;
use super::error::ApiError;
use crate::daemon::stream::RobotStream;

pub(super) async fn all(State(api): State<Api>) -> Result<Response, ApiError> {
    let hub = api.live.as_ref().ok_or_else(no_stream)?;
    Ok(stream(hub.robots().values().cloned().collect(), &api))
}

pub(super) async fn one(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Response, ApiError> {
    api.robot(&name)?;
    let hub = api.live.as_ref().ok_or_else(no_stream)?;
    let robot = hub.robot(&name).ok_or_else(no_stream)?;
    Ok(stream(vec![robot.clone()], &api))
}

fn no_stream() -> ApiError {
    ApiError::Unavailable {
        message: "this daemon publishes no live stream".into(),
        reason: "shutting-down",
    }
}

/// NDJSON lines of `robots`' streams until the daemon closes or the reader falls behind.
fn stream(robots: Vec<RobotStream>, api: &Api) -> Response {
    let (tx, rx) = mpsc::channel::<Bytes>(crate::daemon::stream::CAPACITY);
    for robot in robots {
        let (tx, closing) = (tx.clone(), api.closing.clone());
        tokio::spawn(async move {
            tokio::select! {
                () = forward(robot, tx) => {}
                () = closing.cancelled() => {}
            }
        });
    }
    drop(tx);
    let lines = futures_util::stream::unfold(rx, |mut rx| async move {
        let line = rx.recv().await?;
        Some((Ok::<_, Infallible>(line), rx))
    });
    (
        [(header::CONTENT_TYPE, "application/x-ndjson")],
        Body::from_stream(lines),
    )
        .into_response()
}

/// One robot's messages into `tx`, each a line.
async fn forward(robot: RobotStream, tx: mpsc::Sender<Bytes>) {
    let mut sub = robot.subscribe();
    if tx.send(line(&sub.first)).await.is_err() {
        return;
    }
    loop {
        match sub.rest.recv().await {
            Ok(frame) if frame.seq <= sub.seq => {}
            Ok(frame) => {
                if tx.send(line(&frame.text)).await.is_err() {
                    return;
                }
            }
            Err(broadcast::error::RecvError::Lagged(n)) => {
                let end = serde_json::json!({"type": "lagged", "robot": robot.name(), "missed": n});
                let _ = tx.send(line(&end.to_string())).await;
                return;
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
    }
}

fn line(text: &str) -> Bytes {
    let mut s = String::with_capacity(text.len() + 1);
    s.push_str(text);
    s.push('\n');
    Bytes::from(s)
}

/// The speed override, as the API reads and sets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedOverride {
    /// 1 to 100 %.
    pub percent: u8,
}

pub(super) async fn get_override(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<SpeedOverride>, ApiError> {
    let robot = api.robot(&name)?;
    Ok(Json(SpeedOverride {
        percent: robot.speed_override(),
    }))
}

pub(super) async fn put_override(
    State(api): State<Api>,
    Path(name): Path<String>,
    body: Bytes,
) -> Result<Json<SpeedOverride>, ApiError> {
    let robot = api.robot(&name)?;
    let value: serde_json::Value =
        serde_json::from_slice(&body).map_err(|e| ApiError::BadRequest {
            message: format!("the body is not valid JSON: {e}"),
            field: None,
        })?;
    let bad = |shown: String| ApiError::BadRequest {
        message: format!(
            "percent = {shown}: must be a whole number within 1 to 100 (the share of every \
             move's speed)"
        ),
        field: Some("percent".into()),
    };
    let percent = match value.get("percent") {
        Some(v) => v
            .as_u64()
            .filter(|p| (1..=100).contains(p))
            .ok_or_else(|| bad(v.to_string()))?,
        None => return Err(bad("(missing)".into())),
    };
    if let Some(other) = value
        .as_object()
        .and_then(|o| o.keys().find(|k| *k != "percent"))
    {
        return Err(ApiError::BadRequest {
            message: format!("{other}: unknown field, expected `percent`"),
            field: Some(other.clone()),
        });
    }
    let percent = robot.set_speed_override(percent as u8);
    tracing::info!(robot = %name, percent, "speed override set");
    Ok(Json(SpeedOverride { percent }))
}
