//! PURE. An S-curve under drive limits as the time-optimal motion averaged: a line's or a path
//! section's time-optimal motion under every limit ([`super::timing`]), averaged over a moving
//! window ([`crate::geometry::Pace::smoothed`]) just long enough to hold its jerk within the
//! one asked ([`crate::geometry::Pace::jerk_window_s`]). The average keeps the path, its speed
//! and acceleration within the time-optimal motion's, and its jerk within the one asked; it
//! ends one window later. Where only a stretch of the path needs the speed to drop (near the
//! base axis, at a joint's reversal, on a tight arc) only that stretch is slowed, where
//! slowing the S-curve as a whole ([`super::slowed`](mod@super::slowed)) slows all of it; the
//! planner's strategy plans the faster of the two (`crate::plan::strategy`).
//!
//! The joints' accelerations are the average's through the path's derivatives, which change
//! along the window: near the axis a joint's can pass its limit by a little. The planned motion
//! is checked ([`super::within_limits`], by the course's [`Averaging::plan`]) and, where a drive
//! would not follow it, timed again to a lower share of every joint's acceleration
//! ([`RETIMING`]); where the average passes a channel's top frequency, to a lower share of every
//! top frequency ([`Shares`]).
//!
//! A path section whose speed must change along it is timed so without drive limits too: an
//! S-curve run on the pace of a trapezoid (whose changes of speed step the acceleration on and
//! off) would not keep its jerk.

use crate::geometry::{Pace, Path};
use crate::plan::error::PlanError;
use crate::robot::{Motion, Ramp};

use super::timing::{RETIMING, Shares};

/// The averaged motion is tabulated every this many seconds ([`Pace::smoothed`]).
const KNOT_S: f64 = 0.001;

/// How many times the window is lengthened for a joint's `max_jerk`, each time by the share its
/// jerk was over ([`JERK_WIDENING_MARGIN`] more).
const JERK_WIDENINGS: usize = 3;
/// The lengthening's margin over the share a joint's jerk was over.
const JERK_WIDENING_MARGIN: f64 = 1.05;

/// A line or a path section as the averaged S-curve is planned on it.
pub(in crate::plan) trait Averaging {
    /// What planning it gives: one start, or a section's starts.
    type Planned;

    /// Its path timed time-optimally under the trapezoid `motion` (the pace carries it) to
    /// `shares` of the limits, the zones around standstills planned for rows of any length or
    /// not (`rows_any_length`).
    fn timed(
        &self,
        motion: &Motion,
        shares: Shares,
        rows_any_length: bool,
    ) -> Result<(Path, Pace), PlanError>;

    /// Plans `path` at the averaged `pace` under the trapezoid `motion`, as the S-curve asked,
    /// and checks the planned motion ([`super::within_limits`]).
    fn plan(&self, path: &Path, pace: Pace, motion: Motion) -> Result<Self::Planned, PlanError>;

    /// `path` at `pace` sampled under `motion` as [`Averaging::plan`] would sample it: its
    /// duration and the speed factor the sampled check leaves it (`None` if it cannot be
    /// sampled).
    fn probe(&self, path: &Path, pace: Pace, motion: Motion) -> Option<(f64, f64)>;
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

/// How far `path` at `pace` (from rest, its profile cruising at `speed_mm_s`) passes the
/// centripetal limit `centripetal_mm_s2`: the largest `v^2 k / a` on its arcs, read every
/// [`CENTRIPETAL_STEP_MM`] and at least [`CENTRIPETAL_READS`] times along each (0 on a line).
fn centripetal_load(path: &Path, pace: &Pace, speed_mm_s: f64, centripetal_mm_s2: f64) -> f64 {
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

/// A timing of the path to be averaged: the path, its time-optimal pace, the window it is
/// averaged over and the shares of the limits it was timed to.
struct Fitted {
    path: Path,
    pace: Pace,
    window_s: f64,
    shares: Shares,
}

/// The search for the averaged S-curve of one course ([`averaged`]).
struct Averager<'a, A> {
    course: &'a A,
    /// The time-optimal motion's trapezoid (the S-curve asked, its ramp a trapezoid).
    trapezoid: Motion,
    jerk_mm_s3: f64,
    centripetal_mm_s2: f64,
    rows_any_length: bool,
}

impl<A: Averaging> Averager<'_, A> {
    /// `pace` averaged over `window_s`.
    fn smoothed(&self, pace: &Pace, window_s: f64) -> Option<Pace> {
        pace.smoothed(self.trapezoid.speed_mm_s, window_s, KNOT_S)
    }

    /// The path timed to `shares`, its window the one its jerk needs or `window_s`, the longer.
    fn timed_at(&self, shares: Shares, window_s: f64) -> Result<Fitted, PlanError> {
        let (path, pace) = self
            .course
            .timed(&self.trapezoid, shares, self.rows_any_length)?;
        let w = pace.jerk_window_s(self.trapezoid.speed_mm_s, self.jerk_mm_s3);
        Ok(Fitted {
            path,
            pace,
            window_s: w.max(window_s),
            shares,
        })
    }

    /// The path timed to `shares` and its window at least `window_s`, timed again to lower
    /// shares of the centripetal limit while its average passes it (entering an arc the motion
    /// slowed for, the average is still nearly as fast as before it); refused if it still does.
    fn fitted(&self, mut shares: Shares, window_s: f64) -> Result<Fitted, PlanError> {
        let mut fitted = self.timed_at(shares, window_s)?;
        // The load goes down with the share as a power of it (the average's speed on an arc
        // is partly the approach's, which the share does not lower): that power is measured
        // between the last two timings, from the square root (the arc's own speed) at first.
        let mut before: Option<(f64, f64)> = None;
        for retiming in 0..=CENTRIPETAL_RETIMINGS {
            let load = self
                .smoothed(&fitted.pace, fitted.window_s)
                .map_or(0.0, |pace| {
                    centripetal_load(
                        &fitted.path,
                        &pace,
                        self.trapezoid.speed_mm_s,
                        self.centripetal_mm_s2,
                    )
                });
            if load <= 1.0 {
                return Ok(fitted);
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
            fitted = self.timed_at(shares, fitted.window_s)?;
        }
        Err(PlanError::SCurveUnderDriveLimits)
    }

    /// The averaged motion of `fitted` sampled: its duration and the speed factor the sampled
    /// check leaves it ([`Averaging::probe`]).
    fn probe(&self, fitted: &Fitted) -> Option<(f64, f64)> {
        let pace = self.smoothed(&fitted.pace, fitted.window_s)?;
        self.course.probe(&fitted.path, pace, self.trapezoid)
    }

    /// `fitted`, or where its average passes a channel's top frequency (the sampled check
    /// would slow all of it) the path timed again to that share of the channels' top
    /// frequencies, if that is faster on its samples (before any rows are made).
    fn within_top_frequencies(&self, fitted: Fitted) -> Fitted {
        if let Some((duration_s, speed)) = self.probe(&fitted)
            && speed < 1.0
            && let Ok(again) = self.fitted(
                Shares {
                    speed,
                    ..fitted.shares
                },
                fitted.window_s,
            )
            && self.probe(&again).is_some_and(|(d, _)| d < duration_s)
        {
            return again;
        }
        fitted
    }

    /// Plans `fitted`'s averaged motion.
    fn plan(&self, fitted: &Fitted) -> Result<A::Planned, PlanError> {
        self.smoothed(&fitted.pace, fitted.window_s)
            .ok_or(PlanError::SCurveUnderDriveLimits)
            .and_then(|pace| self.course.plan(&fitted.path, pace, self.trapezoid))
    }
}

/// `course`'s time-optimal motion averaged to the S-curve `motion`'s jerk, planned
/// ([`Averaging`]); `centripetal_mm_s2` is the path's centripetal limit (infinite on a line).
/// The window is lengthened while a joint's jerk is over its `max_jerk` ([`JERK_WIDENINGS`]),
/// and the path timed again to a lower share ([`RETIMING`]) while a drive would not follow it;
/// the last refusal when none is followed.
///
/// Where the average passes a channel's top frequency, the sampled check slows the whole
/// motion; the path is then timed again to that share of every top frequency, which slows
/// only where a channel's frequency holds the motion back, and the faster of the two on their
/// samples is planned.
pub(in crate::plan) fn averaged<A: Averaging>(
    course: &A,
    motion: &Motion,
    centripetal_mm_s2: f64,
    rows_any_length: bool,
) -> Result<A::Planned, PlanError> {
    let Ramp::SCurve { jerk_mm_s3 } = motion.ramp else {
        return Err(PlanError::SCurveUnderDriveLimits);
    };
    let averager = Averager {
        course,
        trapezoid: Motion {
            ramp: Ramp::Trapezoid,
            ..*motion
        },
        jerk_mm_s3,
        centripetal_mm_s2,
        rows_any_length,
    };
    let mut last = Err(PlanError::SCurveUnderDriveLimits);
    for accel in std::iter::once(1.0).chain(RETIMING) {
        // The window the path's jerk needs, lengthened while a joint's jerk is over its
        // `max_jerk`: the part of a joint's jerk the path's makes shrinks with the window.
        let whole = Shares {
            accel,
            ..Shares::WHOLE
        };
        let mut fitted = averager.within_top_frequencies(averager.fitted(whole, 0.0)?);
        for widening in 0..=JERK_WIDENINGS {
            let outcome = averager.plan(&fitted);
            let widen = match &outcome {
                Err(PlanError::OverMaxJerk { jerk, max_jerk, .. }) => jerk / max_jerk,
                _ => 0.0,
            };
            if !outcome.as_ref().is_err_and(PlanError::refused_by_a_drive) {
                return outcome;
            }
            last = outcome;
            if widen <= 1.0 || widening == JERK_WIDENINGS {
                break;
            }
            // A longer window lags more: the centripetal limit fitted again.
            fitted = averager.fitted(
                fitted.shares,
                fitted.window_s * widen * JERK_WIDENING_MARGIN,
            )?;
        }
    }
    last
}
