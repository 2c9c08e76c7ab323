//! A section cut into parts, chained at speed through the PLC's waiting start, where one start
//! cannot run it: where its tables would not fit a channel's area or 8 segments (cut in halves
//! until they do), where a bounded-error plan fails because a joint first moves too late into
//! it for one table to hold its channel back (cut just before that joint moves), and where a
//! joint reverses while another moves, or a channel would need a later F174 segment (its next
//! segment would start up to a PLC scan late, off the path; cut at its extreme count, or before
//! the segment). Every cut falls on a sample point, where every channel's row ends at the same
//! planned instant; each part is planned from exactly the counts the one before it ends on and
//! judged by the execution model on its own, against the same path and the same profile.

use rayon::prelude::*;

use crate::kinematics::JOINTS;
use crate::robot::{Motion, Robot};

use super::super::course::Course;
use super::super::error::PlanError;
use super::super::part::{named, plan_start};
use super::super::planned::Plan;
use super::super::sampled::Sampled;
use super::super::start::Start;

/// The shortest part a section is cut into, s: chaining needs the next part uploaded while one
/// runs.
pub const MIN_PART_S: f64 = 0.1;
/// How long before a late joint's first pulse the part that starts it begins, s: its first row
/// then lands its first pulse within this of the start, where a whole-hertz frequency is fine
/// enough.
const LEAD_S: f64 = 0.05;

/// Plans `course` from `start` into one start or, where it must be cut, several parts chained
/// at speed (see the module's docs).
pub(super) fn parts(
    robot: &Robot,
    course: &Course,
    start: &Start,
    motion: Motion,
) -> Result<Vec<Plan>, PlanError> {
    let sampled = Sampled::new(robot, course, start, motion)?;
    let ahead = planned_ahead(&sampled, start.counts);
    parts_in_turn(robot, &sampled, start, ahead)
}

/// Sample points in the shortest part ([`MIN_PART_S`]).
fn min_points(sampled: &Sampled) -> usize {
    (MIN_PART_S / sampled.profile.period_s).ceil() as usize
}

/// [`parts`] of `sampled`, one after the other, each from the counts the one before ended on,
/// taking a plan of `ahead` where it was made from those very counts.
pub(super) fn parts_in_turn(
    robot: &Robot,
    sampled: &Sampled,
    start: &Start,
    mut ahead: Vec<Ahead>,
) -> Result<Vec<Plan>, PlanError> {
    let mut todo = vec![(0, sampled.last_point())];
    let mut plans = Vec::new();
    let mut counts = start.counts;
    while let Some((first, end)) = todo.pop() {
        if sampled.cut_for_segments()
            && let Some(cut) = sampled.reversal_cut(first, end)
        {
            todo.push((cut, end));
            todo.push((first, cut));
            continue;
        }
        let planned = Ahead::take(&mut ahead, first, end, counts)
            .unwrap_or_else(|| plan_start(sampled, first, end, counts));
        let split = match planned {
            // A part plays as planned only with one segment per channel.
            Ok(plan)
                if sampled.cut_for_segments()
                    && let Some(cut) = segment_cut(sampled, &plan, first, end) =>
            {
                cut
            }
            Ok(plan) => {
                counts = plan.end_counts();
                plans.push(plan);
                continue;
            }
            Err(e) => cut_refused(robot, sampled, e, (first, end), counts)?,
        };
        todo.push((split, end));
        todo.push((first, split));
    }
    Ok(plans)
}

/// Where part `first..end`, refused with `e` from `counts`, is cut in two to be planned again
/// (too big: in the middle; a tolerance too small: before the late joint moves), or the
/// refusal (named for the part) when it cannot be.
fn cut_refused(
    robot: &Robot,
    sampled: &Sampled,
    e: PlanError,
    (first, end): (usize, usize),
    counts: [i64; JOINTS],
) -> Result<usize, PlanError> {
    let min_points = min_points(sampled);
    match e {
        e if e.too_big() && end - first >= 2 * min_points => Ok(first + (end - first) / 2),
        e @ PlanError::ToleranceTooSmall { .. } => late_cut(sampled, first, end, min_points)
            .ok_or_else(|| {
                late_start(robot, sampled, first, end)
                    .unwrap_or_else(|| named(sampled, e, first, end, counts))
            }),
        e => Err(e),
    }
}

/// A part planned ahead of its turn ([`planned_ahead`]).
pub(super) struct Ahead {
    pub(super) first: usize,
    pub(super) end: usize,
    /// The counts it was planned from.
    pub(super) counts: [i64; JOINTS],
    pub(super) plan: Result<Plan, PlanError>,
}

impl Ahead {
    /// The plan made ahead of part `first..end` from `counts`, taken out of `ahead`.
    fn take(
        ahead: &mut Vec<Self>,
        first: usize,
        end: usize,
        counts: [i64; JOINTS],
    ) -> Option<Result<Plan, PlanError>> {
        let i = ahead
            .iter()
            .position(|a| a.first == first && a.end == end && a.counts == counts)?;
        Some(ahead.swap_remove(i).plan)
    }
}

/// The parts a bounded-error section is cut into at reversals ([`Sampled::reversal_cut`],
/// before any is planned), planned side by side on the machine's cores, each from the counts the
/// samples give at its first point (the first from `start`): [`parts`] takes such a plan only
/// when the part before did end on those counts, so the result is the one planning them in turn
/// gives. Empty when there is nothing to plan side by side.
pub(super) fn planned_ahead(sampled: &Sampled, start: [i64; JOINTS]) -> Vec<Ahead> {
    // A joint move's polyline remembers where its last search ended: not measured side by side.
    if sampled.bounded().is_none() || sampled.course.path().is_none() {
        return Vec::new();
    }
    let mut cut = Vec::new();
    let mut todo = vec![(0, sampled.last_point())];
    while let Some((first, end)) = todo.pop() {
        match sampled.reversal_cut(first, end) {
            Some(at) => {
                todo.push((at, end));
                todo.push((first, at));
            }
            None => cut.push((first, end)),
        }
    }
    if cut.len() < 2 {
        return Vec::new();
    }
    cut.into_par_iter()
        .map(|(first, end)| {
            let counts = if first == 0 {
                start
            } else {
                sampled.samples.counts[first]
            };
            Ahead {
                first,
                end,
                counts,
                plan: plan_start(sampled, first, end, counts),
            }
        })
        .collect()
}

/// Where to cut a part from sample point `first` to `end` whose `plan` gives a channel a later
/// F174 segment (a run that no one frequency range plays within its windows): at the last sample
/// point before the segment begins, for the same reason as at a reversal
/// ([`Sampled::reversal_cut`]), or at the first point after `first` when it begins before that.
/// `None` when it has none, or the part is one sample interval long.
fn segment_cut(sampled: &Sampled, plan: &Plan, first: usize, end: usize) -> Option<usize> {
    let (_, at_s) = plan.later_segment()?;
    let at_s = plan.window.from_s + at_s;
    let cut = (first + 1..end)
        .rev()
        .find(|&i| sampled.time_s(i) <= at_s)
        .unwrap_or(first + 1);
    (cut < end).then_some(cut)
}

/// Every joint that first moves more than [`LATE_START_S`] after sample point `from` (and by
/// `to`), with the point where its count first changes, in the joints' order: F174 cannot hold
/// a channel back that long with the precision a bounded-error plan needs (the first pulse of a
/// table lands one period of a whole-hertz frequency after the start: 1/1.5, 1/2, 1/3 s ...).
fn late_joints<'s>(
    sampled: &'s Sampled<'_>,
    from: usize,
    to: usize,
) -> impl Iterator<Item = (usize, usize)> + 's {
    let counts = &sampled.samples.counts;
    let dt_s = sampled.profile.period_s;
    (0..crate::kinematics::JOINTS).filter_map(move |j| {
        let moved = (from + 1..=to).find(|&i| counts[i][j] != counts[from][j])?;
        ((moved - from) as f64 * dt_s > LATE_START_S).then_some((j, moved))
    })
}

/// Where to cut the course between sample points `from` and `to`: [`LEAD_S`] before the first
/// pulse of a joint that starts late (the earliest such cut over the joints), when both sides
/// keep at least `min_points`.
fn late_cut(sampled: &Sampled, from: usize, to: usize, min_points: usize) -> Option<usize> {
    let lead = (LEAD_S / sampled.profile.period_s).round() as usize;
    late_joints(sampled, from, to)
        .map(|(_, moved)| moved.saturating_sub(lead))
        .filter(|&cut| cut >= from + min_points && cut + min_points <= to)
        .min()
}

/// A failed bounded-error plan between sample points `from` and `to` that no cut could mend,
/// put down to the first joint that starts late in it (when one does), with when it first moves
/// into the section.
fn late_start(robot: &Robot, sampled: &Sampled, from: usize, to: usize) -> Option<PlanError> {
    let (j, moved) = late_joints(sampled, from, to).next()?;
    Some(PlanError::LateStart {
        joint: robot.joints[j].name.clone(),
        at_s: moved as f64 * sampled.profile.period_s,
    })
}

/// How late into a part a joint may first move before the part is cut there (or a failed
/// bounded-error plan put down to it), s.
const LATE_START_S: f64 = 0.1;
