//! Property tests of the bounded-error method over random reachable moves and tolerances for
//! every kinematics: the executed path never leaves the tolerance, whatever the PLC's scan
//! between a channel's segments; every table keeps the F174 rules, a line cut where a joint
//! reverses chains from exactly the counts each start was planned from, and the move ends on
//! target. A tolerance below what the pulse grid reaches is refused with one that works.

use crate::common;

use common::moves::{Motion, cylindrical_move, gantry_move, scara_move};
use linterpd::geometry::Line;
use linterpd::geometry::Pose;
use linterpd::kinematics::Kinematics;
use linterpd::plan::{MoveRequest, Origin, Plan, PlanError, plan_line};
use linterpd::robot::{Method, Robot};
use linterpd::sim;
use linterpd::table::FrequencyModel;
use proptest::prelude::*;

fn motion() -> impl Strategy<Value = (Motion, f64)> {
    (100.0..400.0f64, 0.05..0.4f64, any::<bool>(), 0.02..0.3f64).prop_map(
        |(speed_mm_s, accel_s, ideal, tol)| {
            (
                Motion {
                    speed_mm_s,
                    accel_s,
                    period_s: 0.05,
                    ideal,
                },
                tol,
            )
        },
    )
}

/// Plans with bounded-error, every start of it; `None` for the refusals that are right for
/// some random moves: a tolerance below the grid's floor (checked to name a tolerance that
/// works) or rows beyond one table area.
fn plan(
    robot: &Robot,
    (from, to): (Pose, Pose),
    (m, tolerance_mm): (Motion, f64),
) -> Result<Option<Vec<Plan>>, TestCaseError> {
    let mut motion = robot.motion;
    motion.speed_mm_s = m.speed_mm_s;
    motion.accel_s = m.accel_s;
    motion.frequency_model = if m.ideal {
        FrequencyModel::Ideal
    } else {
        FrequencyModel::FpxDivider
    };
    motion.method = Method::BoundedError { tolerance_mm };
    let req = MoveRequest {
        from: Origin::Pose(from),
        to,
        motion,
    };
    match plan_line(robot, &req) {
        Ok(planned) => Ok(Some(planned.starts().cloned().collect())),
        Err(PlanError::ToleranceTooSmall {
            floor_mm, works_mm, ..
        }) => {
            prop_assert!(floor_mm > 0.0);
            if let Some(works) = works_mm {
                let mut again = req;
                again.motion.method = Method::BoundedError {
                    tolerance_mm: works,
                };
                let p = plan_line(robot, &again)
                    .map_err(|e| TestCaseError::fail(format!("{works} mm said to work: {e}")))?;
                prop_assert!(p.starts().all(|p| p.figures.path_deviation_mm <= works));
            }
            Ok(None)
        }
        Err(e) if common::moves::refused_for_area(&e) => Ok(None),
        Err(e) => Err(TestCaseError::fail(format!("{from:?} -> {to:?}: {e}"))),
    }
}

/// The PLC scans the tables may meet between a channel's segments, s (ACCURACY.md).
const SCANS_S: [f64; 3] = [0.0, 0.002, 0.010];

fn check(
    robot: &Robot,
    (from, to): (Pose, Pose),
    starts: &[Plan],
    tolerance_mm: f64,
) -> Result<(), TestCaseError> {
    let line = Line { from, to };
    for plan in starts {
        prop_assert!(plan.valid(), "{:?}", plan.problems);
        prop_assert!(
            plan.figures.path_deviation_mm <= tolerance_mm,
            "{} > {tolerance_mm}",
            plan.figures.path_deviation_mm
        );
        prop_assert!(plan.figures.tracking_error_mm <= 2.0 * tolerance_mm);
        common::moves::check_tables_and_ends(robot, plan)?;
        for gap_s in SCANS_S {
            let run = plan.execution_with_scan(gap_s);
            let events = run.events.iter().copied();
            let d = sim::path_deviation_mm(robot, &plan.start_counts(), events, &line);
            prop_assert!(
                d <= tolerance_mm,
                "{d} > {tolerance_mm} with {gap_s} s between segments"
            );
        }
    }
    for pair in starts.windows(2) {
        prop_assert_eq!(pair[1].start_counts(), pair[0].end_counts());
    }
    let q = robot.kinematics.ik(&to, None).unwrap();
    prop_assert_eq!(starts[starts.len() - 1].end_counts(), robot.counts_of(&q));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn cylindrical_bounded_plans_stay_within_tolerance(mv in cylindrical_move(), m in motion()) {
        let robot = common::cylindrical();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, mv, &p, m.1)?; }
    }

    #[test]
    fn gantry_bounded_plans_stay_within_tolerance(mv in gantry_move(), m in motion()) {
        let robot = common::gantry();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, mv, &p, m.1)?; }
    }

    #[test]
    fn scara_bounded_plans_stay_within_tolerance(mv in scara_move(), m in motion()) {
        let robot = common::scara();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, mv, &p, m.1)?; }
    }
}
