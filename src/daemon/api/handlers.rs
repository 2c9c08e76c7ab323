//! The handlers: each takes its path parameters and body, asks a [`RobotHandle`] and answers JSON
//! (or NDJSON, or the metrics text).

use crate::cell::Mode;
use std::convert::Infallible;

use axum::Json;
use axum::body::{Body, Bytes};
use axum::extract::{Path, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::error::Category;
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;

use super::Api;
use super::answers::{self, DeletedPosition, NamedPosition, PositionList, SavedPosition};
use super::body::JsonBody;
use super::error::ApiError;
use super::metrics;
use crate::daemon::{
    MoveAccepted, MoveId, MoveOrder, MoveReport, PathAccepted, PathOrder, RobotHandle, RobotState,
};

pub(super) async fn robots(State(api): State<Api>) -> Json<Vec<RobotState>> {
    Json(api.robots.values().map(RobotHandle::state).collect())
}

pub(super) async fn robot(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<RobotState>, ApiError> {
    Ok(Json(api.robot(&name)?.state()))
}

pub(super) async fn submit(
    State(api): State<Api>,
    Path(name): Path<String>,
    JsonBody(body): JsonBody,
) -> Result<(StatusCode, Json<MoveAccepted>), ApiError> {
    let robot = api.robot(&name)?;
    let order = parse_order(&body)?;
    let ids = {
        let _owner = robot.owned_by(Mode::Local).await?;
        robot.submit_starts(order.clone()).await?
    };
    let id = ids[ids.len() - 1];
    tracing::info!(robot = %name, move_id = id, starts = ids.len(), "move accepted");
    // Queued: the answer is 202 whatever follows (a report of a queued move is never dropped).
    let report = robot
        .report(id)
        .unwrap_or_else(|| MoveReport::new(id, &name, order));
    Ok((StatusCode::ACCEPTED, Json(MoveAccepted { id, ids, report })))
}

pub(super) async fn submit_path(
    State(api): State<Api>,
    Path(name): Path<String>,
    JsonBody(body): JsonBody,
) -> Result<(StatusCode, Json<PathAccepted>), ApiError> {
    let robot = api.robot(&name)?;
    let order: PathOrder = parse_body(&body)?;
    // A path takes milliseconds to plan (13 ms and more): the handle plans it off the runtime,
    // so the workers' status polls are not held up behind it.
    let ids = {
        let _owner = robot.owned_by(Mode::Local).await?;
        robot.submit_path(&order).await?
    };
    tracing::info!(robot = %name, sections = ids.len(), first_move_id = ids.first().copied().unwrap_or(0), "path accepted");
    // Queued: the answer is 202 whatever follows; a report that ended and was dropped since
    // (only ended ones are) is left out.
    let reports = ids.iter().filter_map(|&id| robot.report(id)).collect();
    Ok((StatusCode::ACCEPTED, Json(PathAccepted { ids, reports })))
}

pub(super) async fn report(
    State(api): State<Api>,
    Path((name, id)): Path<(String, String)>,
) -> Result<Json<MoveReport>, ApiError> {
    let robot = api.robot(&name)?;
    let id = move_id(&id)?;
    robot.report(id).map(Json).ok_or_else(|| no_move(id))
}

pub(super) async fn events(
    State(api): State<Api>,
    Path((name, id)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let robot = api.robot(&name)?;
    let id = move_id(&id)?;
    let feed = robot.subscribe(id).ok_or_else(|| no_move(id))?;
    let lines = futures_util::stream::unfold(
        (Feed::First(feed), api.closing.clone()),
        |(feed, closing)| async move {
            let (line, next) = next_line(feed, &closing).await?;
            Some((Ok::<_, Infallible>(line), (next, closing)))
        },
    );
    Ok((
        [(header::CONTENT_TYPE, "application/x-ndjson")],
        Body::from_stream(lines),
    )
        .into_response())
}

pub(super) async fn stop(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let robot = api.robot(&name)?;
    tracing::info!(robot = %name, "stop requested");
    robot.stop().await?;
    Ok(Json(serde_json::json!({ "stopped": true })))
}

pub(super) async fn clear_fault(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let robot = api.robot(&name)?;
    tracing::info!(robot = %name, "fault clear requested");
    drop(robot.owned_by(Mode::Local).await?);
    robot.clear_fault().await?;
    Ok(Json(serde_json::json!({ "cleared": true })))
}

pub(super) async fn home(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let robot = api.robot(&name)?;
    tracing::info!(robot = %name, "home requested");
    drop(robot.owned_by(Mode::Local).await?);
    robot.home().await?;
    Ok(Json(serde_json::json!({ "homed": true })))
}

pub(super) async fn positions(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let robot = api.robot(&name)?;
    let positions = robot
        .positions()
        .into_iter()
        .map(|(name, position)| NamedPosition { name, position })
        .collect();
    let warning = robot.positions_warning().map(str::to_owned);
    Ok(Json(answers::sorted(&PositionList { positions, warning })))
}

pub(super) async fn position(
    State(api): State<Api>,
    Path((name, pos)): Path<(String, String)>,
) -> Result<Json<NamedPosition>, ApiError> {
    let position = api.robot(&name)?.position(&pos)?;
    Ok(Json(NamedPosition {
        name: pos,
        position,
    }))
}

/// `PUT .../positions/{pos}`'s query: `?frame=NAME` keeps the position in that frame.
#[derive(Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SaveParams {
    frame: Option<String>,
}

pub(super) async fn save_position(
    State(api): State<Api>,
    Path((name, pos)): Path<(String, String)>,
    axum::extract::Query(params): axum::extract::Query<SaveParams>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let robot = api.robot(&name)?;
    let saved = robot.save_position(&pos, params.frame.as_deref())?;
    let answer = SavedPosition {
        saved: NamedPosition {
            name: pos,
            position: saved.position,
        },
        replaced: saved.replaced,
        warning: robot.positions_warning().map(str::to_owned),
    };
    Ok(Json(answers::sorted(&answer)))
}

pub(super) async fn delete_position(
    State(api): State<Api>,
    Path((name, pos)): Path<(String, String)>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let position = api.robot(&name)?.delete_position(&pos)?;
    let deleted = NamedPosition {
        name: pos,
        position,
    };
    Ok(Json(answers::sorted(&DeletedPosition { deleted })))
}

pub(super) async fn metrics(State(api): State<Api>) -> impl IntoResponse {
    let states: Vec<_> = api.robots.values().map(RobotHandle::state).collect();
    // Every robot of a daemon shares one set of metrics; with no robot there is only build info.
    let text = match api.robots.values().next() {
        Some(robot) => metrics::render(robot.metrics(), &states),
        None => metrics::render(&crate::daemon::metrics::Metrics::new(), &states),
    };
    let text = match &api.journal {
        Some(journal) => super::metrics_text(journal, text),
        None => text,
    };
    ([(header::CONTENT_TYPE, metrics::CONTENT_TYPE)], text)
}

pub(super) async fn no_route() -> ApiError {
    ApiError::NotFound {
        message: "no such path; the API is under /v1/robots (docs/API.md)".into(),
        field: None,
    }
}

pub(super) async fn wrong_method() -> ApiError {
    ApiError::MethodNotAllowed
}

fn move_id(text: &str) -> Result<MoveId, ApiError> {
    text.parse().map_err(|_| ApiError::NotFound {
        message: format!("no move {text:?}: a move id is a number"),
        field: Some("id"),
    })
}

fn no_move(id: MoveId) -> ApiError {
    ApiError::NotFound {
        message: format!("no move {id}"),
        field: Some("id"),
    }
}

/// Where an event stream is.
enum Feed {
    /// Nothing sent yet: the current report goes first.
    First(watch::Receiver<MoveReport>),
    /// Sent at least one report; the next goes when it changes.
    Next(watch::Receiver<MoveReport>),
    /// Sent a final report.
    Ended,
}

/// The next line of an event stream, or `None` when it ends (final stage sent, the move's feed
/// gone, or the daemon closing).
async fn next_line(feed: Feed, closing: &CancellationToken) -> Option<(Bytes, Feed)> {
    let mut rx = match feed {
        Feed::Ended => return None,
        Feed::First(rx) => rx,
        Feed::Next(mut rx) => {
            tokio::select! {
                changed = rx.changed() => changed.ok()?,
                () = closing.cancelled() => return None,
            }
            rx
        }
    };
    let report = rx.borrow_and_update().clone();
    let mut line = serde_json::to_vec(&report).unwrap_or_default();
    line.push(b'\n');
    let next = if report.stage.is_final() {
        Feed::Ended
    } else {
        Feed::Next(rx)
    };
    Some((Bytes::from(line), next))
}

/// A move order from a request body, or a 400 naming the field serde blames.
fn parse_order(body: &[u8]) -> Result<MoveOrder, ApiError> {
    parse_body(body)
}

/// A JSON body, an error naming the field that is wrong.
pub(super) fn parse_body<T: serde::de::DeserializeOwned>(body: &[u8]) -> Result<T, ApiError> {
    let mut de = serde_json::Deserializer::from_slice(body);
    let order = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        body_error(e.inner(), &path)
    })?;
    de.end().map_err(|e| body_error(&e, "."))?;
    Ok(order)
}

fn body_error(e: &serde_json::Error, path: &str) -> ApiError {
    if matches!(
        e.classify(),
        Category::Syntax | Category::Eof | Category::Io
    ) {
        return ApiError::BadRequest {
            message: format!("the body is not valid JSON: {e}"),
            field: None,
        };
    }
    let message = e.to_string();
    // The path names an unknown field itself, but stops above a missing one.
    let field = match path {
        "." => quoted_name(&message, "missing field `"),
        path => Some(path.to_owned()),
    };
    let message = match &field {
        Some(field) => format!("{field}: {message}"),
        None => format!("the body is not a move order: {message}"),
    };
    ApiError::BadRequest { message, field }
}

/// The name between `prefix` and the next backquote in `message`.
fn quoted_name(message: &str, prefix: &str) -> Option<String> {
    let rest = &message[message.find(prefix)? + prefix.len()..];
    Some(rest[..rest.find('`')?].to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_of(body: &str) -> Option<String> {
        match parse_order(body.as_bytes()).unwrap_err() {
            ApiError::BadRequest { field, .. } => field,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn body_errors_name_the_field_serde_blames() {
        assert_eq!(
            field_of(r#"{"to":[1,2,3],"colour":1}"#).as_deref(),
            Some("colour")
        );
        assert_eq!(field_of(r#"{"to":"here"}"#).as_deref(), Some("to"));
        assert_eq!(field_of(r#"{"to":[1,"x",3]}"#).as_deref(), Some("to[1]"));
        assert_eq!(field_of("not json"), None);
        assert_eq!(field_of(r#"{"to":[1,2,3]} x"#), None);
    }

    #[test]
    fn a_good_body_parses() {
        let order = parse_order(br#"{"to":[1,2,3],"speed_mm_s":100}"#).unwrap();
        assert_eq!(order.to, Some(vec![1.0, 2.0, 3.0]));
        let jog = parse_order(br#"{"by":[0,5,0]}"#).unwrap();
        assert_eq!(jog.by, Some(vec![0.0, 5.0, 0.0]));
        assert_eq!(
            field_of(r#"{"joints":[1,2,"x",4]}"#).as_deref(),
            Some("joints[2]")
        );
        assert_eq!(field_of(r#"{"position":7}"#).as_deref(), Some("position"));
    }
}
