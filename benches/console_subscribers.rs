//! The console's subscribers against the daemon's CPU (issue 46's goal: 20 browsers and a
//! `status --watch` cost no PLC exchange and at most 10 % more CPU). Runs `linterpd demo
//! --console` (the daemon, the mock PLC at 115200 baud and the console, one process), drives
//! the same moves twice, without subscribers and with 20 WebSocket subscribers and one NDJSON
//! reader of `/v1/live`, and reads the process's CPU time from /proc around each run.
//!
//! `cargo bench --bench console_subscribers`

#![allow(missing_docs)]

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{SinkExt as _, StreamExt as _};
use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

const MOVES: usize = 8;

fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let after = &stat[stat.rfind(')').unwrap() + 2..];
    let fields: Vec<&str> = after.split(' ').collect();
    let ticks: f64 = fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap();
    ticks / 100.0
}

/// One HTTP/1.1 request on its own connection; the status, the Set-Cookie value, the body.
async fn http(
    addr: &str,
    method: &str,
    path: &str,
    cookie: &str,
    body: &str,
) -> (u16, String, String) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "{method} {path} HTTP/1.1\r\nhost: {addr}\r\norigin: http://{addr}\r\ncookie: {cookie}\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).await.unwrap();
    let status = out[9..12].parse().unwrap();
    let cookie = out
        .lines()
        .find_map(|l| l.strip_prefix("set-cookie: "))
        .and_then(|c| c.split(';').next())
        .unwrap_or_default()
        .to_owned();
    let body = out.split("\r\n\r\n").nth(1).unwrap_or_default().to_owned();
    (status, cookie, body)
}

async fn login(addr: &str, user: &str) -> String {
    let body = format!("{{\"user\":\"{user}\",\"password\":\"{user}-demo\"}}");
    let (status, cookie, _) = http(addr, "POST", "/console/login", "", &body).await;
    assert_eq!(status, 200);
    cookie
}

type Ws = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<TcpStream>>;

async fn ws(addr: &str, cookie: &str) -> Ws {
    let mut r = format!("ws://{addr}/console/ws")
        .into_client_request()
        .unwrap();
    r.headers_mut().insert("cookie", cookie.parse().unwrap());
    r.headers_mut()
        .insert("origin", format!("http://{addr}").parse().unwrap());
    tokio_tungstenite::connect_async(r).await.unwrap().0
}

/// Moves the tool up and down `MOVES` times through the console's API, each to its end.
async fn moves(addr: &str, cookie: &str) -> Duration {
    let began = Instant::now();
    for k in 0..MOVES {
        let dz = if k % 2 == 0 { 80 } else { -80 };
        let body = format!("{{\"by\":[0,0,{dz}],\"speed_mm_s\":120}}");
        let (status, _, answer) =
            http(addr, "POST", "/v1/robots/press-loader/moves", cookie, &body).await;
        assert_eq!(status, 202, "{answer}");
        let id: serde_json::Value = serde_json::from_str(&answer).unwrap();
        let id = id["id"].as_u64().unwrap();
        loop {
            let (_, _, report) = http(
                addr,
                "GET",
                &format!("/v1/robots/press-loader/moves/{id}"),
                cookie,
                "",
            )
            .await;
            let r: serde_json::Value = serde_json::from_str(&report).unwrap();
            if ["done", "stopped", "failed", "cancelled"].contains(&r["stage"].as_str().unwrap()) {
                break;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    began.elapsed()
}

#[tokio::main]
async fn main() {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let addr = format!("127.0.0.1:{port}");
    let mut daemon = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(["demo", "--console", "--listen", &addr])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(daemon.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.starts_with("the console:"), "{line}");
    let pid = daemon.id();
    let operator = login(&addr, "operator").await;
    let mut seat = ws(&addr, &operator).await;
    seat.send(Message::Text(
        r#"{"type":"take-seat","robot":"press-loader"}"#.into(),
    ))
    .await
    .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;

    let cpu0 = cpu_s(pid);
    let alone = moves(&addr, &operator).await;
    let cpu_alone = cpu_s(pid) - cpu0;

    let viewer = login(&addr, "viewer").await;
    let mut counters = Vec::new();
    for _ in 0..20 {
        let mut socket = ws(&addr, &viewer).await;
        let n = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
        counters.push(std::sync::Arc::clone(&n));
        tokio::spawn(async move {
            while let Some(Ok(_)) = socket.next().await {
                n.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        });
    }
    // The NDJSON stream `status --watch` reads (here through the console's API).
    let watch_addr = addr.clone();
    let watch_cookie = viewer.clone();
    tokio::spawn(async move {
        let mut s = TcpStream::connect(&watch_addr).await.unwrap();
        let req = format!(
            "GET /v1/live HTTP/1.1\r\nhost: {watch_addr}\r\ncookie: {watch_cookie}\r\n\r\n"
        );
        s.write_all(req.as_bytes()).await.unwrap();
        let mut buf = vec![0_u8; 65536];
        while s.read(&mut buf).await.unwrap_or(0) > 0 {}
    });
    tokio::time::sleep(Duration::from_millis(500)).await;
    let cpu1 = cpu_s(pid);
    let with = moves(&addr, &operator).await;
    let cpu_with = cpu_s(pid) - cpu1;
    let messages: u64 = counters
        .iter()
        .map(|n| n.load(std::sync::atomic::Ordering::Relaxed))
        .sum();
    println!(
        "{MOVES} moves of 80 mm at 120 mm/s through the console, MEWTOCOL % at 115200 baud:\n  \
         no subscriber: {:.3} s wall, daemon CPU {:.2} s ({:.1} %)\n  \
         20 WebSockets + 1 NDJSON reader: {:.3} s wall, daemon CPU {:.2} s ({:.1} %), {:.1} messages a second to each WebSocket\n  \
         CPU with them / without: x{:.3}",
        alone.as_secs_f64(),
        cpu_alone,
        cpu_alone / alone.as_secs_f64() * 100.0,
        with.as_secs_f64(),
        cpu_with,
        cpu_with / with.as_secs_f64() * 100.0,
        messages as f64 / 20.0 / with.as_secs_f64(),
        (cpu_with / with.as_secs_f64()) / (cpu_alone / alone.as_secs_f64()),
    );
    let _ = daemon.kill();
    let _ = daemon.wait();
}
