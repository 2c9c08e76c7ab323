//! Property tests of the bounded-error method over random reachable moves and tolerances for
//! every kinematics: the executed path never leaves the tolerance, every table keeps the F174
//! rules, and the move ends on target. A tolerance below what the pulse grid reaches is refused
//! with one that works.

mod common;

use common::moves::{Motion, cylindrical_move, gantry_move, scara_move};
use linterpd::geometry::Pose;
use linterpd::plan::{MoveRequest, Origin, Plan, PlanError, plan_move};
use linterpd::robot::{Method, Robot};
use linterpd::table::{FrequencyModel, TableProblem};
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

/// Plans with bounded-error; `None` for the refusals that are right for some random moves: a
/// tolerance below the grid's floor (checked to name a tolerance that works) or rows beyond one
/// table area.
fn plan(
    robot: &Robot,
    (from, to): (Pose, Pose),
    (m, tolerance_mm): (Motion, f64),
) -> Result<Option<Plan>, TestCaseError> {
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
        seed_exact: false,
    };
    match plan_move(robot, &req) {
        Ok(plan) => Ok(Some(plan)),
        Err(PlanError::ToleranceTooSmall {
            floor_mm, works_mm, ..
        }) => {
            prop_assert!(floor_mm > 0.0);
            if let Some(works) = works_mm {
                let mut again = req;
                again.motion.method = Method::BoundedError {
                    tolerance_mm: works,
                };
                let p = plan_move(robot, &again)
                    .map_err(|e| TestCaseError::fail(format!("{works} mm said to work: {e}")))?;
                prop_assert!(p.figures.path_deviation_mm <= works);
            }
            Ok(None)
        }
        Err(PlanError::InvalidTable {
            first: TableProblem::AreaOverflow { .. },
            ..
        }) => Ok(None),
        Err(e) => Err(TestCaseError::fail(format!("{from:?} -> {to:?}: {e}"))),
    }
}

fn check(robot: &Robot, plan: &Plan, tolerance_mm: f64) -> Result<(), TestCaseError> {
    prop_assert!(plan.valid(), "{:?}", plan.problems);
    prop_assert!(
        plan.figures.path_deviation_mm <= tolerance_mm,
        "{} > {tolerance_mm}",
        plan.figures.path_deviation_mm
    );
    prop_assert!(plan.figures.tracking_error_mm <= 2.0 * tolerance_mm);
    common::moves::check_tables_and_ends(robot, plan)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn cylindrical_bounded_plans_stay_within_tolerance(mv in cylindrical_move(), m in motion()) {
        let robot = common::cylindrical();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, &p, m.1)?; }
    }

    #[test]
    fn gantry_bounded_plans_stay_within_tolerance(mv in gantry_move(), m in motion()) {
        let robot = common::gantry();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, &p, m.1)?; }
    }

    #[test]
    fn scara_bounded_plans_stay_within_tolerance(mv in scara_move(), m in motion()) {
        let robot = common::scara();
        if let Some(p) = plan(&robot, mv, m)? { check(&robot, &p, m.1)?; }
    }
}
