//! The daemon's API as the CLI reaches it: HTTP/1.1 over the daemon's Unix socket (hyper's
//! client on one connection per request), JSON in and out, and the NDJSON progress feed.

mod access;
mod live;

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use http_body_util::{BodyExt, Full};
use hyper::body::{Bytes, Incoming};
use hyper::{Method, Request, StatusCode};
use hyper_util::rt::TokioIo;
use serde::Deserialize as _;
use serde::de::DeserializeOwned;
use serde_json::Value;
use tokio::net::UnixStream;

use crate::daemon::RobotState;
use crate::daemon::api::ErrorBody;

/// Where the daemon listens unless told otherwise.
pub const DEFAULT_SOCKET: &str = "/run/linterpd/api.sock";

pub use access::{NoPermission, NotRunning};
pub use live::{LiveFeed, LiveUpdate};

/// A client for the daemon at one socket.
#[derive(Debug, Clone)]
pub struct Client {
    socket: PathBuf,
}

/// An answer: the status and the JSON body.
#[derive(Debug)]
pub struct Answer {
    /// HTTP status.
    pub status: StatusCode,
    /// JSON body (`Null` when empty).
    pub body: Value,
}

impl Answer {
    /// The API's error text for an error answer: the field to blame first when the message does
    /// not name it, the `reason` word last when there is one.
    #[must_use]
    pub fn error(&self) -> String {
        let Some(body) = self.error_body() else {
            return "no error text".to_owned();
        };
        let msg = body.error;
        let text = match body.field {
            Some(field) if !msg.contains(&field) => format!("{field}: {msg}"),
            _ => msg,
        };
        match body.reason {
            Some(reason) => format!("{text} (reason: {reason})"),
            None => text,
        }
    }

    /// The API's word for programs (`not-homed`, `link-down`, ...), when it gave one.
    #[must_use]
    pub fn reason(&self) -> Option<String> {
        self.error_body()?.reason
    }

    /// The body of an error answer, when it is one.
    fn error_body(&self) -> Option<ErrorBody> {
        ErrorBody::deserialize(&self.body).ok()
    }
}

/// A body the daemon answered, read into the API's type `T`, with its JSON as the daemon wrote
/// it (what `--json` prints, as is).
#[derive(Debug, Clone)]
pub struct Received<T> {
    /// The body, typed.
    pub value: T,
    /// The body as written.
    pub json: Value,
}

impl<T: DeserializeOwned> Received<T> {
    /// Reads `json` as a `T`; `what` names it when it is not one.
    pub fn read(json: Value, what: &str) -> anyhow::Result<Self> {
        let value =
            T::deserialize(&json).with_context(|| format!("the daemon's answer is not {what}"))?;
        Ok(Self { value, json })
    }
}

type Sender = hyper::client::conn::http1::SendRequest<Full<Bytes>>;

impl Client {
    /// A client for the daemon at `socket`.
    #[must_use]
    pub fn new(socket: &Path) -> Self {
        Self {
            socket: socket.to_owned(),
        }
    }

    async fn connect(&self) -> anyhow::Result<Sender> {
        let stream = UnixStream::connect(&self.socket)
            .await
            .map_err(|source| access::connect_error(&self.socket, source))?;
        let (sender, connection) = hyper::client::conn::http1::handshake(TokioIo::new(stream))
            .await
            .context("HTTP handshake with the daemon")?;
        tokio::spawn(connection);
        Ok(sender)
    }

    fn request(
        method: Method,
        path: &str,
        body: Option<&Value>,
    ) -> anyhow::Result<Request<Full<Bytes>>> {
        let bytes = body.map_or_else(Bytes::new, |b| Bytes::from(b.to_string()));
        Ok(Request::builder()
            .method(method)
            .uri(path)
            .header("host", "localhost")
            .header("content-type", "application/json")
            // The daemon's journal tells the CLI's commands from other API clients' by it.
            .header(
                "user-agent",
                concat!("linterpd/", env!("CARGO_PKG_VERSION")),
            )
            .body(Full::new(bytes))?)
    }

    /// Sends a request and reads the whole JSON answer.
    pub async fn call(
        &self,
        method: Method,
        path: &str,
        body: Option<&Value>,
    ) -> anyhow::Result<Answer> {
        let mut sender = self.connect().await?;
        let response = sender
            .send_request(Self::request(method, path, body)?)
            .await
            .context("request to the daemon")?;
        let status = response.status();
        let bytes = response
            .into_body()
            .collect()
            .await
            .context("reading the daemon's answer")?
            .to_bytes();
        let body = if bytes.is_empty() {
            Value::Null
        } else {
            serde_json::from_slice(&bytes)
                .map_err(|e| anyhow!("the daemon answered {status} with no JSON: {e}"))?
        };
        Ok(Answer { status, body })
    }

    /// Opens an NDJSON feed: an error answer is returned as it is, a success as a [`Feed`].
    pub async fn feed(&self, path: &str) -> anyhow::Result<Result<Feed, Answer>> {
        let mut sender = self.connect().await?;
        let response = sender
            .send_request(Self::request(Method::GET, path, None)?)
            .await
            .context("request to the daemon")?;
        let status = response.status();
        if !status.is_success() {
            let bytes = response.into_body().collect().await?.to_bytes();
            let body = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
            return Ok(Err(Answer { status, body }));
        }
        Ok(Ok(Feed {
            body: response.into_body(),
            pending: Vec::new(),
        }))
    }
}

/// An NDJSON feed being read: one JSON value per line.
#[derive(Debug)]
pub struct Feed {
    body: Incoming,
    pending: Vec<u8>,
}

impl Feed {
    /// The next JSON line, or `None` once the feed has ended. Cancel-safe: what was read before
    /// a cancelled call is kept for the next.
    pub async fn next(&mut self) -> anyhow::Result<Option<Value>> {
        loop {
            while let Some(end) = self.pending.iter().position(|b| *b == b'\n') {
                let line: Vec<u8> = self.pending.drain(..=end).collect();
                if line.iter().all(u8::is_ascii_whitespace) {
                    continue;
                }
                let value =
                    serde_json::from_slice(&line).context("a progress line that is not JSON")?;
                return Ok(Some(value));
            }
            let Some(frame) = self.body.frame().await else {
                return Ok(None);
            };
            let frame = frame.context("reading the progress feed")?;
            if let Some(data) = frame.data_ref() {
                self.pending.extend_from_slice(data);
            }
        }
    }
}

impl Client {
    /// The robot to act on: `name` if given, else the daemon's only robot.
    pub async fn robot(&self, name: Option<&str>) -> anyhow::Result<String> {
        if let Some(n) = name {
            return Ok(n.to_owned());
        }
        let answer = self.call(Method::GET, "/v1/robots", None).await?;
        let robots: Vec<RobotState> = match answer.body {
            list @ Value::Array(_) => Received::read(list, "a list of robots")?.value,
            _ => Vec::new(),
        };
        let names: Vec<String> = robots.into_iter().map(|r| r.name).collect();
        match names.as_slice() {
            [one] => Ok(one.clone()),
            [] => Err(anyhow!("the daemon has no robots")),
            many => Err(anyhow!(
                "the daemon runs several robots ({}); name one with --robot",
                many.join(", ")
            )),
        }
    }
}
