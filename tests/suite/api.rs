//! The HTTP/JSON API end to end: the router on a Unix socket in a temp dir, the daemon behind it
//! on the mock PLC, and a real HTTP client; then the `linterpd serve` binary against
//! `linterpd mock-plc`.

use crate::common;

use std::time::Duration;

use common::daemon::duplex_connector;
use common::exchange::{P1, P2, mock_at_seed_start};
use common::http::{Answer, Endpoint, read_response};
use common::process::TempDir;
use hyper::StatusCode;
use linterpd::config::Config;
use linterpd::daemon::api::{self, Api, BearerToken};
use linterpd::daemon::{Daemon, RobotHandle};
use linterpd::plc::exchange::ContractSettings;
use serde_json::{Value, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, UnixListener, UnixStream};

const ROBOT: &str = "/v1/robots/press-loader";
use common::serve::READY;
const SHIPPED: &str = include_str!("../../config/linterpd.toml");

/// The daemon on a mock at the seed's start, its API on a Unix socket in `dir`.
struct Served {
    daemon: Daemon,
    api: Endpoint,
    _dir: TempDir,
}

impl Served {
    async fn start() -> Self {
        let shared = mock_at_seed_start("");
        let (daemon, _) =
            common::daemon::spawn(duplex_connector(&shared, None), ContractSettings::default());
        let dir = TempDir::new("api");
        let path = dir.path().join("api.sock");
        let listener = UnixListener::bind(&path).unwrap();
        let router = Api::new(daemon.robots().clone()).router(None);
        tokio::spawn(api::serve(listener, router, std::future::pending()));
        let served = Self {
            api: Endpoint::unix(&path),
            daemon,
            _dir: dir,
        };
        served.wait_connected().await;
        served
    }

    fn handle(&self) -> &RobotHandle {
        self.daemon.robot("press-loader").unwrap()
    }

    /// Until the robot's counts are known (so a submitted move is planned at once).
    async fn wait_connected(&self) {
        let mut feed = tokio::time::interval(Duration::from_millis(10));
        for _ in 0..1_000 {
            if self.handle().state().counts.is_some() {
                return;
            }
            feed.tick().await;
        }
        panic!("never connected: {:?}", self.handle().state());
    }

    async fn submit(&self, to: [f64; 3]) -> u64 {
        self.submit_order(&json!({ "to": to })).await
    }

    /// Posts `order` as a move: accepted, its id.
    async fn submit_order(&self, order: &Value) -> u64 {
        let answer = self
            .api
            .post(&format!("{ROBOT}/moves"), &order.to_string())
            .await;
        assert_eq!(answer.status, StatusCode::ACCEPTED, "{}", answer.text());
        let body = answer.json();
        assert_eq!(body["report"]["id"], body["id"]);
        body["id"].as_u64().unwrap()
    }

    async fn events(&self, id: u64) -> Vec<Value> {
        let answer = self.api.get(&format!("{ROBOT}/moves/{id}/events")).await;
        assert_eq!(answer.status, StatusCode::OK);
        assert_eq!(answer.content_type, "application/x-ndjson");
        answer.lines()
    }
}

fn assert_error(answer: &Answer, status: StatusCode, field: Option<&str>) {
    assert_eq!(answer.status, status, "{}", answer.text());
    let body = answer.json();
    assert!(
        body["error"].as_str().is_some_and(|e| !e.is_empty()),
        "{body}"
    );
    assert_eq!(body["field"].as_str(), field, "{body}");
}

fn assert_done_on_target(report: &Value) {
    assert_eq!(report["stage"], "done", "{report}");
    let errors = report["final_error_pulses"]
        .as_array()
        .expect("final counts compared");
    assert!(
        errors.iter().all(|e| e.as_i64().unwrap().abs() <= 1),
        "{report}"
    );
}

#[tokio::test]
async fn posted_move_ends_on_its_target_and_its_events_end_with_done() {
    let s = Served::start().await;
    let id = s.submit(P2).await;
    let events = s.events(id).await;
    assert!(events.len() >= 2, "{events:?}");
    assert!(
        events[..events.len() - 1]
            .iter()
            .all(|e| e["stage"] != "done")
    );
    assert_done_on_target(events.last().unwrap());
    let report = s.api.get(&format!("{ROBOT}/moves/{id}")).await;
    assert_eq!(report.status, StatusCode::OK);
    assert_done_on_target(&report.json());
    // The stream of a finished move is its final report alone.
    assert_eq!(s.events(id).await.len(), 1);
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn bad_requests_get_a_json_error_naming_the_field_and_queue_nothing() {
    let s = Served::start().await;
    let moves = format!("{ROBOT}/moves");
    for (body, status, field) in [
        (r#"{"to":[1,2]}"#, StatusCode::BAD_REQUEST, Some("to")),
        (
            r#"{"to":[1,2,3],"colour":"red"}"#,
            StatusCode::BAD_REQUEST,
            Some("colour"),
        ),
        (r#"{"to":"home"}"#, StatusCode::BAD_REQUEST, Some("to")),
        (
            r#"{"to":[1,2,3],"speed_mm_s":0}"#,
            StatusCode::BAD_REQUEST,
            Some("speed_mm_s"),
        ),
        ("move to P2", StatusCode::BAD_REQUEST, None),
        // Out of the d3 limit (0 to 1000 mm): a plan error.
        (
            r#"{"to":[-1144.43,659.6,5000]}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
            None,
        ),
    ] {
        assert_error(&s.api.post(&moves, body).await, status, field);
    }
    let state = s.api.get(ROBOT).await.json();
    assert_eq!(state["queued"], json!([]), "{state}");
    assert_eq!(state["current_move"], Value::Null, "{state}");
    assert!(s.handle().reports().is_empty());
    assert_error(
        &s.api.get(&format!("{ROBOT}/moves/1")).await,
        StatusCode::NOT_FOUND,
        Some("id"),
    );
    let unknown = s.api.get("/v1/robots/welder").await;
    assert_error(&unknown, StatusCode::NOT_FOUND, Some("robot"));
    assert_eq!(
        unknown.json()["error"],
        "no robot \"welder\"; robots: press-loader"
    );
    assert_error(
        &s.api
            .post("/v1/robots/welder/moves", r#"{"to":[1,2,3]}"#)
            .await,
        StatusCode::NOT_FOUND,
        Some("robot"),
    );
    assert_error(&s.api.get("/v2/nothing").await, StatusCode::NOT_FOUND, None);
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn several_clients_at_once_are_all_served() {
    let s = Served::start().await;
    let mut clients = tokio::task::JoinSet::new();
    for i in 0..8 {
        let api = s.api.clone();
        let path = if i % 2 == 0 {
            "/v1/robots".to_owned()
        } else {
            ROBOT.to_owned()
        };
        clients.spawn(async move { api.get(&path).await.status });
    }
    let api = s.api.clone();
    clients.spawn(async move {
        api.post(&format!("{ROBOT}/moves"), &json!({ "to": P2 }).to_string())
            .await
            .status
    });
    let mut statuses = Vec::new();
    while let Some(status) = clients.join_next().await {
        statuses.push(status.unwrap());
    }
    assert_eq!(statuses.len(), 9);
    assert_eq!(
        statuses.iter().filter(|s| **s == StatusCode::OK).count(),
        8,
        "{statuses:?}"
    );
    assert!(statuses.contains(&StatusCode::ACCEPTED), "{statuses:?}");
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn stop_answers_200_and_the_move_ends_stopped() {
    let s = Served::start().await;
    // A slow move (about 5.5 s), stopped a tenth of the way: on a loaded machine the test may
    // be woken late, and the move must still be running when it is.
    let id = s
        .submit_order(&json!({ "to": P2, "speed_mm_s": 60.0 }))
        .await;
    let mut feed = s.handle().subscribe(id).unwrap();
    common::daemon::report_until(&mut feed, "10 % done", |r| r.progress > 0.1).await;
    let stop = s.api.post(&format!("{ROBOT}/stop"), "").await;
    assert_eq!(stop.status, StatusCode::OK, "{}", stop.text());
    assert_eq!(stop.json(), json!({ "stopped": true }));
    let events = s.events(id).await;
    assert_eq!(events.last().unwrap()["stage"], "stopped", "{events:?}");
    s.daemon.shut_down().await;
}

/// Every sample line of an `OpenMetrics` text whose series starts with `series`, as
/// (series, value).
fn samples(text: &str, series: &str) -> Vec<(String, f64)> {
    text.lines()
        .filter(|l| l.starts_with(series))
        .filter_map(|l| l.rsplit_once(' '))
        .map(|(k, v)| (k.to_owned(), v.parse().unwrap()))
        .collect()
}

#[tokio::test]
async fn metrics_are_lifetime_counters_that_only_go_up() {
    let s = Served::start().await;
    let before = s.api.get("/metrics").await;
    assert_eq!(before.status, StatusCode::OK);
    assert!(
        before
            .content_type
            .starts_with("application/openmetrics-text"),
        "{}",
        before.content_type
    );
    let mut before = before.text();
    // The first connection is not a reconnection.
    let reconnects = "linterpd_link_reconnects_total{robot=\"press-loader\"}";
    assert_eq!(samples(&before, reconnects), [(reconnects.to_owned(), 0.0)]);
    assert!(
        samples(&before, "linterpd_build_info{version=")
            .iter()
            .any(|(k, v)| k.contains("commit=") && (*v - 1.0).abs() < f64::EPSILON),
        "{before}"
    );
    assert!(!before.contains(" -0"), "{before}");

    for (i, to) in [P2, P1, P2].into_iter().enumerate() {
        let id = s.submit(to).await;
        assert_done_on_target(s.events(id).await.last().unwrap());
        let text = s.api.get("/metrics").await.text();
        for line in [
            format!(
                "linterpd_moves_total{{robot=\"press-loader\",outcome=\"done\"}} {}",
                i + 1
            ),
            "linterpd_moves_total{robot=\"press-loader\",outcome=\"stopped\"} 0".to_owned(),
            format!(
                "linterpd_upload_seconds_count{{robot=\"press-loader\"}} {}",
                i + 1
            ),
            format!(
                "linterpd_motion_seconds_count{{robot=\"press-loader\"}} {}",
                i + 1
            ),
            "linterpd_link_up{robot=\"press-loader\"} 1".to_owned(),
            "linterpd_plc_fault{robot=\"press-loader\"} 0".to_owned(),
            format!("{reconnects} 0"),
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
        assert!(
            text.contains("linterpd_heartbeat_age_seconds{robot=\"press-loader\"} "),
            "{text}"
        );
        // Every counter and every histogram's count and sum are at least what they were.
        for (series, was) in samples(&before, "linterpd_")
            .into_iter()
            .filter(|(k, _)| k.contains("_total{") || k.contains("_count{") || k.contains("_sum{"))
        {
            let now = samples(&text, &series);
            assert!(
                now.iter().any(|(k, v)| *k == series && *v >= was),
                "{series} went from {was} to {now:?}"
            );
        }
        before = text;
    }
    s.daemon.shut_down().await;
}

#[test]
fn tcp_listener_beyond_loopback_without_a_token_file_is_refused() {
    let text = format!("{SHIPPED}\n[daemon]\nlisten = \"0.0.0.0:8420\"\n");
    let e = Config::from_toml(&text).unwrap_err().to_string();
    assert!(e.contains("daemon.listen = \"0.0.0.0:8420\""), "{e}");
    assert!(e.contains("token_file"), "{e}");
    let with_token = format!("{text}token_file = \"/etc/linterpd/token\"\n");
    assert!(Config::from_toml(&with_token).is_ok());
}

#[tokio::test]
async fn tcp_listener_with_a_token_wants_it_as_bearer() {
    let s = Served::start().await;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let tcp = Endpoint::Tcp(listener.local_addr().unwrap());
    let token = BearerToken::new("s3cret").unwrap();
    let router = Api::new(s.daemon.robots().clone()).router(Some(token));
    tokio::spawn(async move { axum::serve(listener, router).await });
    assert_error(&tcp.get("/v1/robots").await, StatusCode::UNAUTHORIZED, None);
    let wrong = tcp.call("GET", "/v1/robots", None, Some("guess")).await;
    assert_error(&wrong, StatusCode::UNAUTHORIZED, None);
    let right = tcp.call("GET", "/v1/robots", None, Some("s3cret")).await;
    assert_eq!(right.status, StatusCode::OK, "{}", right.text());
    assert_eq!(right.json()[0]["name"], "press-loader");
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn a_bearer_scheme_in_lower_case_is_accepted_as_rfc_9110_says() {
    let s = Served::start().await;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let tcp = Endpoint::Tcp(listener.local_addr().unwrap());
    let token = BearerToken::new("s3cret").unwrap();
    let router = Api::new(s.daemon.robots().clone()).router(Some(token));
    tokio::spawn(async move { axum::serve(listener, router).await });
    for value in ["bearer s3cret", "BEARER s3cret", "Bearer s3cret"] {
        let answer = tcp
            .request("GET", "/v1/robots", &[("authorization", value)], Vec::new())
            .await;
        assert_eq!(answer.status, StatusCode::OK, "{value}: {}", answer.text());
    }
    let wrong = tcp
        .request(
            "GET",
            "/v1/robots",
            &[("authorization", "bearer guess")],
            Vec::new(),
        )
        .await;
    assert_error(&wrong, StatusCode::UNAUTHORIZED, None);
    s.daemon.shut_down().await;
}

/// The API of a daemon with no robots, served by [`api::serve_with`] on a Unix socket in `dir`
/// with `header_timeout`.
fn serve_robotless(dir: &TempDir, header_timeout: Duration) -> std::path::PathBuf {
    let path = dir.path().join("api.sock");
    let listener = UnixListener::bind(&path).unwrap();
    let router = Api::new(std::collections::BTreeMap::new()).router(None);
    tokio::spawn(api::serve_with(
        listener,
        router,
        header_timeout,
        std::future::pending(),
    ));
    path
}

#[tokio::test]
async fn a_10_mb_body_gets_a_json_413_naming_its_size_and_the_limit() {
    let dir = TempDir::new("api-413");
    let socket = serve_robotless(&dir, api::HEADER_READ_TIMEOUT);
    let limit = api::MAX_BODY_BYTES;
    // Declared: refused on its Content-Length, before the body is read.
    let mut stream = UnixStream::connect(&socket).await.unwrap();
    let head = "POST /v1/robots/press-loader/moves HTTP/1.1\r\nhost: localhost\r\n\
                content-type: application/json\r\ncontent-length: 10485760\r\n\r\n";
    stream.write_all(head.as_bytes()).await.unwrap();
    stream.write_all(&vec![b' '; 65_536]).await.unwrap();
    let answer = read_response(&mut stream).await;
    assert_eq!(answer.status, 413);
    assert_eq!(answer.header("content-type"), Some("application/json"));
    assert_eq!(
        answer.json(),
        json!({
            "error": format!("the body is 10485760 bytes; at most {limit} bytes"),
            "reason": "too-large"
        })
    );
    // Chunked, its size unknown: refused once it passes the limit.
    let stream = UnixStream::connect(&socket).await.unwrap();
    let (mut rx, mut tx) = stream.into_split();
    let head = "POST /v1/robots/press-loader/paths HTTP/1.1\r\nhost: localhost\r\n\
                content-type: application/json\r\ntransfer-encoding: chunked\r\n\r\n";
    let writer = tokio::spawn(async move {
        tx.write_all(head.as_bytes()).await?;
        let chunk = vec![b' '; 65_536];
        for _ in 0..(limit / chunk.len() + 8) {
            tx.write_all(b"10000\r\n").await?;
            tx.write_all(&chunk).await?;
            tx.write_all(b"\r\n").await?;
        }
        std::io::Result::Ok(())
    });
    let answer = read_response(&mut rx).await;
    assert_eq!(answer.status, 413);
    assert_eq!(
        answer.json()["error"],
        format!("the body is more than {limit} bytes; at most {limit} bytes")
    );
    writer.abort();
}

#[tokio::test]
async fn rejections_axum_makes_itself_answer_the_json_error_shape() {
    let dir = TempDir::new("api-rejections");
    let api = Endpoint::unix(&serve_robotless(&dir, api::HEADER_READ_TIMEOUT));
    // A robot name that is not UTF-8: the path extractor's rejection, plain text before.
    let bad_name = api.get("/v1/robots/%FF").await;
    assert_error(&bad_name, StatusCode::BAD_REQUEST, None);
    assert_eq!(bad_name.content_type, "application/json");
    let error = bad_name.json()["error"].as_str().unwrap().to_owned();
    assert!(error.starts_with(char::is_lowercase), "{error}");
    assert_error(
        &api.call("DELETE", "/v1/robots", None, None).await,
        StatusCode::METHOD_NOT_ALLOWED,
        None,
    );
    assert_error(&api.get("/nowhere").await, StatusCode::NOT_FOUND, None);
}

#[tokio::test(start_paused = true)]
async fn half_open_connections_are_closed_after_the_header_timeout() {
    let dir = TempDir::new("api-half-open");
    let socket = serve_robotless(&dir, api::HEADER_READ_TIMEOUT);
    let began = tokio::time::Instant::now();
    let mut idle = Vec::new();
    for i in 0..200 {
        let mut stream = UnixStream::connect(&socket).await.unwrap();
        if i % 2 == 0 {
            // Half a request head, never finished.
            stream
                .write_all(b"GET /v1/robots HTTP/1.1\r\nhost: localhost\r\n")
                .await
                .unwrap();
        }
        idle.push(stream);
    }
    // On paused time: open until the timeout, closed at it (read: end of stream or reset).
    let short = api::HEADER_READ_TIMEOUT.saturating_sub(Duration::from_secs(1));
    let mut byte = [0; 1];
    let open = tokio::time::timeout(short, idle[0].read(&mut byte)).await;
    assert!(open.is_err(), "closed before the timeout: {open:?}");
    for (i, stream) in idle.iter_mut().enumerate() {
        let end = stream.read(&mut byte).await;
        assert!(matches!(end, Ok(0) | Err(_)), "connection {i}: {end:?}");
    }
    assert!(began.elapsed() >= api::HEADER_READ_TIMEOUT);
    // A client that sends its request is served as before.
    let robots = Endpoint::unix(&socket).get("/v1/robots").await;
    assert_eq!(robots.status, StatusCode::OK, "{}", robots.text());
}

#[tokio::test]
async fn serve_binary_runs_a_move_on_the_mock_plc_and_exits_0_on_sigterm() {
    let mut running = common::serve::start();
    let socket = running.socket.clone();
    let api = Endpoint::unix(&socket);
    // The mock starts at counts 0: tool at (0, 500, 0) mm. A short move from there.
    let answer = api
        .post(&format!("{ROBOT}/moves"), r#"{"to":[50,520,20]}"#)
        .await;
    assert_eq!(
        answer.status,
        StatusCode::ACCEPTED,
        "{}\n{}",
        answer.text(),
        running.serve.output()
    );
    let id = answer.json()["id"].as_u64().unwrap();
    let events = api.get(&format!("{ROBOT}/moves/{id}/events")).await.lines();
    assert_done_on_target(events.last().unwrap());
    let status = running.serve.terminate(READY);
    assert!(status.success(), "{status}\n{}", running.serve.output());
    assert!(!socket.exists(), "the socket is removed on exit");
}
