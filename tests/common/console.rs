//! The console's test client: logins, the API behind the console's guard, and the WebSocket, on
//! `linterpd::demo::console::ConsoleRig` (the seed's robot, the mock in the press cell, the
//! console on a free loopback port).

use std::net::SocketAddr;
use std::time::Duration;

use futures_util::{SinkExt as _, StreamExt as _};
use http_body_util::{BodyExt, Full};
use hyper::body::Bytes;
use hyper::{Request, StatusCode};
use hyper_util::rt::TokioIo;
use linterpd::demo::console::{ConsoleOptions, ConsoleRig};
use serde_json::Value;
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

/// The rig on a free port at `baud` (`None`: as fast as the pipe).
pub async fn rig(baud: Option<u32>) -> ConsoleRig {
    ConsoleRig::start(ConsoleOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        baud,
        ..ConsoleOptions::default()
    })
    .await
    .unwrap()
}

/// A browser as the console sees it: its cookie and its page's origin.
#[derive(Debug, Clone)]
pub struct Browser {
    pub addr: SocketAddr,
    pub cookie: Option<String>,
    pub origin: Option<String>,
}

/// An answer: status, the Set-Cookie header, the JSON body.
#[derive(Debug)]
pub struct Reply {
    pub status: StatusCode,
    pub set_cookie: Option<String>,
    pub json: Value,
}

impl Browser {
    /// A browser on the console's own page, logged out.
    pub fn new(addr: SocketAddr) -> Self {
        Self {
            addr,
            cookie: None,
            origin: Some(format!("http://{addr}")),
        }
    }

    /// Logs in as `user` (the demo's password `USER-demo`); panics unless it works.
    pub async fn logged_in(addr: SocketAddr, user: &str) -> Self {
        let mut b = Self::new(addr);
        let r = b.login(user, &format!("{user}-demo")).await;
        assert_eq!(r.status, StatusCode::OK, "{:?}", r.json);
        b
    }

    /// POST /console/login; keeps the cookie it sets.
    pub async fn login(&mut self, user: &str, password: &str) -> Reply {
        let body = serde_json::json!({"user": user, "password": password});
        let r = self.call("POST", "/console/login", Some(&body)).await;
        if let Some(set) = &r.set_cookie {
            self.cookie = set.split(';').next().map(str::to_owned);
        }
        r
    }

    /// `method path` with this browser's cookie and origin.
    pub async fn call(&self, method: &str, path: &str, body: Option<&Value>) -> Reply {
        let mut request = Request::builder()
            .method(method)
            .uri(path)
            .header("host", self.addr.to_string());
        if let Some(c) = &self.cookie {
            request = request.header("cookie", c);
        }
        if let Some(o) = &self.origin {
            request = request.header("origin", o);
        }
        if body.is_some() {
            request = request.header("content-type", "application/json");
        }
        let bytes = body.map(ToString::to_string).unwrap_or_default();
        let request = request.body(Full::new(Bytes::from(bytes))).unwrap();
        let stream = TcpStream::connect(self.addr).await.unwrap();
        let (mut sender, connection) = hyper::client::conn::http1::handshake(TokioIo::new(stream))
            .await
            .unwrap();
        tokio::spawn(connection);
        let response = sender.send_request(request).await.unwrap();
        let status = response.status();
        let set_cookie = response
            .headers()
            .get("set-cookie")
            .map(|v| v.to_str().unwrap().to_owned());
        let body = response.into_body().collect().await.unwrap().to_bytes();
        let json = serde_json::from_slice(&body).unwrap_or(Value::Null);
        Reply {
            status,
            set_cookie,
            json,
        }
    }

    /// `method /v1/robots/press-loader/{what}`.
    pub async fn robot(&self, method: &str, what: &str, body: Option<&Value>) -> Reply {
        self.call(method, &format!("/v1/robots/press-loader/{what}"), body)
            .await
    }

    /// Opens the WebSocket; `Err` with the HTTP status when the upgrade is refused.
    pub async fn ws(&self) -> Result<Ws, u16> {
        let mut request = format!("ws://{}/console/ws", self.addr)
            .into_client_request()
            .unwrap();
        if let Some(c) = &self.cookie {
            request.headers_mut().insert("cookie", c.parse().unwrap());
        }
        if let Some(o) = &self.origin {
            request.headers_mut().insert("origin", o.parse().unwrap());
        }
        match tokio_tungstenite::connect_async(request).await {
            Ok((stream, _)) => Ok(Ws { stream }),
            Err(tokio_tungstenite::tungstenite::Error::Http(r)) => Err(r.status().as_u16()),
            Err(e) => panic!("WebSocket: {e}"),
        }
    }
}

/// The console's WebSocket as a page holds it.
pub struct Ws {
    stream: tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<TcpStream>>,
}

impl Ws {
    pub async fn send(&mut self, v: Value) {
        self.stream
            .send(Message::Text(v.to_string().into()))
            .await
            .unwrap();
    }

    /// The next JSON message, within `limit`; `None` once closed.
    pub async fn next(&mut self, limit: Duration) -> Option<Value> {
        loop {
            let m = tokio::time::timeout(limit, self.stream.next())
                .await
                .expect("a WebSocket message in time")?;
            match m {
                Ok(Message::Text(t)) => return Some(serde_json::from_str(&t).unwrap()),
                Ok(Message::Close(_)) | Err(_) => return None,
                Ok(_) => {}
            }
        }
    }

    /// Reads messages until `until` holds for one (returning it), within `limit`.
    pub async fn until(&mut self, limit: Duration, until: impl Fn(&Value) -> bool) -> Value {
        let deadline = tokio::time::Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            let m = self.next(left).await.expect("the WebSocket stayed open");
            if until(&m) {
                return m;
            }
        }
    }

    /// Drops the connection without a close frame (a browser killed).
    pub fn kill(self) {
        drop(self.stream);
    }

    /// Closes it as a page does.
    pub async fn close(mut self) {
        let _ = self.stream.close(None).await;
    }
}
