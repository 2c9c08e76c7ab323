//! The console's WebSocket, one per page: the live stream of every robot out (a `hello`, then
//! each robot's whole snapshot, then its merge patches), the page's jog and seat requests in.
//!
//! ```text
//! out: {"type":"hello","user":"ann","role":"operator"}
//!      {"type":"full",...} {"type":"patch",...}                 (wire::LiveMessage)
//!      {"type":"error","robot":"r","error":"...","for":"jog"}   a request refused
//! in:  {"type":"jog","robot":"r","axis":"x","positive":true,"seq":1}   button down
//!      {"type":"keep","robot":"r","seq":2}                       at most every 100 ms while held
//!      {"type":"release","robot":"r"}                            pointerup, pointercancel, ...
//!      {"type":"hidden"}                                         blur, visibilitychange, pagehide
//!      {"type":"take-seat","robot":"r"}  {"type":"leave-seat","robot":"r"}
//! ```
//! The upgrade is refused (403) without a session or from another `Origin` (browsers do not
//! apply same-origin rules to a `WebSocket`). When the socket closes, for any reason, every
//! robot's jog of this session stops. A page that falls [`super::CAPACITY`] messages behind is
//! closed (code 1008, "too slow"): it reconnects from a whole snapshot.

use std::sync::Arc;

use axum::extract::State;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::http::{HeaderMap, StatusCode};
use axum::response::Response;
use serde::Deserialize;
use serde_json::json;
use tokio::sync::{broadcast, mpsc, oneshot};

use super::ConsoleState;
use super::control::{Control, Request, Who};
use super::server::{origin_allowed, refuse, session_of};
use crate::console::{Event, JogAxis};
use crate::daemon::stream::RobotStream;

/// What a page sends.
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum Incoming {
    Jog {
        robot: String,
        axis: JogAxis,
        positive: bool,
        seq: u64,
    },
    Keep {
        robot: String,
        seq: u64,
    },
    Release {
        robot: String,
    },
    Hidden,
    TakeSeat {
        robot: String,
    },
    LeaveSeat {
        robot: String,
    },
}

pub(super) async fn upgrade(
    State(state): State<Arc<ConsoleState>>,
    headers: HeaderMap,
    upgrade: WebSocketUpgrade,
) -> Response {
    if let Err(e) = origin_allowed(&headers, &state.origins) {
        tracing::warn!(error = %e, "console WebSocket refused");
        return refuse(StatusCode::FORBIDDEN, &e.to_string(), "origin");
    }
    let Some((_, session)) = session_of(&state, &headers) else {
        return refuse(StatusCode::UNAUTHORIZED, "log in first", "login");
    };
    let who = Who {
        session: session.id,
        user: session.user,
        role: session.role,
    };
    upgrade
        .max_message_size(64 * 1024)
        .on_upgrade(move |socket| run(socket, state, who))
}

/// Messages out waiting for the socket, at most.
const OUTBOX: usize = super::CAPACITY;

/// Sends `stream`'s frames to the page's `out`, from the first; a page too slow to keep up is
/// told why on `lagged`, and forwarding ends.
async fn forward(stream: RobotStream, out: mpsc::Sender<String>, lagged: mpsc::Sender<String>) {
    let mut sub = stream.subscribe();
    if out.send(sub.first).await.is_err() {
        return;
    }
    loop {
        match sub.rest.recv().await {
            Ok(frame) if frame.seq <= sub.seq => {}
            Ok(frame) => {
                if out.send(frame.text.clone()).await.is_err() {
                    return;
                }
            }
            Err(broadcast::error::RecvError::Lagged(n)) => {
                let why = format!("too slow: {n} messages of {} missed", stream.name());
                let _ = lagged.send(why).await;
                return;
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
    }
}

/// A task per robot that forwards its live stream to the page's `out`box (`lagged` when the
/// page falls behind).
fn forward_all(
    state: &ConsoleState,
    out: &mpsc::Sender<String>,
    lagged: &mpsc::Sender<String>,
) -> Vec<tokio::task::JoinHandle<()>> {
    state
        .hub
        .robots()
        .values()
        .map(|stream| tokio::spawn(forward(stream.clone(), out.clone(), lagged.clone())))
        .collect()
}

async fn run(mut socket: WebSocket, state: Arc<ConsoleState>, who: Who) {
    let (out, mut outbox) = mpsc::channel::<String>(OUTBOX);
    let (lagged_tx, mut lagged) = mpsc::channel::<String>(1);
    let hello = json!({"type": "hello", "user": who.user, "role": who.role.name()});
    let _ = out.try_send(hello.to_string());
    let forwarders = forward_all(&state, &out, &lagged_tx);
    let closing = state.closing.clone();
    loop {
        tokio::select! {
            () = closing.cancelled() => break,
            why = lagged.recv() => {
                let reason = why.unwrap_or_default();
                tracing::info!(user = %who.user, %reason, "console WebSocket closed");
                let _ = socket
                    .send(Message::Close(Some(CloseFrame { code: 1008, reason: reason.into() })))
                    .await;
                break;
            }
            text = outbox.recv() => {
                let Some(text) = text else { break };
                if socket.send(Message::Text(text.into())).await.is_err() {
                    break;
                }
            }
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(text))) => {
                    if let Some(error) = take(&state, &who, text.as_str()).await {
                        let _ = out.try_send(error.to_string());
                    }
                }
                Some(Ok(Message::Close(_)) | Err(_)) | None => break,
                Some(Ok(_)) => {}
            },
        }
    }
    for f in forwarders {
        f.abort();
    }
    closed(&state, &who).await;
}

/// Tells every robot's control task that `who`'s page closed: its lease ends.
async fn closed(state: &ConsoleState, who: &Who) {
    for control in state.controls.values() {
        control
            .send(Request::Lease(Event::Closed {
                session: who.session,
            }))
            .await;
    }
}

/// Sends `request` to `robot`'s control task: the refusal `answer` brings, as the page's error
/// `for` the message it answers (`None`: none came).
async fn asked<E: std::fmt::Display>(
    control: &Control,
    request: Request,
    answer: oneshot::Receiver<Result<(), E>>,
    robot: &str,
    for_: &str,
) -> Option<serde_json::Value> {
    if !control.send(request).await {
        return None;
    }
    match answer.await {
        Ok(Err(e)) => {
            Some(json!({"type": "error", "robot": robot, "for": for_, "error": e.to_string()}))
        }
        _ => None,
    }
}

/// Robot `robot`'s control task, or the page's error naming the robots there are.
fn control_of<'s>(state: &'s ConsoleState, robot: &str) -> Result<&'s Control, serde_json::Value> {
    state.controls.get(robot).ok_or_else(|| {
        let known: Vec<&str> = state.controls.keys().map(String::as_str).collect();
        json!({"type": "error", "robot": robot,
               "error": format!("no robot {robot:?}; robots: {}", known.join(", "))})
    })
}

/// The page's error for a message that is not one the console takes.
fn unreadable(e: &serde_json::Error) -> serde_json::Value {
    json!({"type": "error", "error": format!("a console message: {e}")})
}

/// Takes one message from the page; an error to send back, if any.
async fn take(state: &ConsoleState, who: &Who, text: &str) -> Option<serde_json::Value> {
    let incoming: Incoming = match serde_json::from_str(text) {
        Ok(m) => m,
        Err(e) => return Some(unreadable(&e)),
    };
    let session = who.session;
    match incoming {
        Incoming::Jog {
            robot,
            axis,
            positive,
            seq,
        } => {
            let jog = (axis, positive, seq);
            let request = |reply| Request::jog(who.clone(), jog, reply);
            ask(state, &robot, "jog", request).await
        }
        Incoming::TakeSeat { robot } => {
            let who = who.clone();
            let request = |reply| Request::TakeSeat { who, reply };
            ask(state, &robot, "take-seat", request).await
        }
        Incoming::Keep { robot, seq } => {
            let keep = Event::KeepAlive { session, seq };
            told(state, &robot, Request::Lease(keep)).await
        }
        Incoming::Release { robot } => {
            let release = Event::Release { session };
            told(state, &robot, Request::Lease(release)).await
        }
        Incoming::Hidden => {
            for c in state.controls.values() {
                c.send(Request::Lease(Event::Hidden { session })).await;
            }
            None
        }
        Incoming::LeaveSeat { robot } => told(state, &robot, Request::LeaveSeat { session }).await,
    }
}

/// Asks robot `robot`'s control task the request `request` makes of its reply: the page's
/// error when there is no such robot or the task refuses, naming what it was `for_`.
async fn ask<E: std::fmt::Display>(
    state: &ConsoleState,
    robot: &str,
    for_: &str,
    request: impl FnOnce(oneshot::Sender<Result<(), E>>) -> Request,
) -> Option<serde_json::Value> {
    let c = match control_of(state, robot) {
        Ok(c) => c,
        Err(e) => return Some(e),
    };
    let (reply, answer) = oneshot::channel();
    asked(c, request(reply), answer, robot, for_).await
}

/// Sends robot `robot`'s control task `request`, which has no answer (none to a robot there
/// is not either).
async fn told(state: &ConsoleState, robot: &str, request: Request) -> Option<serde_json::Value> {
    if let Ok(c) = control_of(state, robot) {
        c.send(request).await;
    }
    None
}
