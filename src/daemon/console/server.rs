//! The console's routes: the page and its assets, login and logout, the robots' descriptions,
//! the WebSocket (the live stream in, jog and seat requests out), and the whole HTTP/JSON API
//! behind a guard: a session cookie, `Origin` on every request that changes anything, and the
//! seat and roles (`console::seat`) on every command.
//!
//! ```text
//! GET  /                         the page                      (no session needed)
//! GET  /assets/{*file}           its scripts, styles, licences (no session needed)
//! POST /console/login            {"user","password"} -> cookie  (Origin; rate-limited)
//! POST /console/logout           the cookie ends                (Origin)
//! GET  /console/session          {"user","role"}                | 401
//! GET  /console/robots           [{name, kinematics, joints, signals, manual speed, lease}]
//! GET  /console/ws               WebSocket                      (Origin; session)
//! *    /v1/...                   the API (docs/API.md)          (session; Origin unless GET;
//!                                                                the seat and the role)
//! ```

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

use axum::Json;
use axum::extract::{Extension, Path, Request, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use serde_json::json;

use super::assets;
use super::session::{COOKIE, LoginError, Session, cookie_value};
use super::{ConsoleState, Peer};
use crate::console::Command;

/// An error as the console answers it: the API's JSON shape, with a `reason` word.
pub(super) fn refuse(status: StatusCode, error: &str, reason: &str) -> Response {
    (status, Json(json!({"error": error, "reason": reason}))).into_response()
}

pub(super) async fn index() -> Response {
    serve_asset(&assets::INDEX)
}

pub(super) async fn asset(Path(file): Path<String>) -> Response {
    match assets::find(&file) {
        Some(a) => serve_asset(a),
        None => refuse(
            StatusCode::NOT_FOUND,
            &format!("no asset {file:?}"),
            "not-found",
        ),
    }
}

fn serve_asset(a: &assets::Asset) -> Response {
    (
        [
            (header::CONTENT_TYPE, a.content_type),
            (header::CACHE_CONTROL, "no-cache"),
            (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        ],
        a.bytes,
    )
        .into_response()
}

/// Why a request that changes something was refused for its `Origin`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(super) enum OriginRefused {
    /// It has none.
    #[error("no Origin header: the console takes changes from its own page only")]
    Missing,
    /// Another site's.
    #[error("Origin {origin} is not this console's ({own}) nor in console.origins")]
    Foreign {
        /// The request's.
        origin: String,
        /// The console's own (`http://` and the `Host`).
        own: String,
    },
}

/// Whether `origin` is the page's own (`Host`) or one the config allows.
pub(super) fn origin_allowed(headers: &HeaderMap, extra: &[String]) -> Result<(), OriginRefused> {
    let origin = headers
        .get(header::ORIGIN)
        .and_then(|v| v.to_str().ok())
        .ok_or(OriginRefused::Missing)?;
    let host = headers
        .get(header::HOST)
        .and_then(|v| v.to_str().ok())
        .unwrap_or_default();
    let own = [format!("http://{host}"), format!("https://{host}")];
    if own.iter().any(|o| o == origin) || extra.iter().any(|o| o == origin) {
        Ok(())
    } else {
        let [own, _] = own;
        Err(OriginRefused::Foreign {
            origin: origin.to_owned(),
            own,
        })
    }
}

/// The session of the request's cookie.
pub(super) fn session_of(state: &ConsoleState, headers: &HeaderMap) -> Option<(String, Session)> {
    let cookies = headers.get(header::COOKIE)?.to_str().ok()?;
    let value = cookie_value(cookies, COOKIE)?;
    Some((value.to_owned(), state.sessions.get(value)?))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Login {
    user: String,
    password: String,
}

impl Login {
    /// The login `body` carries, or the answer refusing it (not a login, or too long).
    fn read(body: &[u8]) -> Result<Self, Box<Response>> {
        let login: Self = serde_json::from_slice(body).map_err(|e| {
            Box::new(refuse(
                StatusCode::BAD_REQUEST,
                &format!("a login is {{\"user\": \"...\", \"password\": \"...\"}}: {e}"),
                "bad-request",
            ))
        })?;
        if login.user.len() > 64 || login.password.len() > 1024 {
            return Err(Box::new(refuse(
                StatusCode::BAD_REQUEST,
                "user is at most 64 bytes and password at most 1024 bytes",
                "bad-request",
            )));
        }
        Ok(login)
    }
}

/// The answer to a login taken: who and their role, the session's cookie set.
fn logged_in(state: &ConsoleState, cookie: &str, session: &Session) -> Response {
    let max_age = state.sessions.lasts().as_secs();
    let set = format!("{COOKIE}={cookie}; HttpOnly; SameSite=Strict; Path=/; Max-Age={max_age}");
    let mut response =
        Json(json!({"user": session.user, "role": session.role.name()})).into_response();
    if let Ok(v) = HeaderValue::from_str(&set) {
        response.headers_mut().insert(header::SET_COOKIE, v);
    }
    response
}

pub(super) async fn login(
    State(state): State<Arc<ConsoleState>>,
    Extension(Peer(peer)): Extension<Peer>,
    headers: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    if let Err(e) = origin_allowed(&headers, &state.origins) {
        return refuse(StatusCode::FORBIDDEN, &e.to_string(), "origin");
    }
    let login = match Login::read(&body) {
        Ok(l) => l,
        Err(refused) => return *refused,
    };
    match state
        .sessions
        .login(client_ip(peer), &login.user, &login.password)
        .await
    {
        Ok((cookie, session)) => logged_in(&state, &cookie, &session),
        Err(e @ LoginError::Limited(_)) => refuse(
            StatusCode::TOO_MANY_REQUESTS,
            &e.to_string(),
            "rate-limited",
        ),
        Err(e @ LoginError::Wrong) => refuse(StatusCode::UNAUTHORIZED, &e.to_string(), "login"),
    }
}

pub(super) async fn logout(State(state): State<Arc<ConsoleState>>, headers: HeaderMap) -> Response {
    if let Err(e) = origin_allowed(&headers, &state.origins) {
        return refuse(StatusCode::FORBIDDEN, &e.to_string(), "origin");
    }
    if let Some((cookie, session)) = session_of(&state, &headers) {
        state.sessions.logout(&cookie);
        for control in state.controls.values() {
            control
                .send(super::control::Request::LeaveSeat {
                    session: session.id,
                })
                .await;
        }
    }
    let mut response = Json(json!({"logged_out": true})).into_response();
    response.headers_mut().insert(
        header::SET_COOKIE,
        HeaderValue::from_static("linterpd_session=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0"),
    );
    response
}

pub(super) async fn session(
    State(state): State<Arc<ConsoleState>>,
    headers: HeaderMap,
) -> Response {
    match session_of(&state, &headers) {
        Some((_, s)) => Json(json!({"user": s.user, "role": s.role.name()})).into_response(),
        None => refuse(StatusCode::UNAUTHORIZED, "log in first", "login"),
    }
}

pub(super) async fn robots(State(state): State<Arc<ConsoleState>>, headers: HeaderMap) -> Response {
    if session_of(&state, &headers).is_none() {
        return refuse(StatusCode::UNAUTHORIZED, "log in first", "login");
    }
    Json(state.infos.clone()).into_response()
}

/// A robot's cycle programs, each with its check now: `[{"name", "ok", "error"?}]`.
pub(super) async fn programs(
    State(state): State<Arc<ConsoleState>>,
    Path(name): Path<String>,
    headers: HeaderMap,
) -> Response {
    if session_of(&state, &headers).is_none() {
        return refuse(StatusCode::UNAUTHORIZED, "log in first", "login");
    }
    let (Some(handle), Some(dir)) = (state.handles.get(&name), state.programs.get(&name)) else {
        return refuse(
            StatusCode::NOT_FOUND,
            &format!("no robot {name:?}"),
            "not-found",
        );
    };
    let Some(dir) = dir else {
        return Json(json!([])).into_response();
    };
    let loaded = match crate::cycle::load::programs(dir) {
        Ok(p) => p,
        Err(e) => {
            return refuse(
                StatusCode::INTERNAL_SERVER_ERROR,
                &e.to_string(),
                "programs",
            );
        }
    };
    let mut list = Vec::new();
    for program in loaded.docs.keys() {
        let checked = handle.check_program(program);
        list.push(json!({"name": program, "ok": checked.is_ok(),
                         "error": checked.err().map(|e| e.to_string())}));
    }
    for (program, why) in &loaded.broken {
        list.push(json!({"name": program, "ok": false, "error": why}));
    }
    Json(list).into_response()
}

/// The guard in front of the API: a session, `Origin` for what changes anything, and the seat
/// and the role for what the request does.
pub(super) async fn guard(
    State(state): State<Arc<ConsoleState>>,
    mut request: Request,
    next: Next,
) -> Response {
    let Some((_, session)) = session_of(&state, request.headers()) else {
        return refuse(StatusCode::UNAUTHORIZED, "log in first", "login");
    };
    // The journal names the console's user as who sent a command.
    if let Some(Peer(peer)) = request.extensions().get::<Peer>().copied() {
        request
            .extensions_mut()
            .insert(crate::daemon::api::Caller::Console {
                user: session.user.clone(),
                ip: client_ip(peer),
            });
    }
    let method = request.method().clone();
    let changes = !matches!(method, Method::GET | Method::HEAD);
    if changes && let Err(e) = origin_allowed(request.headers(), &state.origins) {
        return refuse(StatusCode::FORBIDDEN, &e.to_string(), "origin");
    }
    let path = request.uri().path().to_owned();
    let (robot, command) = classify(&method, &path);
    if let (Some(robot), Some(command)) = (robot, command)
        && let Some(control) = state.controls.get(robot)
    {
        let who = super::control::Who {
            session: session.id,
            user: session.user.clone(),
            role: session.role,
        };
        if let Err(e) = control.check(who, command).await {
            let reason = match e {
                crate::console::Refusal::Role { .. } => "role",
                crate::console::Refusal::NoSeat { .. } => "seat",
                crate::console::Refusal::Remote { .. } => "mode-remote",
            };
            return refuse(StatusCode::FORBIDDEN, &e.to_string(), reason);
        }
        if command != Command::View {
            tracing::info!(user = %session.user, robot, %method, path, "console command");
        }
    }
    next.run(request).await
}

/// The robot an API request is about and what it does, as the seat rules tell them apart.
fn classify<'p>(method: &Method, path: &'p str) -> (Option<&'p str>, Option<Command>) {
    let parts: Vec<&str> = path.trim_matches('/').split('/').collect();
    let robot = match parts.as_slice() {
        ["v1", "robots", name, ..] => Some(*name),
        _ => None,
    };
    let tail = parts.get(3..).unwrap_or_default();
    let command = match (method, tail) {
        (&Method::GET | &Method::HEAD, _) => Command::View,
        (&Method::POST, ["stop"] | ["cycles", "stop"]) => Command::Stop,
        (&Method::DELETE, ["positions", _]) => Command::Delete,
        (&Method::PUT, ["mode"]) => Command::Mode,
        _ => Command::Operate,
    };
    (robot, Some(command))
}

/// The client's address, for the limiter and the log.
pub(super) fn client_ip(peer: SocketAddr) -> IpAddr {
    peer.ip().to_canonical()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn api_requests_are_told_apart_for_the_seat() {
        fn c<'p>(m: &Method, p: &'p str) -> (Option<&'p str>, Option<Command>) {
            classify(m, p)
        }
        assert_eq!(
            c(&Method::GET, "/v1/robots/r/positions"),
            (Some("r"), Some(Command::View))
        );
        assert_eq!(
            c(&Method::POST, "/v1/robots/r/stop"),
            (Some("r"), Some(Command::Stop))
        );
        assert_eq!(
            c(&Method::POST, "/v1/robots/r/cycles/stop"),
            (Some("r"), Some(Command::Stop))
        );
        assert_eq!(
            c(&Method::POST, "/v1/robots/r/moves"),
            (Some("r"), Some(Command::Operate))
        );
        assert_eq!(
            c(&Method::DELETE, "/v1/robots/r/positions/pick"),
            (Some("r"), Some(Command::Delete))
        );
        assert_eq!(
            c(&Method::PUT, "/v1/robots/r/mode"),
            (Some("r"), Some(Command::Mode))
        );
        assert_eq!(
            c(&Method::PUT, "/v1/robots/r/speed-override"),
            (Some("r"), Some(Command::Operate))
        );
        assert_eq!(c(&Method::GET, "/v1/robots").0, None);
    }

    #[test]
    fn only_the_pages_own_origin_or_a_listed_one_passes() {
        let mut h = HeaderMap::new();
        h.insert(header::HOST, HeaderValue::from_static("10.0.0.2:8470"));
        assert!(
            origin_allowed(&h, &[])
                .unwrap_err()
                .to_string()
                .contains("no Origin")
        );
        h.insert(
            header::ORIGIN,
            HeaderValue::from_static("http://10.0.0.2:8470"),
        );
        assert!(origin_allowed(&h, &[]).is_ok());
        h.insert(
            header::ORIGIN,
            HeaderValue::from_static("http://evil.example"),
        );
        let e = origin_allowed(&h, &[]).unwrap_err().to_string();
        assert!(e.contains("Origin http://evil.example is not"), "{e}");
        assert!(origin_allowed(&h, &["http://evil.example".to_owned()]).is_ok());
    }
}
