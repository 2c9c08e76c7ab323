//! A path as the daemon's first motion, against the mock PLC (on paused time, so the daemon's
//! first status reads come before the mock's second scan, every run): the path is built from
//! where the PLC says the robot is when it is submitted, not from counts read before, and
//! runs to its target; one stated to start away from the robot is refused, naming how far.
//!
//! Regression: the mock's power-up scan writes its status block before the test presets the
//! robot's counts (at P1), and the daemon read that block at connect. A move is planned again
//! from the PLC's counts when its turn comes and ran; a path's course was built from those
//! old counts (a pose 928.585 mm from P1) and its first section was refused when its turn came.

use crate::common;

use std::time::Duration;

use common::daemon::{duplex_connector, spawn, taking_moves};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::daemon::{Daemon, MoveOrder, PathOrder, RobotHandle, Stage};
use linterpd::kinematics::JOINTS;
use linterpd::mock::SharedMock;
use linterpd::order::OrderMotion;
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;
use nalgebra::Vector3;
use serde_json::json;

const LIMIT: Duration = Duration::from_secs(30);

fn above(p: [f64; 3], mm: f64) -> [f64; 3] {
    [p[0], p[1], p[2] + mm]
}

/// Where the mock's channels stand, per joint (the seed robot: joint j on channel j).
fn plc_counts(shared: &SharedMock) -> [i64; JOINTS] {
    shared.with(|m| std::array::from_fn(|c| m.count(c)))
}

/// A daemon on `shared`, taking moves.
async fn daemon_on(shared: &SharedMock) -> (Daemon, RobotHandle) {
    let (d, h) = spawn(duplex_connector(shared, None), ContractSettings::default());
    taking_moves(&h).await;
    (d, h)
}

/// Up 100 mm from P1, across to 100 mm above P2 and down to P2, the two corners blended;
/// `start`: the path's stated start, if any.
fn pick_and_place(start: Option<[f64; 3]>) -> PathOrder {
    let mut path = json!({
        "path_accel": "5000mm/s2",
        "element": [
            {"line": above(P1, 100.0), "blend": "20mm"},
            {"line": above(P2, 100.0), "blend": "20mm"},
            {"line": P2},
        ]
    });
    if let Some(start) = start {
        path["start"] = json!(start);
    }
    PathOrder {
        path,
        motion: OrderMotion {
            tolerance_mm: Some(0.05),
            ..OrderMotion::default()
        },
        ..PathOrder::default()
    }
}

/// Runs `order` and checks it ended done on P2, every start from the counts it was planned
/// from.
async fn runs_to_p2(shared: &SharedMock, h: &RobotHandle, order: &PathOrder) {
    let ids = h.submit_path(order).await.unwrap();
    for id in &ids {
        let report = h.wait(*id, LIMIT).await.unwrap();
        assert_eq!(report.stage, Stage::Done, "{report:?}");
    }
    let at = seed_robot().pose_of(&plc_counts(shared)).position_mm;
    let off_mm = (at - Vector3::from(P2)).norm();
    assert!(off_mm < 0.05, "ended {off_mm} mm from P2");
    assert_eq!(h.state().counts, Some(plc_counts(shared)));
    let starts = shared.with(|m| m.starts().to_vec());
    assert!(!starts.is_empty());
    assert!(starts.iter().all(|st| !st.from_mismatch()), "{starts:?}");
}

/// The daemon still holds the block the mock wrote at power-up, before the robot's counts were
/// preset: the case these tests are about.
fn holds_the_power_up_block(shared: &SharedMock, h: &RobotHandle) {
    assert_ne!(
        h.state().counts,
        Some(plc_counts(shared)),
        "the daemon read the mock's counts already: this test no longer sets up its case"
    );
}

#[tokio::test(start_paused = true)]
async fn a_path_as_the_daemons_first_motion_runs_from_where_the_plc_says_the_robot_is() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon_on(&shared).await;
    holds_the_power_up_block(&shared, &h);
    runs_to_p2(&shared, &h, &pick_and_place(None)).await;
    d.shut_down().await;
}

#[tokio::test(start_paused = true)]
async fn a_first_path_stated_to_start_where_the_robot_is_runs() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon_on(&shared).await;
    holds_the_power_up_block(&shared, &h);
    runs_to_p2(&shared, &h, &pick_and_place(Some(P1))).await;
    d.shut_down().await;
}

#[tokio::test(start_paused = true)]
async fn a_first_path_stated_to_start_away_from_the_robot_is_refused_naming_how_far() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon_on(&shared).await;
    let from = plc_counts(&shared);
    let e = h
        .submit_path(&pick_and_place(Some(P2)))
        .await
        .unwrap_err()
        .to_string();
    let off_mm = (Vector3::from(P2) - seed_robot().pose_of(&from).position_mm).norm();
    assert!(e.contains(&format!("{off_mm:.3} mm from it")), "{e}");
    assert!(e.contains("move to the path's start first"), "{e}");
    assert!(shared.with(|m| m.starts().is_empty()), "nothing starts");
    assert_eq!(plc_counts(&shared), from);
    d.shut_down().await;
}

/// A daemon restarted with the robot away from where the mock powered up (the mock keeps its
/// counts): its first motion, a path from where the robot stands, runs.
#[tokio::test(start_paused = true)]
async fn after_a_restart_away_from_home_the_first_path_runs_from_where_the_robot_stands() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon_on(&shared).await;
    let id = h
        .submit(MoveOrder {
            to: Some(above(P1, 30.0).to_vec()),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    assert_eq!(h.wait(id, LIMIT).await.unwrap().stage, Stage::Done);
    d.shut_down().await;
    let stands = plc_counts(&shared);
    let (d, h) = daemon_on(&shared).await;
    // Up to 100 mm above P1 from 30 mm above it, stated: the robot stands there.
    runs_to_p2(&shared, &h, &pick_and_place(Some(above(P1, 30.0)))).await;
    assert_ne!(stands, plc_counts(&shared));
    d.shut_down().await;
}
