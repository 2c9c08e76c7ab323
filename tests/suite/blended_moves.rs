//! A cycle program's consecutive move steps with `blend_mm`, run by the daemon against the mock
//! PLC: one path, the robot passing each corner within the blend but not through it, and
//! ending exactly on the last move's target.

use crate::common;

use std::time::Duration;

use common::daemon::{duplex_connector, programs_dir, spawn_in_cell, taking_moves};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::config::CellSettings;
use linterpd::daemon::CycleState;
use linterpd::gateway::GatewaySettings;
use linterpd::kinematics::JOINTS;
use linterpd::robot::seed_robot;
use nalgebra::Vector3;

const LIMIT: Duration = Duration::from_secs(20);
const BLEND_MM: f64 = 20.0;

fn above(p: [f64; 3]) -> [f64; 3] {
    [p[0], p[1], p[2] + 100.0]
}

/// From P1 up to 100 mm above it, across to 100 mm above P2, down to P2: the two corners
/// blended. The run is the daemon's first motion (`tests/suite/first_path.rs`).
fn lift_across_down() -> String {
    let step = |p: [f64; 3], blend: &str| format!("[[step]]\nmove = {{ to = {p:?} }}\n{blend}");
    let blend = format!("blend_mm = {BLEND_MM}\n");
    [
        step(above(P1), &blend),
        step(above(P2), &blend),
        step(P2, ""),
    ]
    .concat()
}

#[tokio::test]
async fn blended_moves_pass_each_corner_within_the_blend_and_end_exactly_on_the_last_target() {
    let shared = mock_at_seed_start("");
    shared.with(|m| m.record_pulses(true));
    let dir = programs_dir("blends", "corners", &[("pp", lift_across_down())]);
    let cell = CellSettings {
        programs: Some(dir),
        ..CellSettings::default()
    };
    let (d, h) = spawn_in_cell(
        duplex_connector(&shared, None),
        cell,
        GatewaySettings::default(),
    );
    taking_moves(&h).await;
    let robot = seed_robot();
    // Where the mock's channels stand (the daemon's counts may be those of the block the mock
    // wrote at power-up, before they were preset).
    let from: [i64; JOINTS] = shared.with(|m| std::array::from_fn(|c| m.count(c)));
    let s = h.run_cycle("pp", Some(1)).await.unwrap();
    assert_eq!(s.state, CycleState::Running);
    // The status names the run by its first step while it moves.
    let began = std::time::Instant::now();
    let mut named = None;
    let s = loop {
        let s = h.cycle().unwrap();
        if let Some(at) = &s.step {
            named = Some((at.step, at.does.clone()));
        }
        if s.state.is_final() {
            break s;
        }
        assert!(began.elapsed() < LIMIT, "never done: {s:?}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    };
    assert_eq!((s.state, s.done), (CycleState::Done, 1), "{s:?}");
    let (step, does) = named.expect("a step was named");
    assert_eq!(step, 1);
    assert!(does.starts_with("blended moves, steps 1 to 3: "), "{does}");
    // On P2 (within the pulse grid; the tool's angle kept), every start from the counts it
    // was planned from.
    let target = h.state().counts.unwrap();
    let off_mm = (robot.pose_of(&target).position_mm - Vector3::from(P2)).norm();
    assert!(off_mm < 0.05, "ended {off_mm} mm from P2");
    let starts = shared.with(|m| m.starts().to_vec());
    assert!(!starts.is_empty());
    assert!(starts.iter().all(|st| !st.from_mismatch()), "{starts:?}");
    // The mock's pulses, played from where the robot stood (joint j on channel j): each corner
    // passed within the blend, and never through it.
    let mut pulses = shared.with(linterpd::mock::MockPlc::take_pulses);
    pulses.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut counts = from;
    let mut nearest = [f64::INFINITY; 2];
    let corners = [above(P1), above(P2)].map(Vector3::from);
    for p in &pulses {
        counts[usize::from(p.channel)] = p.count;
        let at = robot.pose_of(&counts).position_mm;
        for (n, c) in nearest.iter_mut().zip(&corners) {
            *n = n.min((at - c).norm());
        }
    }
    assert_eq!(counts, target, "the trace ends where the robot stands");
    for (n, corner) in nearest.iter().zip(["above P1", "above P2"]) {
        assert!(
            *n > 1.0 && *n <= BLEND_MM,
            "{corner}: passed {n:.3} mm from it (blend {BLEND_MM} mm)"
        );
    }
    d.shut_down().await;
}
