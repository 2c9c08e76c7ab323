//! Jogs, joint moves and taught positions, end to end in process: the daemon on the mock PLC, its
//! API on a Unix socket in a temp dir, its positions in a temp state directory.

use crate::common;

use common::exchange::{P1, P2, mock_at_seed_start};
use common::process::TempDir;
use common::served::{LIMIT, ROBOT, Served};
use hyper::StatusCode;
use linterpd::daemon::{MoveOrder, MoveReport, RobotHandle, Stage, TaughtPositions};
use linterpd::geometry::Pose;
use linterpd::kinematics::{JOINTS, Kinematics};
use linterpd::order::OrderMotion;
use linterpd::robot::seed_robot;
use serde_json::json;

/// Done, on exactly its target counts.
fn assert_exactly_on_target(r: &MoveReport) {
    assert_eq!(r.stage, Stage::Done, "{r:?}");
    assert_eq!(r.final_error_pulses, Some([0; 4]), "{r:?}");
}

/// The seed robot's counts (joint j on channel j) nearest `pose`, near `from`'s joint values.
fn counts_at(pose: &Pose, from: [i64; JOINTS]) -> [i64; JOINTS] {
    let robot = seed_robot();
    let q = robot
        .kinematics
        .ik(pose, Some(&robot.values_of(&from)))
        .unwrap();
    robot.counts_of(&q)
}

fn counts_now(h: &RobotHandle) -> [i64; JOINTS] {
    h.state().counts.unwrap()
}

#[tokio::test]
async fn a_jog_ends_on_its_offset_and_a_queued_jog_is_relative_to_the_one_before() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("jog");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    let start = counts_now(&s.handle);
    let robot = seed_robot();
    let from = robot.pose_of(&start);

    let r = s.run(&json!({"by": [10.0, -20.0, 15.0]})).await;
    assert_exactly_on_target(&r);
    let mut there = from;
    there.position_mm += nalgebra::Vector3::new(10.0, -20.0, 15.0);
    let want = counts_at(&there, start);
    assert_eq!(r.target_counts, Some(want));
    assert_eq!(counts_now(&s.handle), want);
    assert_eq!(r.order.by, Some(vec![10.0, -20.0, 15.0]));

    // Out and back queued at once: the second is anchored where the first is planned to end,
    // so the pair ends where it began, whatever the first's start saw.
    let out = s
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, 30.0, -10.0, 20.0]),
            motion: OrderMotion {
                speed_mm_s: Some(60.0),
                ..OrderMotion::default()
            },
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let back = s
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, -30.0, 10.0, -20.0]),
            motion: OrderMotion {
                speed_mm_s: Some(60.0),
                ..OrderMotion::default()
            },
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let rb = s.handle.wait(back, LIMIT).await.unwrap();
    assert_eq!(s.handle.report(out).unwrap().stage, Stage::Done);
    assert_exactly_on_target(&rb);
    assert_eq!(rb.target_counts, Some(want));
    assert_eq!(counts_now(&s.handle), want);

    // A jog that would leave a joint's limits is refused, naming the joint; nothing is queued.
    let e = s
        .handle
        .submit(MoveOrder {
            by: Some(vec![0.0, 0.0, 500.0]),
            ..MoveOrder::default()
        })
        .await
        .unwrap_err();
    assert!(e.to_string().starts_with("joint d2 would reach"), "{e}");
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn a_joint_move_ends_on_its_joint_targets_by_either_method() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("joints");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    // theta1 70 deg, d2 120 mm, d3 650 mm, wrist 10 deg: counts at 0.0025 deg, 0.025 mm,
    // 0.013 mm and 0.0025 deg a pulse.
    let want = [28_000, 4_800, 50_000, 4_000];
    let r = s.run(&json!({"joints": [70.0, 120.0, 650.0, 10.0]})).await;
    assert_exactly_on_target(&r);
    assert_eq!(r.target_counts, Some(want));
    assert_eq!(counts_now(&s.handle), want);

    let back = counts_at(
        &seed_robot()
            .pose_with_wrist_at_zero(P1[0], P1[1], P1[2])
            .unwrap(),
        want,
    );
    let user: Vec<f64> = (0..JOINTS)
        .map(|j| {
            let joint = &seed_robot().joints[j];
            joint.user(joint.value_of(back[j]))
        })
        .collect();
    let r = s
        .run(&json!({"joints": user, "tolerance_mm": 0.1, "speed_mm_s": 150}))
        .await;
    assert_exactly_on_target(&r);
    assert_eq!(r.target_counts, Some(back));
    let predicted = r.predicted.unwrap();
    assert!(predicted.path_deviation_mm <= 0.1, "{predicted:?}");

    // Beyond a limit: 422 naming the joint and its limits, nothing queued.
    let answer = s
        .api
        .post(
            &format!("{ROBOT}/moves"),
            &json!({"joints": [70.0, 120.0, 1_200.0, 10.0]}).to_string(),
        )
        .await;
    assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(
        answer.json()["error"],
        "joint d3 target 1200.0000 mm is beyond its limits 0 to 1000 mm"
    );
    let answer = s
        .api
        .post(&format!("{ROBOT}/moves"), r#"{"joints": [1, 2, 3]}"#)
        .await;
    assert_eq!(answer.status, StatusCode::BAD_REQUEST);
    assert_eq!(answer.json()["field"], "joints");
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn positions_are_saved_listed_shown_deleted_and_moved_to() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("teach");
    let state = TempDir::new("teach-state");
    let s = Served::start(&shared, Some(state.path()), dir.path(), "api.sock").await;
    let at_p1 = counts_now(&s.handle);

    let saved = s.call("PUT", "positions/pick").await;
    assert_eq!(saved.status, StatusCode::OK, "{}", saved.text());
    let saved = saved.json();
    assert_eq!(saved["name"], "pick");
    assert_eq!(saved["replaced"], false);
    assert_eq!(saved["joint_counts"], json!(at_p1));
    let pose = seed_robot().pose_of(&at_p1).to_mm_deg();
    for (i, v) in pose.iter().enumerate() {
        // serde_json reads floats to within an ulp.
        assert!(
            (saved["pose"][i].as_f64().unwrap() - v).abs() < 1e-9,
            "{saved}"
        );
    }
    assert!(saved.get("warning").is_none(), "{saved}");
    assert_eq!(
        s.call("POST", "positions/pick").await.json()["replaced"],
        true
    );

    assert_exactly_on_target(&s.run(&json!({"to": P2})).await);
    let at_p2 = counts_now(&s.handle);
    assert_ne!(at_p2, at_p1);
    assert_eq!(
        s.call("PUT", "positions/place").await.status,
        StatusCode::OK
    );

    let list = s.call("GET", "positions").await.json();
    let names: Vec<&str> = list["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["pick", "place"]);
    let shown = s.call("GET", "positions/place").await.json();
    assert_eq!(shown["joint_counts"], json!(at_p2));

    // To the taught position: on exactly the counts it was taught at.
    let r = s.run(&json!({"position": "pick"})).await;
    assert_exactly_on_target(&r);
    assert_eq!(r.target_counts, Some(at_p1));
    assert_eq!(counts_now(&s.handle), at_p1);

    // Names, unknown positions, deleting.
    let bad = s.call("PUT", "positions/-x").await;
    assert_eq!(bad.status, StatusCode::BAD_REQUEST);
    assert_eq!(bad.json()["field"], "position");
    let missing = s.call("GET", "positions/drop").await;
    assert_eq!(missing.status, StatusCode::NOT_FOUND);
    assert_eq!(
        missing.json()["error"],
        "no position \"drop\" for robot press-loader; positions: pick, place"
    );
    let deleted = s.call("DELETE", "positions/place").await;
    assert_eq!(deleted.status, StatusCode::OK);
    assert_eq!(deleted.json()["deleted"]["name"], "place");
    assert_eq!(
        s.call("DELETE", "positions/place").await.status,
        StatusCode::NOT_FOUND
    );
    let answer = s
        .api
        .post(&format!("{ROBOT}/moves"), r#"{"position": "place"}"#)
        .await;
    assert_eq!(answer.status, StatusCode::BAD_REQUEST, "{}", answer.text());
    assert_eq!(
        answer.json()["error"],
        "position = \"place\": no such position; taught positions: pick"
    );

    // Not while a move runs: its pose is no position.
    let id = s
        .handle
        .submit(MoveOrder {
            to: Some(P2.to_vec()),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let busy = s.call("PUT", "positions/mid").await;
    assert_eq!(busy.status, StatusCode::CONFLICT, "{}", busy.text());
    assert_eq!(busy.json()["reason"], "busy");
    s.handle.wait(id, LIMIT).await.unwrap();
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn positions_survive_a_daemon_restart() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("restart");
    let state = TempDir::new("restart-state");
    let first = Served::start(&shared, Some(state.path()), dir.path(), "first.sock").await;
    let at_p1 = counts_now(&first.handle);
    assert_eq!(
        first.call("PUT", "positions/home-1").await.status,
        StatusCode::OK
    );
    assert_exactly_on_target(&first.run(&json!({"to": P2})).await);
    first.daemon.kill().await;

    let second = Served::start(&shared, Some(state.path()), dir.path(), "second.sock").await;
    let list = second.call("GET", "positions").await.json();
    assert_eq!(list["positions"][0]["name"], "home-1", "{list}");
    assert_eq!(list["positions"][0]["joint_counts"], json!(at_p1));
    assert!(list.get("warning").is_none(), "{list}");
    let r = second.run(&json!({"position": "home-1"})).await;
    assert_exactly_on_target(&r);
    assert_eq!(counts_now(&second.handle), at_p1);
    second.daemon.shut_down().await;
}

#[tokio::test]
async fn a_corrupt_positions_file_is_refused_kept_aside_and_the_daemon_runs_on() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("corrupt");
    let state = TempDir::new("corrupt-state");
    let garbage = "{\"linterpd_positions\": 1, \"robots\": {\"press-loader\": {\"pick\": [";
    std::fs::write(state.path().join("positions.json"), garbage).unwrap();
    let s = Served::start(&shared, Some(state.path()), dir.path(), "api.sock").await;

    let list = s.call("GET", "positions").await;
    assert_eq!(list.status, StatusCode::OK);
    let list = list.json();
    assert_eq!(list["positions"], json!([]));
    let warning = list["warning"].as_str().unwrap();
    assert!(
        warning.contains("positions.json is corrupt: ")
            && warning.contains("kept aside as ")
            && warning.contains("started with no positions"),
        "{warning}"
    );
    let aside: Vec<_> = std::fs::read_dir(state.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("positions.json.corrupt-")
        })
        .collect();
    assert_eq!(aside.len(), 1, "{aside:?}");
    assert_eq!(std::fs::read_to_string(&aside[0]).unwrap(), garbage);
    assert!(
        warning.contains(&aside[0].display().to_string()),
        "{warning}"
    );

    // The daemon runs on: it moves, and it teaches into a fresh file.
    assert_exactly_on_target(&s.run(&json!({"to": P2})).await);
    let saved = s.call("PUT", "positions/pick").await;
    assert_eq!(saved.status, StatusCode::OK);
    assert!(saved.json()["warning"].as_str().is_some());
    s.daemon.shut_down().await;
    let again = TaughtPositions::in_state_dir(state.path());
    assert!(again.warning().is_none());
    assert_eq!(again.of("press-loader").len(), 1);
}

/// The pose `offset` mm from P1, the tool angle 0.
fn near_p1(offset: [f64; 3]) -> Vec<f64> {
    vec![P1[0] + offset[0], P1[1] + offset[1], P1[2] + offset[2]]
}

#[tokio::test]
async fn a_position_kept_in_a_frame_moves_with_the_frames_points_when_they_are_taught_again() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("frame-teach");
    let frame: linterpd::pallet::doc::FrameDoc = toml::from_str(
        r#"origin = "@o"
x_point = "@x"
xy_point = "@xy""#,
    )
    .unwrap();
    let mut set = linterpd::pallet::RobotPallets::default();
    set.add_frame("station", &frame).unwrap();
    let options = linterpd::daemon::DaemonOptions {
        pallets: std::sync::Arc::new(linterpd::daemon::pallets::Pallets {
            sets: [("press-loader".to_owned(), set)].into(),
            counters: linterpd::daemon::pallets::PalletCounters::in_memory(),
        }),
        ..linterpd::daemon::DaemonOptions::default()
    };
    let connect = common::daemon::duplex_connector(&shared, None);
    let s = Served::start_with(connect, &shared, &options, dir.path(), "api.sock").await;
    // Teaches the frame's three points `shift` mm along x from P1.
    let teach_frame = |shift: f64| {
        let s = &s;
        async move {
            for (name, at) in [
                ("o", [shift, 0.0, 0.0]),
                ("x", [shift + 100.0, 0.0, 0.0]),
                ("xy", [shift, 100.0, 0.0]),
            ] {
                assert_exactly_on_target(&s.run(&json!({"to": near_p1(at)})).await);
                let saved = s.call("PUT", &format!("positions/{name}")).await;
                assert_eq!(saved.status, StatusCode::OK, "{}", saved.text());
            }
        }
    };
    teach_frame(0.0).await;
    // The grip taught 30 mm along the frame's x, 40 along its y, 20 up from its origin.
    assert_exactly_on_target(&s.run(&json!({"to": near_p1([30.0, 40.0, 20.0])})).await);
    let saved = s.call("PUT", "positions/grip?frame=station").await;
    assert_eq!(saved.status, StatusCode::OK, "{}", saved.text());
    let saved = saved.json();
    assert_eq!(saved["frame"], "station", "{saved}");
    for (i, want) in [30.0, 40.0, 20.0].iter().enumerate() {
        let got = saved["pose"][i].as_f64().unwrap();
        // Within the pulse grid: the pose is the one the counts stand at.
        assert!((got - want).abs() < 0.05, "{saved}");
    }
    // The frame taught again 25 mm further along x: the grip moves with it.
    teach_frame(25.0).await;
    let r = s.run(&json!({"position": "grip"})).await;
    assert_exactly_on_target(&r);
    // The frame is only shifted: the grip stands 25 mm further along x, its tool angle the
    // one it was taught at, within the pulse grid (the frame's points and the grip were each
    // taught on the grid).
    let taught_a = saved["pose"][3].as_f64().unwrap();
    let now = seed_robot().pose_of(&counts_now(&s.handle)).to_mm_deg();
    let want = [P1[0] + 55.0, P1[1] + 40.0, P1[2] + 20.0, taught_a];
    for i in 0..4 {
        assert!(
            (now[i] - want[i]).abs() < 0.1,
            "at {now:?}, expected {want:?}"
        );
    }
    // A frame the config does not have: refused, naming the frames there are.
    let bad = s.call("PUT", "positions/other?frame=die").await;
    assert_eq!(bad.status, StatusCode::BAD_REQUEST, "{}", bad.text());
    assert_eq!(bad.json()["field"], "frame");
    assert!(
        bad.json()["error"]
            .as_str()
            .unwrap()
            .contains("the frames defined are station"),
        "{}",
        bad.text()
    );
    s.daemon.shut_down().await;
}
