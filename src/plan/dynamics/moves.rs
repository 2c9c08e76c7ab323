//! PURE. A line and a joint move of a robot with drive limits: the line as a path of that one
//! line at its time-optimal pace, the joint move as one trapezoid the slowest joint allows.

use crate::geometry::{Corner, Element, Line, Pace, Path, PathSpec};
use crate::kinematics::Joints;
use crate::plan::error::PlanError;
use crate::robot::{Joint, Motion, Ramp, Robot};

use super::timing::{
    ACCEL_MARGIN, PathLimits, REST_ROW_PERIODS, START_MARGIN, Shape, Shares, any_length_rest_row_s,
    pace,
};

/// A line for a robot with drive limits: a path of that one line, from the joints `start`, and
/// its time-optimal pace ([`pace`]) to `shares` of the limits, its standstills' zones for rows
/// of any length or not ([`PathLimits::rows_any_length`]).
pub(in crate::plan) fn timed_line(
    robot: &Robot,
    line: &Line,
    start: &Joints,
    motion: &Motion,
    rows_any_length: bool,
    shares: Shares,
) -> Result<(Path, Pace), PlanError> {
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
        start,
        motion,
        &PathLimits {
            centripetal_mm_s2: f64::INFINITY,
            rest_row_s: motion.period_s,
            rows_any_length,
            shares,
        },
    )?;
    Ok((path, pace))
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
    // Every moving joint's share of the course: how far it moves per mm of it.
    let shares = robot.joints.iter().enumerate().map(|(j, joint)| {
        let share = (to[j] - from[j]).abs() / length_mm;
        (joint, share)
    });
    if let Ramp::SCurve { jerk_mm_s3 } = motion.ramp {
        let jerk = shares
            .clone()
            .filter_map(|(joint, share)| {
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
    for (joint, share) in shares {
        if share == 0.0 {
            continue;
        }
        if let Some(a) = joint.dynamics.max_accel {
            accel = accel.min(a * ACCEL_MARGIN / share);
        }
        if let Some(rest) = rest_accel(joint, motion.period_s, rows_any_length)? {
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

/// The acceleration `joint`'s `start_hz` allows it from and to rest, joint units/s^2 (`None`
/// without one): over a row from rest of a period (`period_s`), or under bounded-error
/// (`rows_any_length`) over the row of any length that leaves the most acceleration, planned up
/// to [`REST_ROW_PERIODS`] of it (as a line's).
fn rest_accel(
    joint: &Joint,
    period_s: f64,
    rows_any_length: bool,
) -> Result<Option<f64>, PlanError> {
    let Some(start_hz) = joint.dynamics.start_hz else {
        return Ok(None);
    };
    let (row_s, rows) = if rows_any_length {
        (any_length_rest_row_s(start_hz), REST_ROW_PERIODS)
    } else {
        (period_s, 1.0)
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
    Ok(Some(2.0 * room_hz / (rows * row_s) * joint.step.abs()))
}
