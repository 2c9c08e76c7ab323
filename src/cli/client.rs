//! The daemon's API as the CLI reaches it: HTTP/1.1 over the daemon's Unix socket (hyper's
//! client on one connection per request), JSON in and out, and the NDJSON progress feed.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use http_body_util::{BodyExt, Full};
use hyper::body::Bytes;
use hyper::{Method, Request, StatusCode};
use hyper_util::rt::TokioIo;
use serde_json::Value;
use tokio::net::UnixStream;

/// Where the daemon listens unless told otherwise.
pub const DEFAULT_SOCKET: &str = "/run/linterpd/api.sock";

/// The daemon could not be reached at all.
#[derive(Debug, thiserror::Error)]
#[error(
    "the linterpd daemon is not running (nothing answers at {socket}): start it with \
     `systemctl start linterpd`, or give its socket with --socket or LINTERPD_SOCKET"
)]
pub struct NotRunning {
    /// The socket tried.
    pub socket: PathBuf,
    /// Why connecting failed.
    #[source]
    pub source: std::io::Error,
}

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
    /// The API's error text for an error answer.
    #[must_use]
    pub fn error(&self) -> String {
        let msg = self
            .body
            .get("error")
            .and_then(Value::as_str)
            .unwrap_or("no error text");
        match self.body.get("field").and_then(Value::as_str) {
            Some(field) if !msg.contains(field) => format!("{field}: {msg}"),
            _ => msg.to_owned(),
        }
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
            .map_err(|source| NotRunning {
                socket: self.socket.clone(),
                source,
            })?;
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

    /// Sends a request and returns the body of a success; a failed call or an error answer
    /// becomes the [`super::Failure`] it calls for (4xx: bad input; daemon not there:
    /// unreachable; anything else: runtime).
    pub async fn expect(
        &self,
        method: Method,
        path: &str,
        body: Option<&Value>,
    ) -> Result<Value, super::Failure> {
        let answer = self
            .call(method, path, body)
            .await
            .map_err(super::Failure::from_client)?;
        if answer.status.is_success() {
            Ok(answer.body)
        } else {
            Err(super::Failure::from_status(
                answer.status,
                anyhow!("{}", answer.error()),
            ))
        }
    }

    /// Reads an NDJSON feed, calling `each` with every JSON line until the feed ends or `each`
    /// returns `false`.
    pub async fn feed(
        &self,
        path: &str,
        mut each: impl FnMut(&Value) -> bool,
    ) -> anyhow::Result<StatusCode> {
        let mut sender = self.connect().await?;
        let response = sender
            .send_request(Self::request(Method::GET, path, None)?)
            .await
            .context("request to the daemon")?;
        let status = response.status();
        if !status.is_success() {
            return Ok(status);
        }
        let mut body = response.into_body();
        let mut pending = Vec::new();
        while let Some(frame) = body.frame().await {
            let frame = frame.context("reading the progress feed")?;
            let Some(data) = frame.data_ref() else {
                continue;
            };
            pending.extend_from_slice(data);
            while let Some(end) = pending.iter().position(|b| *b == b'\n') {
                let line: Vec<u8> = pending.drain(..=end).collect();
                if line.iter().all(u8::is_ascii_whitespace) {
                    continue;
                }
                let value: Value =
                    serde_json::from_slice(&line).context("a progress line that is not JSON")?;
                if !each(&value) {
                    return Ok(status);
                }
            }
        }
        Ok(status)
    }
}

impl Client {
    /// The robot to act on: `name` if given, else the daemon's only robot.
    pub async fn robot(&self, name: Option<&str>) -> anyhow::Result<String> {
        if let Some(n) = name {
            return Ok(n.to_owned());
        }
        let answer = self.call(Method::GET, "/v1/robots", None).await?;
        let names: Vec<String> = answer
            .body
            .as_array()
            .map(|robots| {
                robots
                    .iter()
                    .filter_map(|r| r["name"].as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default();
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
