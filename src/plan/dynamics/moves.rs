//! PURE. A line and a joint move of a robot with drive limits: the line as a path of that one
//! line at its time-optimal pace, the joint move as one trapezoid the slowest joint allows.

use crate::geometry::{Corner, Element, Line, Path, PathSpec};
use crate::kinematics::Joints;
use crate::robot::{Motion, Ramp, Robot};

use super::super::course::Course;
use super::super::{PlanError, Start};
use super::timing::{ACCEL_MARGIN, PathLimits, START_MARGIN, Shape, pace};

/// A line for a robot with drive limits: a path of that one line, run at its time-optimal
/// pace ([`pace`]).
pub(in crate::plan) fn timed_line(
    robot: &Robot,
    line: &Line,
    start: &Start,
    motion: &Motion,
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
            accel_share: 1.0,
        },
    )?;
    Ok(Course::Path { path, pace })
}

/// A joint move's motion under its joints' drive limits: every joint moves in proportion, so
/// the time-optimal motion is one trapezoid, its acceleration the lowest any joint allows
/// (`max_accel`, and `start_hz` over the first and last periods) over its share of the
/// course's length; an S-curve's jerk the lowest any joint's `max_jerk` allows over its share
/// likewise. Without drive limits, `motion` as it is.
pub(in crate::plan) fn joint_move_motion(
    robot: &Robot,
    from: &Joints,
    to: &Joints,
    length_mm: f64,
    motion: Motion,
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
            let room_hz = START_MARGIN * start_hz - 1.0 / motion.period_s;
            if room_hz <= 0.0 {
                return Err(PlanError::StartHzTooLow {
                    joint: joint.name.clone(),
                    start_hz,
                    min_hz: 1.0 / motion.period_s / START_MARGIN,
                    row_s: motion.period_s,
                });
            }
            let rest = 2.0 * room_hz / motion.period_s * joint.step.abs();
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
