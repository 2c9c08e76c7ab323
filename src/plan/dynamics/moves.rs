//! PURE. A line and a joint move of a robot with drive limits: the line as a path of that one
//! line at its time-optimal pace, the joint move as one trapezoid the slowest joint allows.

use crate::geometry::{Corner, Element, Line, Path, PathSpec};
use crate::kinematics::Joints;
use crate::robot::{Motion, Ramp, Robot};

use super::super::course::Course;
use super::super::{PlanError, Start};
use super::timing::{
    ACCEL_MARGIN, PathLimits, REST_ROW_PERIODS, START_MARGIN, Shape, any_length_rest_row_s, pace,
};

/// A line for a robot with drive limits: a path of that one line, run at its time-optimal
/// pace ([`pace`]), its standstills' zones for rows of any length or not
/// ([`PathLimits::rows_any_length`], [`rest_rows_first`]).
pub(in crate::plan) fn timed_line(
    robot: &Robot,
    line: &Line,
    start: &Start,
    motion: &Motion,
    rows_any_length: bool,
) -> Result<Course, PlanError> {
    timed_line_at(robot, line, start, motion, rows_any_length, 1.0, 1.0)
}

/// [`timed_line`] timed to `accel_share` of every joint's acceleration limit and
/// `speed_share` of every channel's top frequency ([`PathLimits::accel_share`],
/// [`PathLimits::speed_share`]).
pub(in crate::plan) fn timed_line_at(
    robot: &Robot,
    line: &Line,
    start: &Start,
    motion: &Motion,
    rows_any_length: bool,
    accel_share: f64,
    speed_share: f64,
) -> Result<Course, PlanError> {
    let path = Path::build(&PathSpec {
        start: line.from,
        elements: vec![(Element::Line { to: line.to }, Corner::Stop)],
    })?;
    let pace = pace(
        robot,
        &Shape {
            length_mm: path.length_mm(),
            pose_at: &|s| path.at(s),
            curvature_at: &|_| 0.0,
            breaks_mm: &[],
        },
        &start.values,
        motion,
        &PathLimits {
            centripetal_mm_s2: f64::INFINITY,
            rest_row_s: motion.period_s,
            rows_any_length,
            accel_share,
            speed_share,
            centripetal_share: 1.0,
        },
    )?;
    Ok(Course::Path { path, pace })
}

/// Plans with the standstills' zones planned for rows of any length under bounded-error
/// (`plan(true)`), and where that is refused, for a period (`plan(false)`, as constant-period's
/// are): a joint's rows from rest that its windows make too fast are narrowed, which on a long
/// move can outgrow the table area, and the zone of a period plans what it always did. The
/// refusal is the second's.
pub(in crate::plan) fn rest_rows_first<T>(
    motion: &Motion,
    plan: impl Fn(bool) -> Result<T, PlanError>,
) -> Result<T, PlanError> {
    if motion.method.tolerance_mm().is_some()
        && let Ok(planned) = plan(true)
    {
        return Ok(planned);
    }
    plan(false)
}

/// A joint move's motion under its joints' drive limits: every joint moves in proportion, so
/// the time-optimal motion is one trapezoid, its acceleration the lowest any joint allows
/// (`max_accel`, and `start_hz` over the first and last periods, or under bounded-error over
/// the row from rest that leaves the most, [`any_length_rest_row_s`]) over its share of the
/// course's length; an S-curve's jerk the lowest any joint's `max_jerk` allows over its share
/// likewise. Without drive limits, `motion` as it is.
pub(in crate::plan) fn joint_move_motion(
    robot: &Robot,
    from: &Joints,
    to: &Joints,
    length_mm: f64,
    motion: Motion,
    rows_any_length: bool,
) -> Result<Motion, PlanError> {
    let mut motion = motion;
    if let Ramp::SCurve { jerk_mm_s3 } = motion.ramp {
        let jerk = robot
            .joints
            .iter()
            .enumerate()
            .filter_map(|(j, joint)| {
                let share = (to[j] - from[j]).abs() / length_mm;
                let max_jerk = joint.dynamics.max_jerk?;
                (share > 0.0).then(|| max_jerk * ACCEL_MARGIN / share)
            })
            .fold(jerk_mm_s3, f64::min);
        motion.ramp = Ramp::SCurve { jerk_mm_s3: jerk };
    }
    let mut accel = if motion.accel_s > 0.0 {
        motion.speed_mm_s / motion.accel_s
    } else {
        f64::INFINITY
    };
    for (j, joint) in robot.joints.iter().enumerate() {
        let share = (to[j] - from[j]).abs() / length_mm;
        if share == 0.0 {
            continue;
        }
        if let Some(a) = joint.dynamics.max_accel {
            accel = accel.min(a * ACCEL_MARGIN / share);
        }
        if let Some(start_hz) = joint.dynamics.start_hz {
            // A row from rest: a period, or under bounded-error the row of any length that
            // leaves the most acceleration, planned up to REST_ROW_PERIODS of it (as a line's).
            let (row_s, rows) = if rows_any_length {
                (any_length_rest_row_s(start_hz), REST_ROW_PERIODS)
            } else {
                (motion.period_s, 1.0)
            };
            let room_hz = START_MARGIN * start_hz - 1.0 / row_s;
            if room_hz <= 0.0 {
                return Err(PlanError::StartHzTooLow {
                    joint: joint.name.clone(),
                    start_hz,
                    min_hz: 1.0 / row_s / START_MARGIN,
                    row_s,
                });
            }
            let rest = 2.0 * room_hz / (rows * row_s) * joint.step.abs();
            accel = accel.min(rest / share);
        }
    }
    Ok(if accel.is_finite() {
        Motion {
            accel_s: motion.speed_mm_s / accel,
            ..motion
        }
    } else {
        motion
    })
}
