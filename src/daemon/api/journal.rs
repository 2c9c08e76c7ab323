//! The journal at the API: every command (a request that is not a `GET`) journaled with its
//! answer's status and who sent it ([`Caller`]: the Unix socket's peer uid, a TCP client's
//! address, the console's user; `linterpd`'s own client tells itself apart by its
//! `User-Agent`), and `GET /v1/journal`, the entries by number, time and robot.
//!
//! ```text
//! GET /v1/journal?since=10m|RFC3339&after=SEQ&robot=NAME&limit=N&newest=true
//!     {"entries": [Entry], "last_seq": N}                  | 400 | 404 (no journal kept)
//! ```

use std::net::{IpAddr, SocketAddr};

use axum::Json;
use axum::body::Body;
use axum::extract::{Query, Request, State};
use axum::http::{Method, header};
use axum::middleware::Next;
use axum::response::Response;
use serde::{Deserialize, Serialize};

use super::{Api, ApiError};
use crate::journal::{Journal, Query as JournalQuery};
use crate::wire::journal::{Entry, Kind, Source, parse_rfc3339, parse_span_ms};

/// Who is at the other end of a request, put on it by the listener (or the console's guard).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Caller {
    /// A process on the Unix socket, by its user id (`SO_PEERCRED`) when the system tells it.
    Unix {
        /// Its user id.
        uid: Option<u32>,
    },
    /// A TCP client.
    Tcp(SocketAddr),
    /// A user logged in to the operator's console.
    Console {
        /// The user.
        user: String,
        /// From where.
        ip: IpAddr,
    },
}

/// The most entries one answer holds.
pub const MAX_ENTRIES: usize = 10_000;
/// Request bodies up to this size are journaled with the command (a move's target, a cycle's
/// program); larger ones (a path) are named by their size only.
const BODY_KEPT: usize = 512;
/// What `linterpd`'s own client sends as its `User-Agent` (followed by its version).
pub const CLI_AGENT: &str = "linterpd/";

/// Journals every command that passes, with its status and who sent it.
pub(super) async fn commands(State(api): State<Api>, request: Request, next: Next) -> Response {
    let journal = match &api.journal {
        Some(j) if !matches!(*request.method(), Method::GET | Method::HEAD) => j.clone(),
        _ => return next.run(request).await,
    };
    let (source, who) = who(&request);
    let (robot, mut action) = action(request.method(), request.uri().path());
    let (request, body) = small_body(request).await;
    if let Some(body) = body {
        action.push(' ');
        action.push_str(&body);
    }
    let response = next.run(request).await;
    let status = response.status().as_u16();
    let (response, refused) = refusal(response).await;
    journal.record(
        robot.as_deref(),
        Kind::Command {
            source,
            who,
            action,
            status: Some(status),
            refused,
        },
    );
    response
}

/// Through what, and who.
fn who(request: &Request) -> (Source, Option<String>) {
    let cli = request
        .headers()
        .get(header::USER_AGENT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|a| a.starts_with(CLI_AGENT));
    match request.extensions().get::<Caller>() {
        Some(Caller::Console { user, ip }) => (Source::Console, Some(format!("{user} from {ip}"))),
        Some(Caller::Unix { uid }) => (
            if cli { Source::Cli } else { Source::Api },
            uid.map(|u| format!("uid {u}")),
        ),
        Some(Caller::Tcp(address)) => (
            if cli { Source::Cli } else { Source::Api },
            Some(address.to_string()),
        ),
        None => (if cli { Source::Cli } else { Source::Api }, None),
    }
}

/// The robot a path is about, and the action (`POST cycles/pause`, `PUT mode`).
fn action(method: &Method, path: &str) -> (Option<String>, String) {
    let parts: Vec<&str> = path.trim_matches('/').split('/').collect();
    match parts.as_slice() {
        ["v1", "robots", name, rest @ ..] if !rest.is_empty() => (
            Some((*name).to_owned()),
            format!("{method} {}", rest.join("/")),
        ),
        _ => (None, format!("{method} {path}")),
    }
}

/// The request's body when it is small JSON (read and put back), for the journal.
async fn small_body(request: Request) -> (Request, Option<String>) {
    let length = request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<usize>().ok());
    match length {
        Some(0) | None => (request, None),
        Some(n) if n > BODY_KEPT => (request, Some(format!("({n} bytes)"))),
        Some(_) => {
            let (parts, body) = request.into_parts();
            let bytes = axum::body::to_bytes(body, BODY_KEPT)
                .await
                .unwrap_or_default();
            let text = serde_json::from_slice::<serde_json::Value>(&bytes).map_or_else(
                |_| String::from_utf8_lossy(&bytes).into_owned(),
                |v| v.to_string(),
            );
            (Request::from_parts(parts, Body::from(bytes)), Some(text))
        }
    }
}

/// An error answer's `reason` (else its `error`), read and put back.
async fn refusal(response: Response) -> (Response, Option<String>) {
    if !response.status().is_client_error() && !response.status().is_server_error() {
        return (response, None);
    }
    let (parts, body) = response.into_parts();
    let bytes = axum::body::to_bytes(body, 64 * 1024)
        .await
        .unwrap_or_default();
    let why = serde_json::from_slice::<super::ErrorBody>(&bytes)
        .ok()
        .map(|e| e.reason.unwrap_or(e.error));
    (Response::from_parts(parts, Body::from(bytes)), why)
}

/// `GET /v1/journal`'s query.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct JournalParams {
    since: Option<String>,
    after: Option<u64>,
    robot: Option<String>,
    limit: Option<usize>,
    #[serde(default)]
    newest: bool,
}

/// `GET /v1/journal`'s answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JournalPage {
    /// The entries, oldest first.
    pub entries: Vec<Entry>,
    /// The last entry's number (the cursor for `after`), or `after` as asked when none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_seq: Option<u64>,
}

/// `GET /v1/journal`.
pub(super) async fn read(
    State(api): State<Api>,
    Query(params): Query<JournalParams>,
) -> Result<Json<JournalPage>, ApiError> {
    let journal: Journal = api.journal.clone().ok_or_else(|| ApiError::NotFound {
        message: "this daemon keeps no journal".into(),
        field: None,
    })?;
    let query = JournalQuery {
        after: params.after,
        since_ms: params.since.as_deref().map(since_ms).transpose()?,
        robot: params.robot,
        limit: params.limit.unwrap_or(1000).clamp(1, MAX_ENTRIES),
        newest: params.newest,
    };
    let entries = tokio::task::spawn_blocking(move || journal.read(&query))
        .await
        .map_err(|_| ApiError::ShuttingDown)?
        .map_err(|e| ApiError::Other {
            status: axum::http::StatusCode::INTERNAL_SERVER_ERROR,
            message: format!(
                "{e}: {}",
                std::error::Error::source(&e).map_or_else(String::new, ToString::to_string)
            ),
        })?;
    let last_seq = entries.last().map(|e| e.seq).or(params.after);
    Ok(Json(JournalPage { entries, last_seq }))
}

/// `since` as ms since the epoch: an RFC 3339 time, or a span back from now (`10m`).
fn since_ms(text: &str) -> Result<u64, ApiError> {
    if let Ok(span) = parse_span_ms(text) {
        return Ok(crate::journal::now_ms().saturating_sub(span));
    }
    parse_rfc3339(text).map_err(|e| ApiError::BadRequest {
        message: format!("since: {e}, or a span back from now (10m, 8h)"),
        field: Some("since".into()),
    })
}

/// The journal's lines for `/metrics` (`OpenMetrics`), put before its `# EOF`.
#[must_use]
pub fn metrics_text(journal: &Journal, text: String) -> String {
    let c = journal.counts();
    let ours = format!(
        "# HELP linterpd_journal_entries Journal entries written.\n\
         # TYPE linterpd_journal_entries counter\n\
         linterpd_journal_entries_total {}\n\
         # HELP linterpd_journal_dropped Journal entries dropped: its queue was full.\n\
         # TYPE linterpd_journal_dropped counter\n\
         linterpd_journal_dropped_total {}\n\
         # HELP linterpd_journal_failed Journal writes or fsyncs that failed.\n\
         # TYPE linterpd_journal_failed counter\n\
         linterpd_journal_failed_total {}\n",
        c.written, c.dropped, c.failed
    );
    match text.rfind("# EOF") {
        Some(at) => format!("{}{ours}{}", &text[..at], &text[at..]),
        None => text + &ours,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_path_is_split_into_the_robot_and_its_action() {
        assert_eq!(
            action(&Method::POST, "/v1/robots/press-loader/cycles/pause"),
            (Some("press-loader".into()), "POST cycles/pause".into())
        );
        assert_eq!(
            action(&Method::PUT, "/v1/robots/a/mode"),
            (Some("a".into()), "PUT mode".into())
        );
        assert_eq!(
            action(&Method::POST, "/v1/other"),
            (None, "POST /v1/other".into())
        );
    }

    #[test]
    fn the_journal_s_counters_go_before_the_end_of_the_metrics() {
        let text = metrics_text(&Journal::off(), "a 1\n# EOF\n".into());
        assert!(
            text.starts_with("a 1\n# HELP linterpd_journal_entries"),
            "{text}"
        );
        assert!(
            text.contains("linterpd_journal_dropped_total 0\n"),
            "{text}"
        );
        assert!(text.ends_with("# EOF\n"), "{text}");
    }
}
