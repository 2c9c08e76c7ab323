//! PURE. An S-curve under drive limits as the time-optimal motion averaged: a line's or a path
//! section's time-optimal motion under every limit ([`super::timing`]), averaged over a moving
//! window ([`crate::geometry::Pace::smoothed`]) just long enough to hold its jerk within the
//! one asked ([`crate::geometry::Pace::jerk_window_s`]). The average keeps the path, its speed
//! and acceleration within the time-optimal motion's, and its jerk within the one asked; it
//! ends one window later. Where only a stretch of the path needs the speed to drop (near the
//! base axis, at a joint's reversal, on a tight arc) only that stretch is slowed, where
//! slowing the S-curve as a whole ([`super::slowed`](mod@super::slowed)) slows all of it; the
//! faster of the two is planned ([`faster_s_curve`]).
//!
//! The joints' accelerations are the average's through the path's derivatives, which change
//! along the window: near the axis a joint's can pass its limit by a little. The planned motion
//! is checked ([`super::within_limits`]) and, where a drive would not follow it, timed again to
//! a lower share of every joint's acceleration ([`RETIMING`]); where the average passes a
//! channel's top frequency, to a lower share of every top frequency ([`Shares`]).
//!
//! A path section whose speed must change along it is timed so without drive limits too: an
//! S-curve run on the pace of a trapezoid (whose changes of speed step the acceleration on and
//! off) would not keep its jerk.

use crate::geometry::{Line, Pace, Path};
use crate::robot::{Motion, Ramp, Robot};

use super::super::course::Course;
use super::super::{Plan, PlanError, Sampled, Start, plan_course};
use super::{RETIMING, refused_by_a_drive, timed_line_at, within_limits};

/// The averaged motion is tabulated every this many seconds ([`Pace::smoothed`]).
const KNOT_S: f64 = 0.001;

/// How many times the window is lengthened for a joint's `max_jerk`, each time by the share its
/// jerk was over ([`JERK_WIDENING_MARGIN`] more).
const JERK_WIDENINGS: usize = 3;
/// The lengthening's margin over the share a joint's jerk was over.
const JERK_WIDENING_MARGIN: f64 = 1.05;

/// The line's time-optimal motion averaged to the S-curve's jerk, planned ([`averaged`]).
/// `motion` is the S-curve asked for.
pub(in crate::plan) fn averaged_line(
    robot: &Robot,
    line: &Line,
    start: &Start,
    motion: &Motion,
    rows_any_length: bool,
) -> Result<Plan, PlanError> {
    averaged(
        motion,
        f64::INFINITY,
        |timed, shares| {
            let Course::Path { path, pace } = timed_line_at(
                robot,
                line,
                start,
                timed,
                rows_any_length,
                shares.accel,
                shares.speed,
            )?
            else {
                unreachable!("a timed line is a path of one line")
            };
            Ok((path, pace))
        },
        |course, timed| {
            let mut plan = plan_course(robot, course, start, timed)?;
            plan.motion.ramp = motion.ramp;
            within_limits(robot, &mut plan)?;
            Ok(plan)
        },
        |course, timed| probe(robot, course, start, timed),
    )
}

/// A course sampled for `motion` as it would be planned: its duration and the speed factor the
/// sampled check leaves it (`None` if it cannot be sampled) ([`averaged`]).
pub(in crate::plan) fn probe(
    robot: &Robot,
    course: &Course,
    start: &Start,
    motion: Motion,
) -> Option<(f64, f64)> {
    let sampled = Sampled::new(robot, course, start, motion).ok()?;
    Some((sampled.profile.duration_s(), sampled.speed_factor))
}

/// The shares of the limits a path is timed to ([`super::PathLimits`]): of every joint's
/// acceleration limit, of every channel's top frequency, and of the centripetal limit.
#[derive(Debug, Clone, Copy)]
pub(in crate::plan) struct Shares {
    pub accel: f64,
    pub speed: f64,
    pub centripetal: f64,
}

impl Shares {
    /// Every limit whole.
    pub(in crate::plan) const WHOLE: Self = Self {
        accel: 1.0,
        speed: 1.0,
        centripetal: 1.0,
    };
}

/// How many times a path is timed again to a lower share of its centripetal limit while its
/// average passes it ([`averaged`]).
const CENTRIPETAL_RETIMINGS: usize = 6;
/// The margin under the share the average passed the centripetal limit by.
const CENTRIPETAL_MARGIN: f64 = 1.01;
/// The spacing the centripetal acceleration is read at along an arc, mm.
const CENTRIPETAL_STEP_MM: f64 = 0.25;
/// The fewest reads of the centripetal acceleration along one arc.
const CENTRIPETAL_READS: usize = 8;

/// How far `course` (a path at a pace from rest, its profile cruising at `speed_mm_s`) passes
/// the centripetal limit `centripetal_mm_s2`: the largest `v^2 k / a` on its arcs, read every
/// [`CENTRIPETAL_STEP_MM`] and at least [`CENTRIPETAL_READS`] times along each (0 on a line).
fn centripetal_load(course: &Course, speed_mm_s: f64, centripetal_mm_s2: f64) -> f64 {
    let Course::Path { path, pace } = course else {
        return 0.0;
    };
    if !centripetal_mm_s2.is_finite() {
        return 0.0;
    }
    let mut load: f64 = 0.0;
    for piece in path.pieces() {
        let k = piece.primitive.curvature_per_mm();
        let length_mm = piece.primitive.length_mm();
        if k <= 0.0 {
            continue;
        }
        let reads = ((length_mm / CENTRIPETAL_STEP_MM).ceil() as usize).max(CENTRIPETAL_READS);
        for i in 0..=reads {
            let s = piece.start_mm + length_mm * i as f64 / reads as f64;
            let v = speed_mm_s * pace.ratio_at(s.min(path.length_mm()));
            load = load.max(v * v * k / centripetal_mm_s2);
        }
    }
    load
}

/// A line's or a path section's time-optimal motion averaged to the S-curve `motion`'s jerk,
/// planned: `timed(motion, shares)` times the path to those shares of the joints' accelerations
/// and the channels' top frequencies (the motion a trapezoid: the pace carries it), and
/// `plan(course, motion)` plans the course at the averaged pace and checks the planned motion
/// ([`within_limits`]); `probe(course, motion)` samples a course as `plan` would and gives its
/// duration and the speed factor the sampled check leaves it (`None` if it cannot be sampled).
/// The window is lengthened while a joint's jerk is over its `max_jerk` ([`JERK_WIDENINGS`]),
/// and the path timed again to a lower share ([`RETIMING`]) while a drive would not follow it;
/// the last refusal when none is followed.
///
/// Where the average passes a channel's top frequency, the sampled check slows the whole
/// motion; the path is then timed again to that share of every top frequency, which slows
/// only where a channel's frequency holds the motion back, and the faster of the two on their
/// samples is planned.
pub(in crate::plan) fn averaged<T>(
    motion: &Motion,
    centripetal_mm_s2: f64,
    timed: impl Fn(&Motion, Shares) -> Result<(Path, Pace), PlanError>,
    plan: impl Fn(&Course, Motion) -> Result<T, PlanError>,
    probe: impl Fn(&Course, Motion) -> Option<(f64, f64)>,
) -> Result<T, PlanError> {
    let Ramp::SCurve { jerk_mm_s3 } = motion.ramp else {
        return Err(PlanError::SCurveUnderDriveLimits);
    };
    let trapezoid = Motion {
        ramp: Ramp::Trapezoid,
        ..*motion
    };
    let smoothed = |path: &Path, pace: &Pace, window_s: f64| {
        let pace = pace.smoothed(trapezoid.speed_mm_s, window_s, KNOT_S)?;
        Some(Course::Path {
            path: path.clone(),
            pace,
        })
    };
    // The path timed to `shares`, its window the one its jerk needs or `window_s`, the longer.
    let timed_at = |shares: Shares, window_s: f64| {
        timed(&trapezoid, shares).map(|(path, pace)| {
            let w = pace.jerk_window_s(trapezoid.speed_mm_s, jerk_mm_s3);
            (path, pace, w.max(window_s))
        })
    };
    // The path timed to `shares` and its window at least `window_s`, timed again to lower
    // shares of the centripetal limit while its average passes it (entering an arc the motion
    // slowed for, the average is still nearly as fast as before it); refused if it still does.
    let fitted = |mut shares: Shares, window_s: f64| {
        let (mut path, mut pace, mut window_s) = timed_at(shares, window_s)?;
        // The load goes down with the share as a power of it (the average's speed on an arc
        // is partly the approach's, which the share does not lower): that power is measured
        // between the last two timings, from the square root (the arc's own speed) at first.
        let mut before: Option<(f64, f64)> = None;
        for retiming in 0..=CENTRIPETAL_RETIMINGS {
            let load = smoothed(&path, &pace, window_s).map_or(0.0, |c| {
                centripetal_load(&c, trapezoid.speed_mm_s, centripetal_mm_s2)
            });
            if load <= 1.0 {
                return Ok((path, pace, window_s, shares));
            }
            if retiming == CENTRIPETAL_RETIMINGS {
                break;
            }
            let power = before
                .map(|(share, was)| (was / load).ln() / (share / shares.centripetal).ln())
                .filter(|p| p.is_finite())
                .map_or(0.5, |p| p.clamp(0.1, 1.0));
            before = Some((shares.centripetal, load));
            // At most halved at a time: where the load does not fall with the share, slowly.
            shares.centripetal *= (load.powf(-1.0 / power) / CENTRIPETAL_MARGIN).max(0.5);
            (path, pace, window_s) = timed_at(shares, window_s)?;
        }
        Err(PlanError::SCurveUnderDriveLimits)
    };
    let mut last = Err(PlanError::SCurveUnderDriveLimits);
    for accel in std::iter::once(1.0).chain(RETIMING) {
        // The window the path's jerk needs, lengthened while a joint's jerk is over its
        // `max_jerk`: the part of a joint's jerk the path's makes shrinks with the window.
        let whole = Shares {
            accel,
            ..Shares::WHOLE
        };
        let (mut path, mut pace, mut window_s, mut shares) = fitted(whole, 0.0)?;
        // Where the average passes a channel's top frequency the sampled check slows all of
        // it: timed again to that share of the channels' top frequencies, and the faster
        // (judged on the samples, before any rows) kept.
        if let Some((duration_s, speed)) =
            smoothed(&path, &pace, window_s).and_then(|c| probe(&c, trapezoid))
            && speed < 1.0
            && let Ok(again) = fitted(Shares { speed, ..shares }, window_s)
            && smoothed(&again.0, &again.1, again.2)
                .and_then(|c| probe(&c, trapezoid))
                .is_some_and(|(d, _)| d < duration_s)
        {
            (path, pace, window_s, shares) = again;
        }
        for widening in 0..=JERK_WIDENINGS {
            let outcome = smoothed(&path, &pace, window_s)
                .ok_or(PlanError::SCurveUnderDriveLimits)
                .and_then(|course| plan(&course, trapezoid));
            let widen = match &outcome {
                Err(PlanError::OverMaxJerk { jerk, max_jerk, .. }) => jerk / max_jerk,
                _ => 0.0,
            };
            if !refused_by_a_drive(&outcome) {
                return outcome;
            }
            last = outcome;
            if widen <= 1.0 || widening == JERK_WIDENINGS {
                break;
            }
            // A longer window lags more: the centripetal limit fitted again.
            (path, pace, window_s, shares) =
                fitted(shares, window_s * widen * JERK_WIDENING_MARGIN)?;
        }
    }
    last
}

/// The faster of an S-curve averaged from the time-optimal motion (`averaged`) and the same
/// S-curve slowed as a whole (`slowed(floor)`, by `duration_s`): the slowed one is planned only
/// when the averaged one is refused or slower than the S-curve unslowed (`unslowed_s`), and
/// then no slower than the averaged one (`floor`, the least share of its accelerations
/// `slowed` tries: slowed to share `k`, a motion takes `1 / sqrt(k)` of its time). The refusal
/// of the slowed one when both are refused.
pub(in crate::plan) fn faster_s_curve<T>(
    averaged: Result<T, PlanError>,
    unslowed_s: Option<f64>,
    duration_s: impl Fn(&T) -> f64,
    slowed: impl FnOnce(f64) -> Result<T, PlanError>,
) -> Result<T, PlanError> {
    let floor = match (&averaged, unslowed_s) {
        (Ok(plan), Some(unslowed_s)) => {
            let averaged_s = duration_s(plan);
            if averaged_s <= unslowed_s {
                return averaged;
            }
            (unslowed_s / averaged_s).powi(2)
        }
        _ => 0.0,
    };
    match (averaged, slowed(floor)) {
        (Ok(a), Ok(s)) => Ok(if duration_s(&a) < duration_s(&s) {
            a
        } else {
            s
        }),
        (Ok(a), Err(_)) => Ok(a),
        (Err(_), slowed) => slowed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plans stood in for by their durations.
    fn faster(
        averaged: Result<f64, PlanError>,
        unslowed_s: Option<f64>,
        slowed: Result<f64, PlanError>,
    ) -> (Result<f64, PlanError>, Option<f64>) {
        let mut floor = None;
        let chosen = faster_s_curve(
            averaged,
            unslowed_s,
            |d| *d,
            |f| {
                floor = Some(f);
                slowed
            },
        );
        (chosen, floor)
    }

    #[test]
    fn the_averaged_s_curve_is_taken_alone_when_no_slowing_could_beat_it() {
        // No slower than the S-curve unslowed: slowing only lengthens that.
        assert_eq!(faster(Ok(1.5), Some(1.5), Ok(1.4)), (Ok(1.5), None));
        // Slower than it: the slowed one is tried down to the share whose time is the
        // averaged one's, (1.5 / 2.0)^2, and the faster taken.
        assert_eq!(faster(Ok(2.0), Some(1.5), Ok(1.8)), (Ok(1.8), Some(0.5625)));
        assert_eq!(faster(Ok(2.0), Some(1.5), Ok(2.1)), (Ok(2.0), Some(0.5625)));
        // The slowed one refused (not even at that share): the averaged one.
        let refused = Err(PlanError::SCurveUnderDriveLimits);
        assert_eq!(
            faster(Ok(2.0), Some(1.5), refused.clone()),
            (Ok(2.0), Some(0.5625))
        );
        // The averaged one refused: the slowed one, searched all the way, or its refusal.
        assert_eq!(
            faster(refused.clone(), Some(1.5), Ok(2.6)),
            (Ok(2.6), Some(0.0))
        );
        assert_eq!(
            faster(refused.clone(), None, refused.clone()),
            (refused, Some(0.0))
        );
    }
}
