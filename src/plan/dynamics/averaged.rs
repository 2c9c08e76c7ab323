//! PURE. An S-curve under drive limits as the time-optimal motion averaged: the line's
//! time-optimal motion under every limit ([`super::timing`]), averaged over a moving window as
//! long as its acceleration's range over the jerk asked ([`Pace::smoothed`]). The average keeps
//! the path, its speed and acceleration within the time-optimal motion's, and its jerk within
//! the one asked; it ends one window later. Where only a stretch of the line needs the speed to
//! drop (near the base axis, at a joint's reversal) only that stretch is slowed, where slowing
//! the S-curve as a whole ([`super::slowed`]) slows all of it.
//!
//! The joints' accelerations are the average's through the path's derivatives, which change
//! along the window: near the axis a joint's can pass its limit by a little. The planned motion
//! is checked ([`super::within_limits`]) and, where a drive would not follow it, timed again to
//! a lower share of every joint's acceleration ([`RETIMING`]).

use crate::geometry::{Line, Pace};
use crate::robot::{Motion, Ramp, Robot};

use super::super::course::Course;
use super::super::{Plan, PlanError, Start, plan_course};
use super::{RETIMING, refused_by_a_drive, timed_line_at, within_limits};

/// The averaged motion is tabulated every this many seconds ([`Pace::smoothed`]).
const KNOT_S: f64 = 0.001;

/// The line's time-optimal motion averaged to the S-curve's jerk, planned; timed again to a
/// lower share of the joints' accelerations ([`RETIMING`]) while a drive would not follow it
/// (the last refusal when none is followed). `motion` is the S-curve asked for.
pub(in crate::plan) fn averaged_line(
    robot: &Robot,
    line: &Line,
    start: &Start,
    motion: &Motion,
    rows_any_length: bool,
) -> Result<Plan, PlanError> {
    let Ramp::SCurve { jerk_mm_s3 } = motion.ramp else {
        return Err(PlanError::SCurveUnderDriveLimits);
    };
    // The time-optimal motion is timed and planned as a trapezoid is: the pace carries it.
    let timed = Motion {
        ramp: Ramp::Trapezoid,
        ..*motion
    };
    let mut last = Err(PlanError::SCurveUnderDriveLimits);
    for share in std::iter::once(1.0).chain(RETIMING) {
        let outcome = (|| {
            let Course::Path { path, pace } =
                timed_line_at(robot, line, start, &timed, rows_any_length, share)?
            else {
                unreachable!("a timed line is a path of one line")
            };
            let pace = averaged(&pace, timed.speed_mm_s, jerk_mm_s3)
                .ok_or(PlanError::SCurveUnderDriveLimits)?;
            let mut plan = plan_course(robot, &Course::Path { path, pace }, start, timed)?;
            plan.motion.ramp = motion.ramp;
            within_limits(robot, &mut plan)?;
            Ok(plan)
        })();
        if !refused_by_a_drive(&outcome) {
            return outcome;
        }
        last = outcome;
    }
    last
}

/// `pace` (time-optimal, its profile cruising at `speed_mm_s`) averaged over the window whose
/// jerk is `jerk_mm_s3`: its acceleration's range over the jerk.
fn averaged(pace: &Pace, speed_mm_s: f64, jerk_mm_s3: f64) -> Option<Pace> {
    let (lo, hi) = pace.accel_range_mm_s2(speed_mm_s);
    pace.smoothed(speed_mm_s, (hi - lo) / jerk_mm_s3, KNOT_S)
}

/// The faster of an S-curve averaged from the time-optimal motion (`averaged`) and the same
/// S-curve slowed as a whole (`slowed`, planned only when the averaged one is refused or slower
/// than the S-curve unslowed, `unslowed_s`: slowing only lengthens it). The refusal of the
/// slowed one when both are refused.
pub(in crate::plan) fn faster_s_curve(
    averaged: Result<Plan, PlanError>,
    unslowed_s: Option<f64>,
    slowed: impl FnOnce() -> Result<Plan, PlanError>,
) -> Result<Plan, PlanError> {
    if let Ok(plan) = &averaged
        && unslowed_s.is_some_and(|s| plan.duration_s() <= s)
    {
        return averaged;
    }
    match (averaged, slowed()) {
        (Ok(a), Ok(s)) => Ok(if a.duration_s() < s.duration_s() {
            a
        } else {
            s
        }),
        (Ok(a), Err(_)) => Ok(a),
        (Err(_), slowed) => slowed,
    }
}
