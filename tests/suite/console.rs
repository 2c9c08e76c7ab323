//! The operator's console without a browser (issue 46): the push stream (every status read of a
//! move reaches every subscriber, N subscribers cost no PLC exchange, a slow one is dropped and
//! never holds the worker), the jog lease end to end on the mock (release, expiry, a closed or
//! hidden page, a take-over, a fault: each stops the pulses; the travel after the last
//! keep-alive within the worst case the console shows), the seat and the roles, and the
//! refusals of a missing session, a foreign `Origin` and too many failed logins.

use std::collections::BTreeMap;
use std::time::Duration;

use hyper::StatusCode;
use linterpd::console::patch;
use linterpd::daemon::console::{LiveHub, SnapshotSetup};
use linterpd::daemon::{MoveOrder, RobotPhase};
use linterpd::demo::console::ConsoleRig;
use linterpd::order::OrderMotion;
use serde_json::{Value, json};

use crate::common::console::{Browser, Ws, rig};

const LIMIT: Duration = Duration::from_secs(20);

/// Follows the stream: the merged snapshot of the robot after each message, with the message.
struct Follower {
    ws: Ws,
    live: Value,
}

impl Follower {
    async fn open(b: &Browser) -> Self {
        let mut ws = b.ws().await.unwrap();
        let hello = ws.next(LIMIT).await.unwrap();
        assert_eq!(hello["type"], "hello");
        let full = ws.next(LIMIT).await.unwrap();
        assert_eq!(full["type"], "full", "{full}");
        Self {
            ws,
            live: full["live"].clone(),
        }
    }

    /// The next change, applied.
    async fn next(&mut self) -> Option<Value> {
        loop {
            let m = self.ws.next(LIMIT).await?;
            match m["type"].as_str() {
                Some("patch") => {
                    patch::apply(&mut self.live, &m["patch"]);
                    return Some(m);
                }
                Some("error") => return Some(m),
                _ => {}
            }
        }
    }

    /// Until the snapshot satisfies `f`.
    async fn until(&mut self, f: impl Fn(&Value) -> bool) -> &Value {
        let deadline = tokio::time::Instant::now() + LIMIT;
        while !f(&self.live) {
            assert!(
                tokio::time::Instant::now() < deadline,
                "never: {}",
                self.live
            );
            self.next().await.expect("the stream stayed open");
        }
        &self.live
    }
}

fn counts(rig: &ConsoleRig) -> [i64; 4] {
    rig.mock.with(|m| std::array::from_fn(|c| m.count(c)))
}

/// The tool's distance between two sets of channel counts, mm.
fn travel_mm(rig: &ConsoleRig, a: [i64; 4], b: [i64; 4]) -> f64 {
    let robot = rig.handle.robot();
    let pose = |c: [i64; 4]| {
        let by_joint = std::array::from_fn(|j| c[usize::from(robot.joints[j].channel)]);
        robot.pose_of(&by_joint).position_mm
    };
    (pose(a) - pose(b)).norm()
}

/// An operator with the seat, following the stream.
async fn operator_with_seat(rig: &ConsoleRig) -> (Browser, Follower) {
    let op = Browser::logged_in(rig.addr, "operator").await;
    let mut f = Follower::open(&op).await;
    f.ws.send(json!({"type": "take-seat", "robot": "press-loader"}))
        .await;
    f.until(|l| l["console"]["seat"]["user"] == "operator")
        .await;
    (op, f)
}

/// Starts a hold-to-run jog along x+ and keeps it alive `n` times, 100 ms apart; returns the
/// counts at the last keep-alive and the next sequence number.
async fn hold(f: &mut Follower, rig: &ConsoleRig, n: u64) -> [i64; 4] {
    f.ws.send(
        json!({"type": "jog", "robot": "press-loader", "axis": "x", "positive": true, "seq": 1}),
    )
    .await;
    let mut at_last = counts(rig);
    for seq in 2..2 + n {
        tokio::time::sleep(Duration::from_millis(100)).await;
        f.ws.send(json!({"type": "keep", "robot": "press-loader", "seq": seq}))
            .await;
        at_last = counts(rig);
    }
    at_last
}

/// Waits until the jog has ended and the robot stands; returns why it ended.
async fn ended(f: &mut Follower) -> String {
    let live = f
        .until(|l| {
            l["console"]["jog"]["active"].is_null()
                && !l["console"]["jog"]["last_end"].is_null()
                && l["state"]["phase"] == "idle"
                && l["state"]["current_move"].is_null()
        })
        .await;
    live["console"]["jog"]["last_end"]
        .as_str()
        .unwrap()
        .to_owned()
}

/// The jog moved the tool, stopped, and went no further after the last keep-alive than the
/// worst case the console shows.
async fn check_travel(rig: &ConsoleRig, f: &Follower, start: [i64; 4], at_last: [i64; 4]) {
    // Let the mock play anything still committed (nothing should be).
    tokio::time::sleep(Duration::from_millis(400)).await;
    let end = counts(rig);
    let moved = travel_mm(rig, start, end);
    let after = travel_mm(rig, at_last, end);
    let worst = f.live["console"]["jog"]["travel_alive_mm"]
        .as_f64()
        .unwrap();
    assert!(moved > 1.0, "the jog moved the tool {moved} mm");
    assert!(
        after <= worst,
        "{after} mm after the last keep-alive; the worst case shown is {worst} mm"
    );
    assert!(
        !rig.mock.with(|m| (0..4).any(|c| m.busy(c))),
        "no channel is busy after the jog"
    );
}

#[tokio::test]
async fn every_subscriber_sees_the_moves_phases_and_pose_at_each_status_read_for_no_exchange() {
    let rig = rig(Some(115_200)).await;
    let mut followers = Vec::new();
    for _ in 0..20 {
        let v = Browser::logged_in(rig.addr, "viewer").await;
        followers.push(Follower::open(&v).await);
    }
    // Idle, 20 subscribers: every exchange is one of the worker's own status reads (or its
    // mode read, every 10 s).
    let (reads0, cmds0) = (rig.handle.snapshot().reads, rig.mock.with(|m| m.commands()));
    tokio::time::sleep(Duration::from_millis(1_500)).await;
    let (reads1, cmds1) = (rig.handle.snapshot().reads, rig.mock.with(|m| m.commands()));
    assert!(reads1 > reads0);
    println!(
        "BENCH 20 subscribers, idle 1.5 s: {} PLC exchanges for {} status reads",
        cmds1 - cmds0,
        reads1 - reads0
    );
    assert!(
        cmds1 - cmds0 <= reads1 - reads0 + 1,
        "{} exchanges for {} status reads with 20 subscribers",
        cmds1 - cmds0,
        reads1 - reads0
    );
    let id = rig
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, 0.0, 60.0]),
            motion: OrderMotion {
                speed_mm_s: Some(60.0),
                ..OrderMotion::default()
            },
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let report = rig.handle.wait(id, LIMIT).await.unwrap();
    assert_eq!(report.stage, linterpd::daemon::Stage::Done);
    for f in &mut followers {
        let mut phases: Vec<String> = Vec::new();
        let mut running_reads = Vec::new();
        loop {
            let phase = f.live["state"]["phase"].as_str().unwrap().to_owned();
            if phases.last() != Some(&phase) {
                phases.push(phase.clone());
            }
            if phase == "running" {
                running_reads.push(f.live["reads"].as_u64().unwrap());
            }
            if f.live["last"]["id"] == json!(id) && phase == "idle" {
                break;
            }
            f.next().await.unwrap();
        }
        assert!(
            phases.iter().any(|p| p == "running") && phases.last().unwrap() == "idle",
            "{phases:?}"
        );
        // Every status read while the move ran reached this subscriber (a read the publisher
        // took together with the next one would show as a gap of 2).
        let span = running_reads.last().unwrap() - running_reads.first().unwrap() + 1;
        assert!(
            running_reads.len() as u64 * 10 >= span * 8,
            "{} of {span} reads while running",
            running_reads.len()
        );
    }
    rig.stop().await;
}

#[tokio::test]
async fn a_slow_subscriber_is_dropped_and_never_holds_the_worker() {
    let rig = rig(None).await;
    let closing = tokio_util::sync::CancellationToken::new();
    let robots = BTreeMap::from([("press-loader".to_owned(), rig.handle.clone())]);
    let hub = LiveHub::with_capacity(
        &robots,
        &BTreeMap::<String, SnapshotSetup>::new(),
        &closing,
        4,
    );
    let mut stalled = hub.robot("press-loader").unwrap().subscribe();
    let reads0 = rig.handle.snapshot().reads;
    let id = rig
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, 0.0, 40.0]),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let report = rig.handle.wait(id, LIMIT).await.unwrap();
    assert_eq!(report.stage, linterpd::daemon::Stage::Done);
    assert!(rig.handle.snapshot().reads > reads0 + 4);
    // The subscriber that read nothing has fallen behind: its next read says so.
    assert!(matches!(
        stalled.rest.recv().await,
        Err(tokio::sync::broadcast::error::RecvError::Lagged(_))
    ));
    closing.cancel();
    rig.stop().await;
}

#[tokio::test]
async fn release_stops_the_jog_and_the_travel_after_the_last_keep_alive_is_within_the_worst_case() {
    let rig = rig(Some(115_200)).await;
    let (_op, mut f) = operator_with_seat(&rig).await;
    let start = counts(&rig);
    let at_last = hold(&mut f, &rig, 10).await;
    f.until(|l| !l["console"]["jog"]["active"].is_null()).await;
    f.ws.send(json!({"type": "release", "robot": "press-loader"}))
        .await;
    assert_eq!(ended(&mut f).await, "released");
    check_travel(&rig, &f, start, at_last).await;
    rig.stop().await;
}

#[tokio::test]
async fn a_page_that_stops_sending_is_stopped_by_the_lease() {
    let rig = rig(Some(115_200)).await;
    let (_op, mut f) = operator_with_seat(&rig).await;
    let start = counts(&rig);
    // Held, then the page freezes: no release, no more keep-alives.
    let at_last = hold(&mut f, &rig, 5).await;
    assert_eq!(ended(&mut f).await, "no keep-alive within the lease");
    check_travel(&rig, &f, start, at_last).await;
    rig.stop().await;
}

#[tokio::test]
async fn a_closed_connection_and_a_hidden_page_each_stop_the_jog() {
    let rig = rig(Some(115_200)).await;
    let (op, mut f) = operator_with_seat(&rig).await;
    hold(&mut f, &rig, 4).await;
    f.ws.send(json!({"type": "hidden"})).await;
    assert_eq!(ended(&mut f).await, "the page lost focus or was hidden");

    // A connection killed while held: the jog stops, seen from another page.
    let mut watcher = Follower::open(&op).await;
    let start = counts(&rig);
    let at_last = hold(&mut f, &rig, 4).await;
    watcher
        .until(|l| !l["console"]["jog"]["active"].is_null())
        .await;
    f.ws.kill();
    assert_eq!(ended(&mut watcher).await, "the page's connection closed");
    check_travel(&rig, &watcher, start, at_last).await;
    rig.stop().await;
}

#[tokio::test]
async fn another_session_taking_the_seat_stops_the_first_ones_jog() {
    let rig = rig(Some(115_200)).await;
    let (_op, mut f) = operator_with_seat(&rig).await;
    let admin = Browser::logged_in(rig.addr, "admin").await;
    let mut g = Follower::open(&admin).await;
    hold(&mut f, &rig, 3).await;
    g.until(|l| !l["console"]["jog"]["active"].is_null()).await;
    g.ws.send(json!({"type": "take-seat", "robot": "press-loader"}))
        .await;
    // The first page keeps its keep-alives going: the take-over alone stops the jog.
    for seq in 10..14 {
        f.ws.send(json!({"type": "keep", "robot": "press-loader", "seq": seq}))
            .await;
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert_eq!(ended(&mut g).await, "another session took the control seat");
    assert_eq!(g.live["console"]["seat"]["user"], "admin");
    // The operator's next jog is refused: the seat is the admin's.
    f.ws.send(
        json!({"type": "jog", "robot": "press-loader", "axis": "y", "positive": true, "seq": 20}),
    )
    .await;
    let e = loop {
        let m = f.next().await.unwrap();
        if m["type"] == "error" {
            break m;
        }
    };
    assert!(
        e["error"].as_str().unwrap().contains("admin holds it"),
        "{e}"
    );
    rig.stop().await;
}

#[tokio::test]
async fn a_fault_stops_the_jog_and_jogging_is_refused_while_faulted() {
    let rig = rig(Some(115_200)).await;
    let (op, mut f) = operator_with_seat(&rig).await;
    hold(&mut f, &rig, 3).await;
    f.until(|l| !l["console"]["jog"]["active"].is_null()).await;
    rig.mock.with(|m| m.set_estop_open(true));
    // Keep-alives go on: the fault alone ends the jog.
    let mut seq = 10;
    let live = loop {
        seq += 1;
        f.ws.send(json!({"type": "keep", "robot": "press-loader", "seq": seq}))
            .await;
        let l = f.until(|_| true).await.clone();
        if l["console"]["jog"]["active"].is_null() && !l["console"]["jog"]["last_end"].is_null() {
            break l;
        }
        f.next().await;
    };
    assert!(
        live["console"]["jog"]["last_end"].as_str().unwrap().len() > 3,
        "{live}"
    );
    f.until(|l| !l["console"]["jog"]["refuses"].is_null()).await;
    f.ws.send(
        json!({"type": "jog", "robot": "press-loader", "axis": "x", "positive": true, "seq": 100}),
    )
    .await;
    let e = loop {
        let m = f.next().await.unwrap();
        if m["type"] == "error" {
            break m;
        }
    };
    assert!(e["error"].as_str().unwrap().contains("jog refused"), "{e}");
    rig.mock.with(|m| m.set_estop_open(false));
    let cleared = op.robot("POST", "clear-fault", None).await;
    assert_eq!(cleared.status, StatusCode::OK, "{:?}", cleared.json);
    rig.stop().await;
}

#[tokio::test]
async fn jogging_is_refused_until_homed_and_while_a_cycle_runs() {
    let rig = rig(None).await;
    let (op, mut f) = operator_with_seat(&rig).await;
    let run = op
        .robot(
            "POST",
            "cycles",
            Some(&json!({"program": "press-load", "count": 1})),
        )
        .await;
    assert_eq!(run.status, StatusCode::ACCEPTED, "{:?}", run.json);
    f.until(|l| {
        l["console"]["jog"]["refuses"]
            .as_str()
            .is_some_and(|r| r.contains("cycle"))
    })
    .await;
    f.ws.send(
        json!({"type": "jog", "robot": "press-loader", "axis": "z", "positive": true, "seq": 1}),
    )
    .await;
    let e = loop {
        let m = f.next().await.unwrap();
        if m["type"] == "error" {
            break m;
        }
    };
    assert!(e["error"].as_str().unwrap().contains("cycle"), "{e}");
    let stop = op
        .robot("POST", "cycles/stop", Some(&json!({"now": true})))
        .await;
    assert_eq!(stop.status, StatusCode::OK, "{:?}", stop.json);
    rig.mock.with(linterpd::mock::MockPlc::power_cycle);
    f.until(|l| {
        l["console"]["jog"]["refuses"]
            .as_str()
            .is_some_and(|r| r.contains("homed"))
    })
    .await;
    rig.stop().await;
}

#[tokio::test]
async fn a_viewer_sees_and_stops_an_operator_needs_the_seat_and_an_admin_deletes() {
    let rig = rig(None).await;
    let viewer = Browser::logged_in(rig.addr, "viewer").await;
    let order = json!({"by": [0, 0, 5]});
    let r = viewer.robot("POST", "moves", Some(&order)).await;
    assert_eq!(r.status, StatusCode::FORBIDDEN);
    assert_eq!(r.json["reason"], "role");
    assert_eq!(
        r.json["error"],
        "user viewer is a viewer: moving the robot needs the operator role"
    );
    assert_eq!(
        viewer.robot("POST", "stop", None).await.status,
        StatusCode::OK
    );
    assert_eq!(
        viewer
            .call("GET", "/v1/robots/press-loader", None)
            .await
            .status,
        StatusCode::OK
    );

    let op = Browser::logged_in(rig.addr, "operator").await;
    let r = op.robot("POST", "moves", Some(&order)).await;
    assert_eq!(
        (r.status, r.json["reason"].as_str()),
        (StatusCode::FORBIDDEN, Some("seat"))
    );
    let (op, _f) = operator_with_seat(&rig).await;
    let r = op.robot("POST", "moves", Some(&order)).await;
    assert_eq!(r.status, StatusCode::ACCEPTED, "{:?}", r.json);
    let id = r.json["id"].as_u64().unwrap();
    rig.handle.wait(id, LIMIT).await.unwrap();
    let r = op.robot("PUT", "positions/here", None).await;
    assert_eq!(r.status, StatusCode::OK, "{:?}", r.json);
    let r = op.robot("DELETE", "positions/here", None).await;
    assert_eq!(
        (r.status, r.json["reason"].as_str()),
        (StatusCode::FORBIDDEN, Some("role"))
    );
    let admin = Browser::logged_in(rig.addr, "admin").await;
    let mut a = Follower::open(&admin).await;
    a.ws.send(json!({"type": "take-seat", "robot": "press-loader"}))
        .await;
    a.until(|l| l["console"]["seat"]["user"] == "admin").await;
    let r = admin.robot("DELETE", "positions/here", None).await;
    assert_eq!(r.status, StatusCode::OK, "{:?}", r.json);
    rig.stop().await;
}

#[tokio::test]
async fn no_session_a_foreign_origin_or_too_many_failed_logins_are_refused() {
    let rig = rig(None).await;
    let anonymous = Browser::new(rig.addr);
    let r = anonymous.call("GET", "/v1/robots/press-loader", None).await;
    assert_eq!(
        (r.status, r.json["reason"].as_str()),
        (StatusCode::UNAUTHORIZED, Some("login"))
    );
    let r = anonymous.robot("POST", "stop", None).await;
    assert_eq!(r.status, StatusCode::UNAUTHORIZED);
    assert_eq!(anonymous.ws().await.err(), Some(401));

    let op = Browser::logged_in(rig.addr, "operator").await;
    let r = op.call("GET", "/console/session", None).await;
    assert_eq!(r.json, json!({"user": "operator", "role": "operator"}));
    let mut evil = op.clone();
    evil.origin = Some("http://evil.example".into());
    let r = evil.robot("POST", "stop", None).await;
    assert_eq!(
        (r.status, r.json["reason"].as_str()),
        (StatusCode::FORBIDDEN, Some("origin"))
    );
    assert!(
        r.json["error"]
            .as_str()
            .unwrap()
            .contains("http://evil.example")
    );
    // A GET changes nothing: the page's own cookie reads from anywhere it is sent.
    assert_eq!(
        evil.call("GET", "/v1/robots/press-loader", None)
            .await
            .status,
        StatusCode::OK
    );
    assert_eq!(evil.ws().await.err(), Some(403));
    let mut bare = op.clone();
    bare.origin = None;
    assert_eq!(
        bare.robot("POST", "stop", None).await.status,
        StatusCode::FORBIDDEN
    );
    assert_eq!(bare.ws().await.err(), Some(403));

    // The cookie: HttpOnly, SameSite=Strict.
    let mut fresh = Browser::new(rig.addr);
    let r = fresh.login("viewer", "viewer-demo").await;
    let cookie = r.set_cookie.unwrap();
    assert!(
        cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
        "{cookie}"
    );
    let r = fresh.call("POST", "/console/logout", None).await;
    assert_eq!(r.status, StatusCode::OK);
    assert_eq!(
        fresh
            .call("GET", "/v1/robots/press-loader", None)
            .await
            .status,
        StatusCode::UNAUTHORIZED
    );
    let mut guesser = Browser::new(rig.addr);
    for k in 0..5 {
        let r = guesser.login("admin", &format!("guess-{k}")).await;
        assert_eq!(r.status, StatusCode::UNAUTHORIZED);
        assert_eq!(r.json["error"], "wrong user or password");
    }
    // Even the right password, from this address: the limit holds until the window passes.
    let r = guesser.login("admin", "admin-demo").await;
    assert_eq!(r.status, StatusCode::TOO_MANY_REQUESTS, "{:?}", r.json);
    assert!(
        r.json["error"]
            .as_str()
            .unwrap()
            .starts_with("too many failed logins")
    );
    rig.stop().await;
}

#[tokio::test]
async fn the_speed_override_plans_every_later_move_at_its_share() {
    let rig = rig(None).await;
    let (op, _f) = operator_with_seat(&rig).await;
    let r = op
        .robot("PUT", "speed-override", Some(&json!({"percent": 0})))
        .await;
    assert_eq!(r.status, StatusCode::BAD_REQUEST);
    assert_eq!(r.json["field"], "percent");
    assert!(
        r.json["error"]
            .as_str()
            .unwrap()
            .contains("within 1 to 100")
    );
    let order = json!({"by": [0, 0, 30], "speed_mm_s": 100});
    let full = op.robot("POST", "moves", Some(&order)).await;
    let full = rig
        .handle
        .wait(full.json["id"].as_u64().unwrap(), LIMIT)
        .await
        .unwrap();
    let r = op
        .robot("PUT", "speed-override", Some(&json!({"percent": 50})))
        .await;
    assert_eq!(r.json, json!({"percent": 50}));
    let back = json!({"by": [0, 0, -30], "speed_mm_s": 100});
    let half = op.robot("POST", "moves", Some(&back)).await;
    let half = rig
        .handle
        .wait(half.json["id"].as_u64().unwrap(), LIMIT)
        .await
        .unwrap();
    let (a, b) = (
        full.predicted.unwrap().duration_s,
        half.predicted.unwrap().duration_s,
    );
    // 30 mm at 100 and at 50 mm/s, each with its 0.2 s ramps: 0.3 + 0.2 s, and 0.6 + 0.2 s.
    assert!(
        (a - 0.5).abs() < 0.02 && (b - 0.8).abs() < 0.02,
        "{a} s at 100 %, {b} s at 50 %"
    );
    assert_eq!(rig.handle.state().phase, RobotPhase::Idle);
    rig.stop().await;
}

#[tokio::test]
async fn status_watch_prints_a_line_at_each_change_from_the_stream() {
    use std::io::{BufRead as _, BufReader};
    let shared = crate::common::exchange::mock_at_seed_start("");
    let dir = crate::common::process::TempDir::new("watch");
    let s = crate::common::served::Served::start(&shared, None, dir.path(), "api.sock").await;
    let socket = dir.path().join("api.sock");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(["status", "--watch", "--socket"])
        .arg(&socket)
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    std::thread::spawn(move || {
        for line in lines {
            if tx.send(line.unwrap()).is_err() {
                return;
            }
        }
    });
    let first = tokio::time::timeout(LIMIT, rx.recv())
        .await
        .unwrap()
        .unwrap();
    assert!(first.starts_with("press-loader: idle; link up"), "{first}");
    let id = s
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, 0.0, 20.0]),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let mut seen = Vec::new();
    loop {
        let line = tokio::time::timeout(LIMIT, rx.recv())
            .await
            .unwrap()
            .unwrap();
        let done = line.starts_with("press-loader: idle;")
            && seen.iter().any(|l: &String| l.contains("running"));
        seen.push(line);
        if done {
            break;
        }
    }
    assert!(
        seen.iter()
            .any(|l| l.contains(&format!("move {id} running"))),
        "{seen:#?}"
    );
    let _ = child.kill();
    let _ = child.wait();
}
