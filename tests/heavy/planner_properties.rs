//! Property tests of the planner over random reachable moves, for every kinematics: FK(IK(p)) = p,
//! every plan ends on its target, every table obeys the F174 rules, no channel drifts more than
//! one period from the grid, and every start plays as planned whatever the PLC's scan between a
//! channel's segments (a line is cut into starts where a joint would need a later segment).

use crate::common;

use linterpd::geometry::Pose;
use linterpd::kinematics::Kinematics;
use linterpd::plan::{MoveRequest, Origin, Plan};
use linterpd::robot::Robot;
use linterpd::table::FrequencyRange;
use proptest::prelude::*;

use common::moves::{Motion, cylindrical_move, gantry_move, motion, scara_move};

/// Plans the move, every start of it; `None` when it is refused only because its rows do not
/// fit one table area (slow-down can stretch a move that far; that refusal has its own test).
fn plan(robot: &Robot, (from, to): (Pose, Pose), m: Motion) -> Option<Vec<Plan>> {
    // At most ~400 periods, so every channel's rows fit its 2000-word area (a longer move is
    // refused with an area error, tested elsewhere).
    let req = MoveRequest {
        from: Origin::Pose(from),
        to,
        motion: common::moves::motion_on(robot, (from, to), m, 400.0),
    };
    common::moves::starts_or_area(robot, &req, "")
}

fn check_fk_ik(robot: &Robot, pose: Pose) -> Result<(), TestCaseError> {
    let q = robot
        .kinematics
        .ik(&pose, None)
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    let back = robot.kinematics.fk(&q);
    prop_assert!(
        (back.position_mm - pose.position_mm).norm() < 1e-9,
        "{pose:?} -> {back:?}"
    );
    let turn = std::f64::consts::TAU;
    let da = (back.a_rad - pose.a_rad).rem_euclid(turn);
    prop_assert!(da.min(turn - da) < 1e-9);
    Ok(())
}

fn check_plan(robot: &Robot, starts: &[Plan]) -> Result<(), TestCaseError> {
    for plan in starts {
        prop_assert!(plan.valid(), "{:?}", plan.problems);
        common::moves::check_tables_and_ends(robot, plan)?;
        for j in 0..plan.tables.len() {
            check_grid(plan, j)?;
        }
        // The same pulses, hence the same figures, with a 10 ms scan between segments.
        let late = plan.execution_with_scan(0.010);
        let on_time = plan.execution();
        prop_assert!(
            late.events.iter().zip(&on_time.events).all(|(a, b)| a == b),
            "a later segment: {:?}",
            plan.later_segment()
        );
    }
    for pair in starts.windows(2) {
        prop_assert_eq!(pair[1].start_counts(), pair[0].end_counts());
    }
    Ok(())
}

/// The time by which one integer Hz moves the end of a row of `pulses` at `set_hz`: how finely a
/// row can be placed at all.
fn resolution_s(plan: &Plan, range: FrequencyRange, pulses: i64, set_hz: u32) -> f64 {
    let model = plan.motion.frequency_model;
    let dur = |f: u32| pulses as f64 / model.actual_hz(f.max(1), range);
    (dur(set_hz.saturating_sub(1)) - dur(set_hz))
        .abs()
        .max((dur(set_hz) - dur(set_hz + 1)).abs())
}

/// No drift: every row of joint `j` ends within one period of the grid point where its target was
/// planned, or, for a row so slow that one Hz moves its end by more than that, within the row's
/// own resolution, or for a row already at the slowest value its range has. The residual is carried, so errors never add up along the move.
fn check_grid(plan: &Plan, j: usize) -> Result<(), TestCaseError> {
    let counts = plan.samples.joint(j);
    let period = plan.profile.period_s;
    let last_point = counts.len() - 1;
    let mut point = 0;
    let mut prev = plan.tables[j].start;
    let rows = plan.row_timings();
    let timings = rows.iter().filter(|r| r.table == j);
    let rows = plan.tables[j]
        .segments
        .iter()
        .flat_map(|s| s.rows.iter().map(move |r| (s.control.range, *r)));
    let n_rows = plan.tables[j].rows();
    for (k, ((range, row), timing)) in rows.zip(timings).enumerate() {
        point = (point + 1..=last_point)
            .find(|&i| counts[i] == row.target)
            .unwrap_or(last_point);
        let planned = if k + 1 == n_rows {
            last_point as f64 * period
        } else {
            point as f64 * period
        };
        let mut allowed = period.max(resolution_s(
            plan,
            range,
            (row.target - prev).abs(),
            row.freq_hz,
        ));
        if row.freq_hz == range.min_set_hz() {
            // The slowest the channel can go (1.5 Hz in range 0): a row that wants to be slower
            // ends early and the next row takes up the time.
            allowed = f64::INFINITY;
        }
        prop_assert!(
            (timing.end_s - planned).abs() <= allowed + 1e-9,
            "joint {j} row {k} ends at {} s, planned {planned} s (allowed {allowed} s)",
            timing.end_s
        );
        prev = row.target;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn cylindrical_fk_of_ik_is_the_pose((from, to) in cylindrical_move()) {
        let robot = common::cylindrical();
        check_fk_ik(&robot, from)?;
        check_fk_ik(&robot, to)?;
    }

    #[test]
    fn gantry_fk_of_ik_is_the_pose((from, to) in gantry_move()) {
        let robot = common::gantry();
        check_fk_ik(&robot, from)?;
        check_fk_ik(&robot, to)?;
    }

    #[test]
    fn scara_fk_of_ik_is_the_pose((from, to) in scara_move()) {
        let robot = common::scara();
        check_fk_ik(&robot, from)?;
        check_fk_ik(&robot, to)?;
    }

    #[test]
    fn cylindrical_plans_end_on_target_and_keep_every_rule(mv in cylindrical_move(), m in motion()) {
        let robot = common::cylindrical();
        let plan = plan(&robot, mv, m);
        prop_assume!(plan.is_some());
        check_plan(&robot, &plan.unwrap())?;
    }

    #[test]
    fn gantry_plans_end_on_target_and_keep_every_rule(mv in gantry_move(), m in motion()) {
        let robot = common::gantry();
        let plan = plan(&robot, mv, m);
        prop_assume!(plan.is_some());
        check_plan(&robot, &plan.unwrap())?;
    }

    #[test]
    fn scara_plans_end_on_target_and_keep_every_rule(mv in scara_move(), m in motion()) {
        let robot = common::scara();
        let plan = plan(&robot, mv, m);
        prop_assume!(plan.is_some());
        check_plan(&robot, &plan.unwrap())?;
    }
}
