//! Random reachable moves for every kinematics, for property tests.

use linterpd::geometry::{Line, Pose};
use linterpd::plan::Plan;
use linterpd::robot::Robot;
use linterpd::table::problems;
use proptest::prelude::*;

/// A point at `radius_mm` and `angle_deg` around the z axis, for the robots with a vertical axis.
fn polar(radius_mm: f64, angle_deg: f64, z: f64, a_deg: f64) -> Pose {
    let t = angle_deg.to_radians();
    Pose::from_mm_deg(radius_mm * t.cos(), radius_mm * t.sin(), z, a_deg)
}

#[derive(Debug, Clone, Copy)]
pub struct Motion {
    pub speed_mm_s: f64,
    pub accel_s: f64,
    pub period_s: f64,
    pub ideal: bool,
}

pub fn motion() -> impl Strategy<Value = Motion> {
    (20.0..600.0f64, 0.0..0.5f64, 0.01..0.1f64, any::<bool>()).prop_map(
        |(speed_mm_s, accel_s, period_s, ideal)| Motion {
            speed_mm_s,
            accel_s,
            period_s,
            ideal,
        },
    )
}

pub fn cylindrical_move() -> impl Strategy<Value = (Pose, Pose)> {
    (
        700.0..1400.0f64,
        -60.0..60.0f64,
        0.0..300.0f64,
        700.0..1400.0f64,
        -60.0..60.0f64,
        0.0..300.0f64,
        -30.0..30.0f64,
    )
        .prop_map(|(r1, t1, z1, r2, t2, z2, a)| {
            (polar(r1, t1 + 90.0, z1, a), polar(r2, t2 + 90.0, z2, -a))
        })
        // Reachable: the whole line stays outside d3 = 0 (500 mm from the axis).
        .prop_filter("line passes inside the d3 = 0 cylinder", |(from, to)| {
            Line {
                from: *from,
                to: *to,
            }
            .xy_radius_range_mm()
            .0 > 520.0
        })
}

pub fn gantry_move() -> impl Strategy<Value = (Pose, Pose)> {
    let p = || {
        (
            -800.0..800.0f64,
            -800.0..800.0f64,
            -300.0..300.0f64,
            -90.0..90.0f64,
        )
    };
    (p(), p()).prop_map(|(a, b)| {
        (
            Pose::from_mm_deg(a.0, a.1, a.2, a.3),
            Pose::from_mm_deg(b.0, b.1, b.2, b.3),
        )
    })
}

pub fn scara_move() -> impl Strategy<Value = (Pose, Pose)> {
    // Ends 300-650 mm out and at most 60 degrees apart: the line stays inside the annulus.
    (
        300.0..650.0f64,
        -30.0..30.0f64,
        300.0..650.0f64,
        -30.0..30.0f64,
        -100.0..100.0f64,
        -45.0..45.0f64,
    )
        .prop_map(|(r1, t1, r2, t2, z, a)| (polar(r1, t1, z, a), polar(r2, t2, -z, -a)))
}

/// Every table keeps the F174 rules, every joint's last target is the count nearest its value at
/// P2, and the execution really gets there.
pub fn check_tables_and_ends(robot: &Robot, plan: &Plan) -> Result<(), TestCaseError> {
    let last = plan.samples.values.last().expect("at least two points");
    for (j, table) in plan.tables.iter().enumerate() {
        prop_assert!(problems(table, robot.channel_limits(j)).is_empty());
        let joint = &robot.joints[j];
        let off = (joint.value_of(table.end()) - last[j]) / joint.step;
        prop_assert!(
            off.abs() <= 0.5 + 1e-9,
            "joint {} ends {off} pulses off",
            joint.name
        );
        let executed = plan
            .execution()
            .events
            .iter()
            .rev()
            .find(|e| e.table == j)
            .map_or(table.start, |e| e.count);
        prop_assert_eq!(executed, table.end());
    }
    Ok(())
}

/// `robot`'s motion with `m`'s speed, acceleration time, period and frequency model, the speed
/// raised where the line from `from` to `to` would need more than `max_periods` periods (more
/// rows than a table area holds: that refusal has tests of its own).
#[allow(dead_code)] // not every test binary plans random lines
pub fn motion_on(
    robot: &Robot,
    (from, to): (Pose, Pose),
    m: Motion,
    max_periods: f64,
) -> linterpd::robot::Motion {
    let length_mm = (to.position_mm - from.position_mm).norm();
    linterpd::robot::Motion {
        speed_mm_s: m.speed_mm_s.max(length_mm / (max_periods * m.period_s)),
        accel_s: m.accel_s,
        period_s: m.period_s,
        frequency_model: if m.ideal {
            linterpd::table::FrequencyModel::Ideal
        } else {
            linterpd::table::FrequencyModel::FpxDivider
        },
        ..robot.motion
    }
}

/// Every start of the line `req` asks for; `None` when it is refused only because its rows do
/// not fit one table area. Any other refusal fails the test, naming the move and `context`.
#[allow(dead_code)] // not every test binary plans random lines
pub fn starts_or_area(
    robot: &Robot,
    req: &linterpd::plan::MoveRequest,
    context: &str,
) -> Option<Vec<Plan>> {
    match linterpd::plan::plan_line(robot, req) {
        Ok(planned) => Some(planned.starts().cloned().collect()),
        Err(e) if refused_for_area(&e) || refused_for_creep(robot, &e) => None,
        Err(e) => panic!("{:?} -> {:?} {context}: {e}", req.from, req.to),
    }
}

/// Whether `e` refuses a bounded-error move because one of `robot`'s joints moves slower than
/// the lowest frequency its channel plays, so that its pulses run ahead of the path whatever the
/// rows (a very slow line, a joint that hardly moves): a limit of the PLC, not of the planner.
/// The refusal must name the joint and say it is slower than its channel and lands early.
#[allow(dead_code)] // not every test binary plans random lines
pub fn refused_for_creep(robot: &Robot, e: &linterpd::plan::PlanError) -> bool {
    match e {
        linterpd::plan::PlanError::ToleranceTooSmall { creep: Some(c), .. } => {
            assert!(
                robot.joints.iter().any(|j| j.name == c.joint)
                    && c.rate_hz < c.lowest_hz
                    && c.rate_hz * c.over_s >= 1.0
                    && c.early_s > 0.0,
                "a creep refusal that does not hold together: {c:?}"
            );
            true
        }
        _ => false,
    }
}

/// Whether `e` refuses a move only because its rows do not fit a table area, however the
/// planner wraps that: a line too big for one start whose parts chained at speed do not fit
/// either (`NoParts`), a joint move that is never cut (`JointMoveTooLong`), a path's section.
#[allow(dead_code)] // not every test binary plans random lines
pub fn refused_for_area(e: &linterpd::plan::PlanError) -> bool {
    use linterpd::plan::PlanError;
    use linterpd::table::TableProblem;
    match e {
        PlanError::InvalidTable {
            first: TableProblem::AreaOverflow { .. },
            ..
        } => true,
        PlanError::NoParts { source, parts } => refused_for_area(source) && refused_for_area(parts),
        PlanError::JointMoveTooLong { source } | PlanError::Section { source, .. } => {
            refused_for_area(source)
        }
        _ => false,
    }
}
