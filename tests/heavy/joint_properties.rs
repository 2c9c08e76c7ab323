//! Property tests of joint-space moves over random starts and targets for every kinematics, with
//! both methods: every plan ends exactly on its target counts, every table keeps the F174 rules,
//! the execution gets there, and a bounded-error plan keeps the tool within its tolerance of the
//! tool's path. A target beyond a joint's limits is refused naming the joint and the limit.

use crate::common;

use linterpd::kinematics::{JOINTS, Joints, Kinematics};
use linterpd::plan::{JointMoveRequest, Origin, Plan, PlanError, plan_joint_move};
use linterpd::robot::{Method, Robot};
use linterpd::table::{FrequencyModel, problems};
use proptest::prelude::*;

/// Joint values in user units (deg or mm), each drawn from its range.
fn joints(ranges: [(f64, f64); JOINTS]) -> impl Strategy<Value = [f64; JOINTS]> {
    let [a, b, c, d] = ranges;
    (a.0..a.1, b.0..b.1, c.0..c.1, d.0..d.1).prop_map(|(a, b, c, d)| [a, b, c, d])
}

fn cylindrical_joints() -> impl Strategy<Value = [f64; JOINTS]> {
    joints([(-90.0, 90.0), (0.0, 300.0), (100.0, 900.0), (-90.0, 90.0)])
}

fn gantry_joints() -> impl Strategy<Value = [f64; JOINTS]> {
    joints([
        (-500.0, 500.0),
        (-500.0, 500.0),
        (-200.0, 200.0),
        (-90.0, 90.0),
    ])
}

fn scara_joints() -> impl Strategy<Value = [f64; JOINTS]> {
    joints([(-60.0, 60.0), (30.0, 150.0), (-100.0, 100.0), (-90.0, 90.0)])
}

/// Speed (mm/s), acceleration time (s), period (s), ideal model, bounded-error tolerance (mm).
type Settings = (f64, f64, f64, bool, Option<f64>);

fn settings() -> impl Strategy<Value = Settings> {
    (
        50.0..400.0f64,
        0.0..0.4f64,
        0.02..0.1f64,
        any::<bool>(),
        prop_oneof![Just(None), (0.05..0.3f64).prop_map(Some)],
    )
}

fn internal(robot: &Robot, user: [f64; JOINTS]) -> Joints {
    std::array::from_fn(|j| robot.joints[j].kind.from_user(user[j]))
}

/// The tool path's length by forward kinematics, or the tool angle's turn in degrees.
fn length_mm(robot: &Robot, from: &Joints, to: &Joints) -> f64 {
    let at = |u: f64| {
        let q: Joints = std::array::from_fn(|j| from[j] + (to[j] - from[j]) * u);
        robot.kinematics.fk(&q)
    };
    let path: f64 = (0..64)
        .map(|i| {
            (at(f64::from(i + 1) / 64.0).position_mm - at(f64::from(i) / 64.0).position_mm).norm()
        })
        .sum();
    path.max((at(1.0).a_rad - at(0.0).a_rad).to_degrees().abs())
}

/// Plans the joint move; `None` for the refusals that are right for some random moves: rows
/// beyond one table area, a tolerance below the pulse grid's floor.
fn plan(
    robot: &Robot,
    from_user: [f64; JOINTS],
    to_user: [f64; JOINTS],
    (speed, accel_s, period_s, ideal, tolerance): Settings,
) -> Result<Option<(JointMoveRequest, Plan)>, TestCaseError> {
    let from = robot.counts_of(&internal(robot, from_user));
    let to = internal(robot, to_user);
    let mut motion = robot.motion;
    // At most ~300 periods (or 1 ms samples x 60), so the rows fit one table area.
    let length = length_mm(robot, &robot.values_of(&from), &to);
    motion.speed_mm_s = speed.max(length / (300.0 * period_s));
    motion.accel_s = accel_s;
    motion.period_s = period_s;
    motion.frequency_model = if ideal {
        FrequencyModel::Ideal
    } else {
        FrequencyModel::FpxDivider
    };
    if let Some(tolerance_mm) = tolerance {
        motion.method = Method::BoundedError { tolerance_mm };
    }
    let req = JointMoveRequest {
        from: Origin::Counts(from),
        to,
        motion,
    };
    match plan_joint_move(robot, &req) {
        Ok(plan) => Ok(Some((req, plan))),
        Err(PlanError::ToleranceTooSmall { .. } | PlanError::NoTravel { .. }) => Ok(None),
        Err(e) if common::moves::refused_for_area(&e) => Ok(None),
        Err(e) => Err(TestCaseError::fail(format!(
            "{from_user:?} -> {to_user:?}: {e}"
        ))),
    }
}

fn check(robot: &Robot, req: &JointMoveRequest, plan: &Plan) -> Result<(), TestCaseError> {
    prop_assert!(plan.valid(), "{:?}", plan.problems);
    prop_assert_eq!(plan.end_counts(), robot.counts_of(&req.to));
    for (j, table) in plan.tables.iter().enumerate() {
        prop_assert!(problems(table, robot.channel_limits(j)).is_empty());
        let executed = plan
            .execution()
            .events
            .iter()
            .rev()
            .find(|e| e.table == j)
            .map_or(table.start, |e| e.count);
        prop_assert_eq!(executed, table.end());
    }
    if let Method::BoundedError { tolerance_mm } = plan.motion.method {
        prop_assert!(
            plan.figures.path_deviation_mm <= tolerance_mm,
            "{} > {tolerance_mm}",
            plan.figures.path_deviation_mm
        );
        prop_assert!(plan.figures.tracking_error_mm <= 2.0 * tolerance_mm);
    }
    Ok(())
}

fn run(
    robot: &Robot,
    from: [f64; JOINTS],
    to: [f64; JOINTS],
    s: Settings,
) -> Result<(), TestCaseError> {
    if let Some((req, p)) = plan(robot, from, to, s)? {
        check(robot, &req, &p)?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn cylindrical_joint_moves_end_on_their_target_counts(
        from in cylindrical_joints(), to in cylindrical_joints(), s in settings()
    ) {
        run(&common::cylindrical(), from, to, s)?;
    }

    #[test]
    fn gantry_joint_moves_end_on_their_target_counts(
        from in gantry_joints(), to in gantry_joints(), s in settings()
    ) {
        run(&common::gantry(), from, to, s)?;
    }

    #[test]
    fn scara_joint_moves_end_on_their_target_counts(
        from in scara_joints(), to in scara_joints(), s in settings()
    ) {
        run(&common::scara(), from, to, s)?;
    }

    #[test]
    fn a_joint_target_beyond_its_limit_is_refused_naming_it(
        from in cylindrical_joints(), joint in 0..JOINTS, beyond in 1.0..100.0f64, above in any::<bool>()
    ) {
        let robot = common::cylindrical();
        let limit = &robot.joints[joint];
        let mut to = from;
        let edge = if above { limit.user(limit.max) } else { limit.user(limit.min) };
        to[joint] = if above { edge + beyond } else { edge - beyond };
        let req = JointMoveRequest {
            from: Origin::Counts(robot.counts_of(&internal(&robot, from))),
            to: internal(&robot, to),
            motion: robot.motion,
        };
        let msg = plan_joint_move(&robot, &req).unwrap_err().to_string();
        let unit = limit.kind.user_unit();
        let named = format!(
            "joint {} target {:.4} {unit} is beyond its limits {} to {} {unit}",
            limit.name,
            to[joint],
            limit.user(limit.min),
            limit.user(limit.max)
        );
        prop_assert_eq!(msg, named);
    }
}
