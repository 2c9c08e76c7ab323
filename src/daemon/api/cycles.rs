//! `/v1/robots/{name}/cycles`: run a cycle program, watch it, stop, pause and resume it.
//!
//! ```text
//! POST /v1/robots/{name}/cycles         {"program", "count"?}  202 CycleStatus | 400 | 404 | 409
//! GET  /v1/robots/{name}/cycles         CycleStatus                          | 404
//! POST /v1/robots/{name}/cycles/stop    {"now"?}               CycleStatus   | 404 | 409
//! POST /v1/robots/{name}/cycles/pause                          CycleStatus   | 404 | 409
//! POST /v1/robots/{name}/cycles/resume                         CycleStatus   | 404 | 409
//! ```
//! Running, pausing and resuming are the local controller's: refused (409 `mode-remote`) while
//! the cell face drives the robot. A stop is taken in both modes.

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};

use super::error::ApiError;
use super::{Api, handlers};
use crate::cell::Mode;
use crate::daemon::CycleStatus;

/// What `POST .../cycles` takes.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CycleOrder {
    /// The program's name.
    pub program: String,
    /// How many cycles (none: until stopped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u64>,
}

/// What `POST .../cycles/stop` takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct CycleStop {
    /// Stop the robot now, mid-step.
    #[serde(default)]
    pub now: bool,
}

pub(super) async fn run(
    State(api): State<Api>,
    Path(name): Path<String>,
    body: Bytes,
) -> Result<(StatusCode, Json<CycleStatus>), ApiError> {
    let robot = api.robot(&name)?;
    let order: CycleOrder = handlers::parse_body(&body)?;
    tracing::info!(robot = %name, program = %order.program, count = order.count, "cycle run requested");
    let status = {
        let _owner = robot.owned_by(Mode::Local).await?;
        robot.run_cycle(&order.program, order.count).await?
    };
    Ok((StatusCode::ACCEPTED, Json(status)))
}

pub(super) async fn status(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<CycleStatus>, ApiError> {
    let robot = api.robot(&name)?;
    robot
        .cycle()
        .map(Json)
        .ok_or_else(|| crate::daemon::CycleError::NoCycle.into())
}

pub(super) async fn stop(
    State(api): State<Api>,
    Path(name): Path<String>,
    body: Bytes,
) -> Result<Json<CycleStatus>, ApiError> {
    let robot = api.robot(&name)?;
    let stop: CycleStop = if body.is_empty() {
        CycleStop::default()
    } else {
        handlers::parse_body(&body)?
    };
    tracing::info!(robot = %name, now = stop.now, "cycle stop requested");
    Ok(Json(robot.stop_cycle(stop.now).await?))
}

pub(super) async fn pause(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<CycleStatus>, ApiError> {
    let robot = api.robot(&name)?;
    tracing::info!(robot = %name, "cycle pause requested");
    let _owner = robot.owned_by(Mode::Local).await?;
    Ok(Json(robot.pause_cycle().await?))
}

pub(super) async fn resume(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<CycleStatus>, ApiError> {
    let robot = api.robot(&name)?;
    tracing::info!(robot = %name, "cycle resume requested");
    let _owner = robot.owned_by(Mode::Local).await?;
    Ok(Json(robot.resume_cycle().await?))
}
