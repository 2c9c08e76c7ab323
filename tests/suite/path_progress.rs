//! A path's progress through the daemon follows the counts read from the PLC, not the clock:
//! every report of a running part pairs its `progress` with the counts it was computed from, and
//! the part's plan, at that share of its duration, has the robot at those counts.

use crate::common;

use common::exchange::{P1, P2, mock_at_seed_start};
use common::process::TempDir;
use common::served::{LIMIT, Served};
use linterpd::daemon::{MoveReport, Stage};
use linterpd::geometry::{Corner, Element, Pose};
use linterpd::plan::{Origin, PathRequest, Plan, plan_path};
use linterpd::robot::{Method, seed_robot};
use serde_json::json;

/// How far, in sample points of 1 ms, the planned counts are searched around the instant the
/// progress names.
const WINDOW_POINTS: usize = 5;
/// Pulses of slack on either side (rounding of the thinned progress curve).
const SLACK_PULSES: i64 = 2;

#[tokio::test]
async fn a_running_parts_progress_names_the_planned_instant_of_the_counts_it_was_read_with() {
    // Every exchange 40 ms late: the counts a report carries are 40 ms old when it is made,
    // so progress by the clock would run about 40 ms ahead of them.
    let shared = mock_at_seed_start("delay40@100%");
    let dir = TempDir::new("path-progress");
    let s = Served::start(&shared, None, dir.path(), "api.sock").await;
    let start = s.handle.state().counts.unwrap();
    let a_deg = seed_robot().pose_of(&start).a_rad.to_degrees();
    let up = [P1[0], P1[1], P1[2] + 100.0];
    let above = [P2[0], P2[1], P2[2] + 100.0];
    let body = json!({
        "path": {
            "start": P1,
            "path_accel": "5000mm/s2",
            "element": [
                {"line": up, "blend": "20mm"},
                {"line": above, "blend": "20mm"},
                {"line": P2, "stop": true},
            ]
        },
        "tolerance_mm": 0.05
    });
    // The same path planned here, from the same counts: the daemon's plans, part by part.
    let robot = seed_robot();
    let pose = |p: [f64; 3]| Pose::from_mm_deg(p[0], p[1], p[2], a_deg);
    let req = PathRequest {
        from: Origin::Counts(start),
        start: None,
        elements: vec![
            (Element::Line { to: pose(up) }, Corner::Blend(20.0)),
            (Element::Line { to: pose(above) }, Corner::Blend(20.0)),
            (Element::Line { to: pose(P2) }, Corner::Stop),
        ],
        motion: linterpd::robot::Motion {
            method: Method::BoundedError { tolerance_mm: 0.05 },
            ..robot.motion
        },
        path_accel_mm_s2: 5_000.0,
    };
    let planned = plan_path(&robot, &req).unwrap();
    let plans: Vec<&Plan> = planned.starts().collect();

    let ids = s.post_path(&body).await;
    assert_eq!(
        ids.len(),
        plans.len(),
        "the daemon cut the path as planned here"
    );
    // Every report of every part, as it changes.
    let watchers: Vec<_> = ids
        .iter()
        .map(|&id| {
            let mut rx = s.handle.subscribe(id).unwrap();
            tokio::spawn(async move {
                let mut seen: Vec<MoveReport> = vec![rx.borrow_and_update().clone()];
                while rx.changed().await.is_ok() {
                    let r = rx.borrow_and_update().clone();
                    let end = matches!(
                        r.stage,
                        Stage::Done | Stage::Failed | Stage::Stopped | Stage::Cancelled
                    );
                    seen.push(r);
                    if end {
                        break;
                    }
                }
                seen
            })
        })
        .collect();
    for &id in &ids {
        let report = s.handle.wait(id, LIMIT).await.unwrap();
        assert_eq!(report.stage, Stage::Done, "{report:?}");
    }
    let mut checked = 0;
    for (k, (watcher, plan)) in watchers.into_iter().zip(&plans).enumerate() {
        let seen = watcher.await.unwrap();
        let last = &seen[seen.len() - 1];
        // The daemon's plan is this one.
        let predicted = last.predicted.as_ref().unwrap();
        assert!(
            (predicted.duration_s - plan.duration_s()).abs() < 1e-9,
            "part {}: {} s here, {} s in the daemon",
            k + 1,
            plan.duration_s(),
            predicted.duration_s
        );
        assert_eq!(last.start_counts, Some(plan.start_counts()));
        checked += check_running(k, plan, &seen);
    }
    assert!(checked >= 5, "only {checked} running reports checked");
    s.daemon.shut_down().await;
}

/// Checks every report of running part `k` (from 0) in `seen` against its `plan`: progress never
/// goes back, and the plan at that share of its duration has the robot at the counts read.
/// Returns how many reports it checked.
fn check_running(k: usize, plan: &Plan, seen: &[MoveReport]) -> usize {
    let mut checked = 0;
    let mut before = 0.0;
    for r in seen.iter().filter(|r| r.stage == Stage::Running) {
        let Some(counts) = r.counts else { continue };
        assert!(r.progress >= before, "part {}: progress went back", k + 1);
        before = r.progress;
        let samples = &plan.samples.counts;
        let at = (r.progress * plan.duration_s() / 0.001).round() as usize;
        let window = &samples
            [at.saturating_sub(WINDOW_POINTS)..=(at + WINDOW_POINTS).min(samples.len() - 1)];
        for j in 0..4 {
            let lo = window.iter().map(|c| c[j]).min().unwrap() - SLACK_PULSES;
            let hi = window.iter().map(|c| c[j]).max().unwrap() + SLACK_PULSES;
            assert!(
                (lo..=hi).contains(&counts[j]),
                "part {}: progress {:.4} puts channel {j} at {lo}..={hi}, the PLC read {}",
                k + 1,
                r.progress,
                counts[j]
            );
        }
        checked += 1;
    }
    checked
}
