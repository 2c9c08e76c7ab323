//! `/v1/robots/{name}/mode`: who drives the robot, local (the CLI and the API) or remote (the
//! cell face).
//!
//! ```text
//! GET /v1/robots/{name}/mode                      {"mode"}        | 404
//! PUT /v1/robots/{name}/mode    {"mode"}          {"mode"}        | 400 | 404 | 409 busy
//! ```

use axum::Json;
use axum::extract::{Path, State};
use serde::{Deserialize, Serialize};

use super::body::JsonBody;
use super::error::ApiError;
use super::{Api, handlers};
use crate::cell::Mode;

/// What `GET` answers and `PUT` takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeBody {
    /// Who drives the robot.
    pub mode: Mode,
}

pub(super) async fn get(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<ModeBody>, ApiError> {
    let robot = api.robot(&name)?;
    Ok(Json(ModeBody { mode: robot.mode() }))
}

pub(super) async fn put(
    State(api): State<Api>,
    Path(name): Path<String>,
    JsonBody(body): JsonBody,
) -> Result<Json<ModeBody>, ApiError> {
    let robot = api.robot(&name)?;
    let asked: ModeBody = handlers::parse_body(&body)?;
    tracing::info!(robot = %name, mode = %asked.mode, "mode change requested");
    let mode = robot.set_mode(asked.mode).await?;
    Ok(Json(ModeBody { mode }))
}
