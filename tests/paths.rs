//! Paths through the daemon, end to end in process: `POST .../paths` on the mock PLC, every
//! section planned before anything moves, one move per section chained by the PLC.

mod common;

use common::exchange::{P1, P2, mock_at_seed_start};
use common::process::TempDir;
use common::served::{LIMIT, ROBOT, Served};
use hyper::StatusCode;
use linterpd::daemon::{PathOrder, Stage};
use linterpd::geometry::Pose;
use linterpd::kinematics::{JOINTS, Kinematics};
use linterpd::robot::seed_robot;
use serde_json::json;

/// The seed robot's counts at `xyz` with the tool at `a_rad`.
fn counts_at(xyz: [f64; 3], a_rad: f64) -> [i64; JOINTS] {
    let robot = seed_robot();
    let pose = Pose {
        position_mm: xyz.into(),
        a_rad,
    };
    robot.counts_of(&robot.kinematics.ik(&pose, None).unwrap())
}

#[tokio::test]
async fn a_path_with_a_blend_and_a_stop_runs_its_sections_in_order_and_ends_on_target() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("paths");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    // The path keeps the tool's angle where it starts.
    let a_rad = seed_robot()
        .pose_of(&s.handle.state().counts.unwrap())
        .a_rad;
    let above = [P2[0], P2[1], P2[2] + 100.0];
    // Up and across to above P2 (blended into the descent), down to P2, stop, back up 50 mm.
    let body = json!({
        "path": {
            "start": [P1[0], P1[1], P1[2]],
            "path_accel": "5000mm/s2",
            "element": [
                {"line": above, "blend": "20mm"},
                {"line": P2, "stop": true},
                {"line": [P2[0], P2[1], P2[2] + 50.0]},
            ]
        },
        "tolerance_mm": 0.05
    });
    let answer = s
        .api
        .post(&format!("{ROBOT}/paths"), &body.to_string())
        .await;
    assert_eq!(answer.status, StatusCode::ACCEPTED, "{}", answer.text());
    let ids: Vec<u64> = answer.json()["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(ids.len(), 2, "two sections: before and after the stop");
    let first = s.handle.wait(ids[0], LIMIT).await.unwrap();
    let second = s.handle.wait(ids[1], LIMIT).await.unwrap();
    assert_eq!(first.stage, Stage::Done, "{first:?}");
    assert_eq!(second.stage, Stage::Done, "{second:?}");
    // The second section was chained behind the first, from the first's targets.
    assert_eq!(first.target_counts, Some(counts_at(P2, a_rad)));
    assert_eq!(second.start_counts, first.target_counts);
    assert_eq!(second.final_error_pulses, Some([0; 4]), "{second:?}");
    let top = counts_at([P2[0], P2[1], P2[2] + 50.0], a_rad);
    assert_eq!(second.target_counts, Some(top));
    assert_eq!(s.handle.state().counts, Some(top));
    // The mock started each table from exactly the counts it was planned from.
    let starts = shared.with(|m| m.starts().to_vec());
    assert!(!starts.is_empty());
    assert!(starts.iter().all(|st| !st.from_mismatch()), "{starts:?}");
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn a_path_that_cannot_run_is_refused_whole_and_nothing_moves() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("paths-refused");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    let before = s.handle.state().counts;
    let refuse = |body: serde_json::Value| {
        let order: PathOrder = serde_json::from_value(body).unwrap();
        s.handle.submit_path(&order).unwrap_err().to_string()
    };
    // A start the robot is not at.
    let e = refuse(json!({"path": {"start": P2, "element": [{"line": P1}]}}));
    assert!(e.contains("mm from it when the path begins"), "{e}");
    // Its second section leaves d3's limits: nothing of the first runs either.
    let e = refuse(json!({"path": {"element": [
        {"line": [P1[0], P1[1], P1[2] + 50.0]},
        {"line": [P1[0], P1[1], P1[2] + 5000.0]},
    ]}}));
    assert!(e.starts_with("path section 2 (element 2): joint"), "{e}");
    // A document that is wrong names its element and key.
    let e = refuse(json!({"path": {"element": [{"arc": P2}]}}));
    assert!(e.contains("element 1: an arc needs `via"), "{e}");
    let e = refuse(json!({"path": {"element": [{"line": "@nowhere"}]}}));
    assert!(e.contains("no taught position named 'nowhere'"), "{e}");
    assert_eq!(s.handle.state().queued, Vec::<u64>::new());
    assert_eq!(s.handle.state().counts, before);
    assert!(shared.with(|m| m.starts().is_empty()));
    s.daemon.shut_down().await;
}

/// The demo's pick and place: from P1 up 100 mm, across to 100 mm above P2, down to P2, 20 mm
/// blends; the lift leaves two joints standing still, so its section is cut into parts.
fn lift_and_place() -> serde_json::Value {
    json!({
        "path": {
            "start": [P1[0], P1[1], P1[2]],
            "path_accel": "5000mm/s2",
            "element": [
                {"line": [P1[0], P1[1], P1[2] + 100.0], "blend": "20mm"},
                {"line": [P2[0], P2[1], P2[2] + 100.0], "blend": "20mm"},
                {"line": P2, "stop": true},
            ]
        },
        "tolerance_mm": 0.05
    })
}

async fn post_path(s: &Served, body: &serde_json::Value) -> Vec<u64> {
    let answer = s
        .api
        .post(&format!("{ROBOT}/paths"), &body.to_string())
        .await;
    assert_eq!(answer.status, StatusCode::ACCEPTED, "{}", answer.text());
    answer.json()["ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

#[tokio::test]
async fn a_section_cut_into_parts_chains_them_at_speed_from_exact_counts_without_a_pause() {
    chains_at_speed("").await;
}

#[tokio::test]
async fn a_link_whose_every_exchange_takes_50_ms_still_chains_the_parts() {
    // The second part starts on five exchanges after the first is seen running (that read, its
    // block written and read back, one more status read, the start write): about 0.25 s of
    // the 0.39 s lift, 0.32 s with the pace check's margin.
    chains_at_speed("delay50@100%").await;
}

/// The lift and place over a mock with fault `script`: both parts done, the second waiting
/// behind the first and taken as it ended, from exactly its end counts.
async fn chains_at_speed(script: &str) {
    let shared = mock_at_seed_start(script);
    let dir = TempDir::new("paths-parts");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    let a_rad = seed_robot()
        .pose_of(&s.handle.state().counts.unwrap())
        .a_rad;
    let ids = post_path(&s, &lift_and_place()).await;
    assert_eq!(ids.len(), 2, "one section, cut into two parts");
    let first = s.handle.wait(ids[0], LIMIT).await.unwrap();
    let second = s.handle.wait(ids[1], LIMIT).await.unwrap();
    assert_eq!(first.stage, Stage::Done, "{first:?}");
    assert_eq!(second.stage, Stage::Done, "{second:?}");
    assert_eq!(second.start_counts, first.target_counts);
    assert_eq!(second.target_counts, Some(counts_at(P2, a_rad)));
    assert_eq!(second.final_error_pulses, Some([0; 4]), "{second:?}");
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 2, "{starts:?}");
    assert!(starts.iter().all(|st| !st.from_mismatch()), "{starts:?}");
    // The second part was waiting: the PLC took it in the scan after the first ended, at the
    // first part's planned duration (the mock plays tables to the pulse) plus at most a scan
    // or two.
    let planned_s = first.predicted.as_ref().unwrap().duration_s;
    let gap_s = starts[1].at_s - starts[0].at_s - planned_s;
    assert!(
        (-0.01..0.03).contains(&gap_s),
        "{gap_s} s between the parts"
    );
    s.daemon.shut_down().await;
}

#[tokio::test]
async fn a_section_whose_parts_cannot_chain_over_a_slow_link_is_refused_before_anything_moves() {
    // Every reply 250 ms late: even the second part's command block (its tables are written
    // before the lift begins) would take longer to write, check and start than the 0.39 s
    // lift, which would end at speed with nothing waiting. The pace the link shows while the
    // second part's tables are preloaded says so before the lift is started.
    let shared = mock_at_seed_start("delay250@100%");
    let dir = TempDir::new("paths-slow");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    let before = s.handle.state().counts;
    let ids = post_path(&s, &lift_and_place()).await;
    let first = s.handle.wait(ids[0], LIMIT).await.unwrap();
    let second = s.handle.wait(ids[1], LIMIT).await.unwrap();
    assert_eq!(first.stage, Stage::Failed, "{first:?}");
    let why = first.error.unwrap_or_default();
    assert!(
        why.contains("part 2 of 2") && why.contains("runs only 0.39 s"),
        "{why}"
    );
    assert_eq!(second.stage, Stage::Cancelled, "{second:?}");
    // Nothing was started; the robot stands where it stood.
    assert!(shared.with(|m| m.starts().is_empty()));
    assert_eq!(s.handle.state().counts, before);
    s.daemon.shut_down().await;
}
