//! Paths through waypoints: the path is built (lines, arcs, blended corners), cut at every stop
//! into sections, and each section planned as one move along it, each starting from the counts
//! the one before it ends on, so the PLC can chain them through its waiting start.
//!
//! A section runs on one trapezoid, at its pace ([`Pace`]): at the speed asked on lines, and on
//! an arc too tight for it at what the path's centripetal acceleration limit allows
//! (`v = sqrt(a r)`), for that arc alone, slowing before it and speeding up after it at the
//! profile's own acceleration (speed / acceleration time). Under `slow-down`, the stretches
//! where a joint's channel would pass its top frequency are slowed for in the same way
//! ([`frequency_caps`]); what that misses, the sampled check lowers the whole section's speed
//! for, as for a line. Under `reject` such a section is refused. An S-curve on a section whose
//! pace would change speed so (an acceleration stepping on and off, past its jerk) is timed as
//! under drive limits: the time-optimal motion averaged to its jerk.
//!
//! A section may need more than one start ("parts", chained at speed through the PLC's waiting
//! start): where its tables would not fit a channel's area or 8 segments (cut in halves until
//! they do), where a bounded-error plan fails because a joint first moves too late into it
//! for one table to hold its channel back (cut just before that joint moves), and, in a
//! bounded-error plan, where a joint reverses while another moves (its next segment would start
//! up to a PLC scan late, off the path; cut at its extreme count). Every
//! cut falls on a sample point, where every channel's row ends at the same planned instant;
//! each part is planned from exactly the counts the one before it ends on and judged by the
//! execution model on its own, against the same path and the same profile.

use crate::geometry::{Corner, Element, Pace, Path, PathSpec, Pose, SpeedCap};
use crate::kinematics::{JOINTS, Kinematics};
use crate::robot::{Method, Motion, OverSpeed, Ramp, Robot};

use crate::table::TableProblem;

use rayon::prelude::*;

use super::course::Course;
use super::{Origin, Plan, PlanError, Sampled, Start};

/// A path to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PathRequest {
    /// Where the robot starts: the first section is planned from its counts.
    pub from: Origin,
    /// Where the path as written starts (its document's `start`), when it says: the path is
    /// built from here, never from `from`, which must lie within [`SECTION_START_SLACK_MM`] of
    /// it. `None`: the path starts at `from`'s pose.
    pub start: Option<Pose>,
    /// Its elements, each with the corner at its end.
    pub elements: Vec<(Element, Corner)>,
    /// The motion settings: the speed is the tool point's along the path.
    pub motion: Motion,
    /// The largest acceleration across the path (centripetal, on arcs and blends), mm/s^2.
    pub path_accel_mm_s2: f64,
}

/// A planned path: the path as built and its sections between stops.
#[derive(Debug, Clone, PartialEq)]
pub struct PathPlan {
    /// The path as planned (blends included).
    pub path: Path,
    /// The sections, in order; each starts from the previous one's end counts.
    pub sections: Vec<SectionPlan>,
}

/// One section of a path (from a stop to the next) as planned.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionPlan {
    /// The section, measured from its start.
    pub path: Path,
    /// Its starts: one, or several parts chained at speed, each from the counts the one before
    /// it ends on.
    pub starts: Vec<Plan>,
}

impl SectionPlan {
    /// The counts it ends on.
    #[must_use]
    pub fn end_counts(&self) -> [i64; crate::kinematics::JOINTS] {
        self.starts[self.starts.len() - 1].end_counts()
    }
}

impl PathPlan {
    /// Every start, in order, over all sections.
    pub fn starts(&self) -> impl Iterator<Item = &Plan> {
        self.sections.iter().flat_map(|s| s.starts.iter())
    }

    /// Whether every start's tables may be sent.
    #[must_use]
    pub fn valid(&self) -> bool {
        self.starts().all(Plan::valid)
    }

    /// Its duration, s (starts back to back, without the PLC's time between them).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.starts().map(Plan::duration_s).sum()
    }

    /// The largest path deviation of any start, mm.
    #[must_use]
    pub fn max_deviation_mm(&self) -> f64 {
        self.starts()
            .map(|p| p.figures.path_deviation_mm)
            .fold(0.0, f64::max)
    }
}

/// Plans `req` for `robot`.
///
/// # Errors
/// When the path cannot be built ([`PlanError::Path`]) or a section cannot be planned (the
/// section's error, naming the elements it covers).
pub fn plan_path(robot: &Robot, req: &PathRequest) -> Result<PathPlan, PlanError> {
    let planned = plan_path_once(robot, req);
    let Err(PlanError::Section {
        section,
        elements,
        source,
    }) = &planned
    else {
        return planned;
    };
    let PlanError::ToleranceTooSmall {
        tolerance_mm,
        floor_mm,
        ref creep,
        works_mm: Some(mut works_mm),
    } = **source
    else {
        return planned;
    };
    // The tolerance named to work is the one that worked for the refusing start: the whole
    // path is planned again with it (and with what a later refusal names) before it is named.
    let refused = |works_mm| PlanError::Section {
        section: *section,
        elements: elements.clone(),
        source: Box::new(PlanError::ToleranceTooSmall {
            tolerance_mm,
            floor_mm,
            creep: creep.clone(),
            works_mm,
        }),
    };
    for _ in 0..WORKS_TRIES {
        let mut again = req.clone();
        again.motion.method = Method::BoundedError {
            tolerance_mm: works_mm,
        };
        match plan_path_once(robot, &again) {
            Ok(_) => return Err(refused(Some(works_mm))),
            Err(PlanError::Section { source, .. }) => match *source {
                PlanError::ToleranceTooSmall {
                    works_mm: Some(more),
                    ..
                } if more > works_mm => works_mm = more,
                _ => break,
            },
            Err(_) => break,
        }
    }
    Err(refused(None))
}

/// Plans of the whole path made to check a tolerance named to work ([`plan_path`]).
const WORKS_TRIES: usize = 4;

/// [`plan_path`], with a refused tolerance's suggestion as its start found it.
fn plan_path_once(robot: &Robot, req: &PathRequest) -> Result<PathPlan, PlanError> {
    if !(req.path_accel_mm_s2.is_finite() && req.path_accel_mm_s2 > 0.0) {
        return Err(PlanError::PathAccel {
            accel_mm_s2: req.path_accel_mm_s2,
        });
    }
    let mut start = Start::at(robot, req.from)?;
    for (element, _) in &req.elements {
        check_pose(&element.to())?;
    }
    let here = robot.kinematics.fk(&start.values);
    let spec = PathSpec {
        start: stated_start(req.start, here)?,
        elements: req.elements.clone(),
    };
    let path = Path::build(&spec)?;
    let mut sections = Vec::new();
    for (n, section) in path.sections().into_iter().enumerate() {
        let starts = section_plan(robot, &section, &start, req.motion, req.path_accel_mm_s2)
            .map_err(|(elements, source)| PlanError::Section {
                section: n + 1,
                elements,
                source: Box::new(source),
            })?;
        let planned = SectionPlan {
            path: section,
            starts,
        };
        let end = planned.end_counts();
        start = Start {
            values: robot.values_of(&end),
            counts: end,
        };
        sections.push(planned);
    }
    Ok(PathPlan { path, sections })
}

/// How far the robot may be from a section's start when the section is planned from its
/// counts, mm: a section chained behind the one before starts within half a pulse of it. The
/// same slack holds between a path's stated start and the robot's pose when it begins.
pub const SECTION_START_SLACK_MM: f64 = 0.1;

/// Where a path is built from: its `stated` start when it has one and the robot's pose `here`
/// is within [`SECTION_START_SLACK_MM`] of it (the robot's pose never reshapes an element),
/// else `here`.
///
/// # Errors
/// [`PlanError::NotAtPathStart`] naming both poses and the distance.
fn stated_start(stated: Option<Pose>, here: Pose) -> Result<Pose, PlanError> {
    let Some(stated) = stated else {
        return Ok(here);
    };
    let off_mm = (stated.position_mm - here.position_mm).norm();
    if off_mm.is_nan() || off_mm > SECTION_START_SLACK_MM {
        return Err(PlanError::NotAtPathStart {
            start: stated.to_mm_deg(),
            robot: here.to_mm_deg(),
            off_mm,
            slack_mm: SECTION_START_SLACK_MM,
        });
    }
    Ok(stated)
}

/// Plans one section of a path from `counts`, where the robot will be when it starts (the end
/// counts of the section before it): its starts, one or several parts chained at speed.
///
/// # Errors
/// [`PlanError::NotAtSectionStart`] when the counts' pose is more than
/// [`SECTION_START_SLACK_MM`] from the section's start; else as [`plan_path`].
pub fn plan_section(
    robot: &Robot,
    section: &Path,
    motion: Motion,
    path_accel_mm_s2: f64,
    counts: [i64; crate::kinematics::JOINTS],
) -> Result<Vec<Plan>, PlanError> {
    let start = Start::at(robot, Origin::Counts(counts))?;
    let here = robot.kinematics.fk(&start.values).position_mm;
    let off_mm = (here - section.at(0.0).position_mm).norm();
    if off_mm > SECTION_START_SLACK_MM {
        return Err(PlanError::NotAtSectionStart {
            off_mm,
            slack_mm: SECTION_START_SLACK_MM,
        });
    }
    section_plan(robot, section, &start, motion, path_accel_mm_s2).map_err(|(_, source)| source)
}

/// Plans `section` from `start` into its starts; an error comes with the elements the section
/// covers.
fn section_plan(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: Motion,
    path_accel_mm_s2: f64,
) -> Result<Vec<Plan>, (String, PlanError)> {
    let elements = covered(section);
    super::dynamics::jerk_needs_s_curve(robot, asked.ramp).map_err(|e| (elements.clone(), e))?;
    let s_curve = matches!(asked.ramp, Ramp::SCurve { .. });
    // An S-curve whose pace would change speed along the section (a tight arc; under
    // `slow-down`, where a channel would be too fast) is timed as a robot with drive limits
    // is: the pace's changes of speed step the acceleration on and off.
    if robot.has_dynamics()
        || (s_curve && !as_asked_pace(robot, section, start, &asked, path_accel_mm_s2).is_uniform())
    {
        let breaks_mm: Vec<f64> = section
            .pieces()
            .iter()
            .skip(1)
            .map(|p| p.start_mm)
            .collect();
        let shape = super::dynamics::Shape {
            length_mm: section.length_mm(),
            pose_at: &|s| section.at(s),
            curvature_at: &|s| section.curvature_per_mm(s),
            breaks_mm: &breaks_mm,
        };
        let pace = |motion: &Motion, shares: super::dynamics::Shares, rows_any_length: bool| {
            let limits = super::dynamics::PathLimits {
                centripetal_mm_s2: path_accel_mm_s2,
                rest_row_s: asked.period_s,
                rows_any_length,
                accel_share: shares.accel,
                speed_share: shares.speed,
                centripetal_share: shares.centripetal,
            };
            super::dynamics::pace(robot, &shape, &start.values, motion, &limits)
        };
        if s_curve {
            // The time-optimal motion averaged to the jerk, or the S-curve slowed as a whole
            // (its path acceleration with the rest) until the drives follow it: the faster.
            let averaged = super::dynamics::rest_rows_first(&asked, |rows_any_length| {
                super::dynamics::averaged(
                    &asked,
                    path_accel_mm_s2,
                    |motion, share| Ok((section.clone(), pace(motion, share, rows_any_length)?)),
                    |course, motion| {
                        let mut starts = parts(robot, course, start, motion)?;
                        for s in &mut starts {
                            s.motion.ramp = asked.ramp;
                            super::dynamics::within_limits(robot, s)?;
                        }
                        Ok(starts)
                    },
                    |course, motion| super::dynamics::probe(robot, course, start, motion),
                )
            });
            if !robot.has_dynamics() {
                // Without drive limits nothing slows the S-curve as a whole but a channel too
                // fast (the sampled check), and on that pace its jerk breaks at the arcs: the
                // averaged one, where it can be planned.
                return averaged
                    .or_else(|_| planned_as_asked(robot, section, start, asked, path_accel_mm_s2))
                    .map_err(|source| (elements, source));
            }
            let duration_s = |starts: &Vec<Plan>| starts.iter().map(Plan::duration_s).sum();
            return super::dynamics::faster_s_curve(averaged, None, duration_s, |floor| {
                super::dynamics::followed(floor, |k| {
                    let mut starts = planned_as_asked(
                        robot,
                        section,
                        start,
                        super::dynamics::slowed(&asked, k),
                        path_accel_mm_s2 * k,
                    )?;
                    for s in &mut starts {
                        s.speed_factor *= k.sqrt();
                        super::dynamics::within_limits(robot, s)?;
                    }
                    Ok(starts)
                })
            })
            .map_err(|source| (elements, source));
        }
        // A timing whose rows a drive refuses (by a little, where the grid between its points
        // or a kink's rounding missed it) is made again to smaller shares of the limits.
        let timed = |accel_share: f64, rows_any_length: bool| {
            let shares = super::dynamics::Shares {
                accel: accel_share,
                ..super::dynamics::Shares::WHOLE
            };
            let pace = pace(&asked, shares, rows_any_length)?;
            let course = Course::Path {
                path: section.clone(),
                pace,
            };
            parts(robot, &course, start, asked)
        };
        return super::dynamics::rest_rows_first(&asked, |rows_any_length| {
            let mut outcome = timed(1.0, rows_any_length);
            for accel_share in super::dynamics::RETIMING {
                if !matches!(
                    outcome,
                    Err(PlanError::RowStep { .. } | PlanError::RestRow { .. })
                ) {
                    break;
                }
                outcome = timed(accel_share, rows_any_length);
            }
            outcome
        })
        .map_err(|source| (elements, source));
    }
    planned_as_asked(robot, section, start, asked, path_accel_mm_s2)
        .map_err(|source| (elements, source))
}

/// [`section_plan`] for a robot without drive limits: the profile along a pace that slows only
/// for tight arcs and, under `slow-down` with a trapezoid, where a channel would be too fast.
///
/// An S-curve is not slowed there: the pace's change of speed into and out of a cap is a
/// constant acceleration that steps on and off, past the jerk asked. The sampled check slows
/// the whole section instead, as it does a line, and the S-curve keeps its jerk.
fn planned_as_asked(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: Motion,
    path_accel_mm_s2: f64,
) -> Result<Vec<Plan>, PlanError> {
    // The pace an S-curve runs at has no caps: its arcs' alone, as under `reject`.
    let paced = match asked.ramp {
        Ramp::Trapezoid => asked,
        Ramp::SCurve { .. } => Motion {
            over_speed: OverSpeed::Reject,
            ..asked
        },
    };
    let course = Course::Path {
        path: section.clone(),
        pace: as_asked_pace(robot, section, start, &paced, path_accel_mm_s2),
    };
    parts(robot, &course, start, asked)
}

/// The pace a trapezoid of `asked` would run `section` at: slowed for tight arcs and, under
/// `slow-down`, where a channel would be too fast ([`frequency_caps`]).
fn as_asked_pace(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: &Motion,
    path_accel_mm_s2: f64,
) -> Pace {
    let caps = match asked.over_speed {
        OverSpeed::SlowDown => frequency_caps(robot, section, start, asked.speed_mm_s),
        OverSpeed::Reject => Vec::new(),
    };
    Pace::new(
        section,
        asked.speed_mm_s,
        path_accel_mm_s2,
        asked.speed_mm_s / asked.accel_s,
        &caps,
    )
}

/// The stretches a section is cut into to find where a joint would be too fast, mm.
const CAP_STRETCH_MM: f64 = 2.0;
/// The most such stretches in one section.
const MAX_CAP_STRETCHES: usize = 4_096;
/// The share of a channel's top frequency a capped stretch is planned to (the rest is left for
/// the joints' rates changing within a stretch, and for the rows' rounding).
const FREQUENCY_MARGIN: f64 = 0.97;

/// Under `slow-down`: every stretch (about [`CAP_STRETCH_MM`]) of `section` where a joint's
/// channel would pass [`FREQUENCY_MARGIN`] of its top frequency at `speed_mm_s`, capped at the
/// speed that keeps every channel within it, from the joints' pulses over the stretch (inverse
/// kinematics at its ends). Empty when a pose is out of reach: sampling the section says where.
/// Whatever the caps miss, the sampled check lowers the whole section's speed for, as before.
fn frequency_caps(robot: &Robot, section: &Path, start: &Start, speed_mm_s: f64) -> Vec<SpeedCap> {
    let length_mm = section.length_mm();
    let n = ((length_mm / CAP_STRETCH_MM).ceil() as usize).clamp(1, MAX_CAP_STRETCHES);
    let Ok(mut q) = robot.kinematics.ik(&section.at(0.0), Some(&start.values)) else {
        return Vec::new();
    };
    let mut caps = Vec::new();
    let mut from_mm = 0.0;
    for i in 1..=n {
        let to_mm = length_mm * i as f64 / n as f64;
        let Ok(next) = robot.kinematics.ik(&section.at(to_mm), Some(&q)) else {
            return Vec::new();
        };
        let fastest = robot
            .joints
            .iter()
            .zip(q.iter().zip(&next))
            .map(|(joint, (a, b))| {
                let pulses = (b - a).abs() / joint.step.abs();
                if pulses > 0.0 {
                    FREQUENCY_MARGIN * f64::from(joint.max_freq_hz) * (to_mm - from_mm) / pulses
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min);
        if fastest < speed_mm_s {
            caps.push(SpeedCap {
                from_mm,
                to_mm,
                speed_mm_s: fastest,
            });
        }
        (q, from_mm) = (next, to_mm);
    }
    caps
}

/// The shortest part a section is cut into, s: chaining needs the next part uploaded while one
/// runs.
pub const MIN_PART_S: f64 = 0.1;
/// How long before a late joint's first pulse the part that starts it begins, s: its first row
/// then lands its first pulse within this of the start, where a whole-hertz frequency is fine
/// enough.
const LEAD_S: f64 = 0.05;

/// Plans `course` from `start` into one start or, where it must be cut, several parts chained
/// at speed (see the module's docs).
fn parts(
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
fn parts_in_turn(
    robot: &Robot,
    sampled: &Sampled,
    start: &Start,
    mut ahead: Vec<Ahead>,
) -> Result<Vec<Plan>, PlanError> {
    let min_points = min_points(sampled);
    let mut todo = vec![(0, sampled.last_point())];
    let mut plans = Vec::new();
    let mut counts = start.counts;
    while let Some((first, end)) = todo.pop() {
        if sampled.cut_for_segments()
            && let Some(cut) = reversal_cut(sampled, first, end)
        {
            todo.push((cut, end));
            todo.push((first, cut));
            continue;
        }
        let planned = match ahead
            .iter()
            .position(|a| a.first == first && a.end == end && a.counts == counts)
        {
            Some(i) => ahead.swap_remove(i).plan,
            None => sampled.plan(first, end, counts),
        };
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
            Err(e) if too_big(&e) && end - first >= 2 * min_points => first + (end - first) / 2,
            Err(e @ PlanError::ToleranceTooSmall { .. }) => {
                match late_cut(sampled, first, end, min_points) {
                    Some(cut) => cut,
                    None => {
                        return Err(late_start(robot, sampled, first, end)
                            .unwrap_or_else(|| sampled.named(e, first, end, counts)));
                    }
                }
            }
            Err(e) => return Err(e),
        };
        todo.push((split, end));
        todo.push((first, split));
    }
    Ok(plans)
}

/// A part planned ahead of its turn ([`planned_ahead`]).
struct Ahead {
    first: usize,
    end: usize,
    /// The counts it was planned from.
    counts: [i64; JOINTS],
    plan: Result<Plan, PlanError>,
}

/// The parts a bounded-error section is cut into at reversals ([`reversal_cut`], before any is
/// planned), planned side by side on the machine's cores, each from the counts the samples give
/// at its first point (the first from `start`): [`parts`] takes such a plan only when the part
/// before did end on those counts, so the result is the one planning them in turn gives. Empty
/// when there is nothing to plan side by side.
fn planned_ahead(sampled: &Sampled, start: [i64; JOINTS]) -> Vec<Ahead> {
    // A joint move's polyline remembers where its last search ended: not measured side by side.
    if sampled.bounded().is_none() || sampled.course.path().is_none() {
        return Vec::new();
    }
    let mut cut = Vec::new();
    let mut todo = vec![(0, sampled.last_point())];
    while let Some((first, end)) = todo.pop() {
        match reversal_cut(sampled, first, end) {
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
                plan: sampled.plan(first, end, counts),
            }
        })
        .collect()
}

/// Whether a start's tables are refused only for their size (more than a channel's area, or
/// than 8 segments): a shorter start would fit.
fn too_big(e: &PlanError) -> bool {
    matches!(
        e,
        PlanError::InvalidTable {
            first: TableProblem::TooManySegments { .. } | TableProblem::AreaOverflow { .. },
            ..
        }
    )
}

/// Where to cut the course between sample points `from` and `to` so that no joint reverses
/// inside a part while another joint moves: at the first such reversal (the last point at the
/// joint's extreme count), wherever it falls between them. A reversal needs a new F174
/// segment, which the PLC starts in the scan after the one before ends: up to a scan late,
/// while the other channels run on, which leaves the path for the rest of the joint's run
/// (near a part's start as much as in its middle). At a cut every channel stops and restarts
/// together in the scan after the part ends: a pause on the path, no deviation.
pub(super) fn reversal_cut(sampled: &Sampled, from: usize, to: usize) -> Option<usize> {
    reversal(sampled, from, to).map(|(cut, _)| cut)
}

/// [`reversal_cut`] with the joint that reverses there.
pub(super) fn reversal(sampled: &Sampled, from: usize, to: usize) -> Option<(usize, usize)> {
    use crate::kinematics::JOINTS;
    let counts = &sampled.samples.counts;
    let others_move = |j: usize, i: usize| {
        (0..JOINTS).any(|k| k != j && counts[i.saturating_sub(1)][k] != counts[(i + 1).min(to)][k])
    };
    // Every joint's way so far (0 before it moves), the joints read side by side: the first
    // reversal met, the earliest joint's at a point, is every joint's first one's least.
    let mut direction = [0_i64; JOINTS];
    for i in from + 1..=to {
        for j in 0..JOINTS {
            let step = (counts[i][j] - counts[i - 1][j]).signum();
            if step == 0 {
                continue;
            }
            let reverses = direction[j] != 0 && step != direction[j];
            direction[j] = step;
            // Point i - 1 is the last at the extreme count.
            if reverses && others_move(j, i - 1) {
                return Some((i - 1, j));
            }
        }
    }
    None
}

/// Where to cut a part from sample point `first` to `end` whose `plan` gives a
/// channel a later F174 segment (a run that no one frequency range plays within its windows):
/// at the last sample point before the segment begins, for the same reason as at a reversal
/// ([`reversal_cut`]), or at the first point after `first` when it begins before that. `None`
/// when it has none, or the part is one sample interval long.
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

/// A waypoint's coordinates must be numbers.
fn check_pose(pose: &Pose) -> Result<(), PlanError> {
    crate::kinematics::check_finite(pose)?;
    Ok(())
}

/// The elements a section covers, as "3" or "2-4".
fn covered(section: &Path) -> String {
    let mut numbers = section.pieces().iter().filter_map(|p| p.element);
    let first = numbers.next();
    let last = numbers.next_back().or(first);
    match (first, last) {
        (Some(a), Some(b)) if a == b => a.to_string(),
        (Some(a), Some(b)) => format!("{a}-{b}"),
        _ => "(a blend)".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::geometry::ArcBy;
    use crate::robot::{Method, seed_robot};
    use crate::table::FrequencyModel;

    const P1: [f64; 3] = [-926.57, 535.03, 50.0];
    const P2: [f64; 3] = [-1144.43, 659.60, 186.60];

    fn pose(p: [f64; 3], dz: f64) -> Pose {
        Pose::from_mm_deg(p[0], p[1], p[2] + dz, 0.0)
    }

    fn motion(robot: &Robot, method: Method, model: FrequencyModel) -> Motion {
        Motion {
            method,
            frequency_model: model,
            ..robot.motion
        }
    }

    /// A pick and place on the seed robot through `waypoints` (then down to P2), every
    /// waypoint `corner`.
    fn cycle(
        waypoints: &[Pose],
        corner: Corner,
        method: Method,
        model: FrequencyModel,
    ) -> Result<PathPlan, PlanError> {
        let robot = seed_robot();
        let mut elements: Vec<_> = waypoints
            .iter()
            .map(|&to| (Element::Line { to }, corner))
            .collect();
        elements.push((Element::Line { to: pose(P2, 0.0) }, Corner::Stop));
        let req = PathRequest {
            from: Origin::Pose(pose(P1, 0.0)),
            start: None,
            elements,
            motion: motion(&robot, method, model),
            path_accel_mm_s2: 5_000.0,
        };
        plan_path(&robot, &req)
    }

    /// From P1 to `via`, a 20 mm blend there, on to `to`, at `motion` (5000 mm/s^2 on arcs).
    fn blended_via(via: Pose, to: Pose, motion: Motion) -> PathRequest {
        PathRequest {
            from: Origin::Pose(pose(P1, 0.0)),
            start: None,
            elements: vec![
                (Element::Line { to: via }, Corner::Blend(20.0)),
                (Element::Line { to }, Corner::Stop),
            ],
            motion,
            path_accel_mm_s2: 5_000.0,
        }
    }

    /// From P1 up and across to 100 mm above P2, a 20 mm blend there, down to P2, at `motion`.
    fn over_p2(motion: Motion) -> PathRequest {
        blended_via(pose(P2, 100.0), pose(P2, 0.0), motion)
    }

    /// `req`'s one section (planned as `plan`) run on the pace a trapezoid would have (as an
    /// S-curve was before stop 40): its duration and the tool's largest jerk along it.
    fn on_trapezoid_pace(robot: &Robot, req: &PathRequest, plan: &PathPlan) -> (f64, f64) {
        let section = &plan.sections[0].path;
        let start = Start::at(robot, req.from).unwrap();
        let pace = as_asked_pace(robot, section, &start, &req.motion, req.path_accel_mm_s2);
        let course = Course::Path {
            path: section.clone(),
            pace,
        };
        let starts = parts(robot, &course, &start, req.motion).unwrap();
        let jerk = starts
            .iter()
            .map(crate::testing::course_jerk)
            .fold(0.0, f64::max);
        (starts.iter().map(Plan::duration_s).sum(), jerk)
    }

    #[test]
    fn a_blended_cycle_is_one_section_within_tolerance_ends_on_p2_and_beats_stops() {
        let robot = seed_robot();
        let target = robot.counts_of(&robot.kinematics.ik(&pose(P2, 0.0), None).unwrap());
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        // Up and across at once to above P2, then down.
        let above = [pose(P2, 100.0)];
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let blended = cycle(&above, Corner::Blend(20.0), bounded, model).unwrap();
            assert_eq!(blended.sections.len(), 1);
            assert!(blended.valid());
            let deviation = blended.max_deviation_mm();
            assert!(deviation <= 0.05, "{model:?}: {deviation} mm");
            assert_eq!(blended.sections[0].end_counts(), target);
            // The blend is an arc of the planned path.
            let arcs = blended.path.pieces().iter().filter(|p| p.element.is_none());
            assert_eq!(arcs.count(), 1);
            let stopped = cycle(&above, Corner::Stop, bounded, model).unwrap();
            assert_eq!(stopped.sections.len(), 2);
            assert_eq!(stopped.sections[1].end_counts(), target);
            // The second section starts from the counts the first ends on.
            assert_eq!(
                stopped.sections[1].starts[0].samples.counts[0],
                stopped.sections[0].end_counts()
            );
            assert!(
                blended.duration_s() < stopped.duration_s(),
                "{} s blended, {} s stopped",
                blended.duration_s(),
                stopped.duration_s()
            );
        }
    }

    #[test]
    fn a_straight_lift_blended_into_the_traverse_is_cut_where_a_joint_starts_late_and_chains_exactly()
     {
        // Straight up from P1: the base and radial joints stand still until the blend, longer
        // than one table can hold them back within 0.05 mm, so the section is cut just before
        // the first of them moves.
        let robot = seed_robot();
        let lift = [pose(P1, 100.0), pose(P2, 100.0)];
        let target = robot.counts_of(&robot.kinematics.ik(&pose(P2, 0.0), None).unwrap());
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let blended = cycle(&lift, Corner::Blend(20.0), bounded, model).unwrap();
            assert_eq!(blended.sections.len(), 1);
            let starts = &blended.sections[0].starts;
            assert!(starts.len() >= 2, "{model:?}: {} starts", starts.len());
            assert!(blended.valid());
            assert!(
                blended.max_deviation_mm() <= 0.05,
                "{model:?}: {} mm",
                blended.max_deviation_mm()
            );
            // The first part is the lift alone: the base and radial joints have nothing to play
            // in it.
            assert!(starts[0].tables[0].segments.is_empty());
            assert!(starts[0].tables[2].segments.is_empty());
            assert!(!starts[1].tables[0].segments.is_empty());
            for pair in starts.windows(2) {
                // Every part begins on exactly the counts the one before ends on, at the
                // instant it ends, and only the last ends at rest.
                assert_eq!(pair[1].start_counts(), pair[0].end_counts());
                assert!((pair[1].window.from_s - pair[0].window.to_s).abs() < 1e-12);
                assert!(pair[0].window.ends_at_speed && pair[1].window.begins_at_speed());
                assert!(pair[0].duration_s() >= MIN_PART_S - 1e-9);
            }
            assert!(!starts[starts.len() - 1].window.ends_at_speed);
            assert_eq!(blended.sections[0].end_counts(), target);
            // Every channel plays each part in one segment (a later one would start up to a PLC
            // scan late, while the others run on): the radial joint starts from rest in the
            // second part and reaches 18 kHz, past range 0's 9.8 kHz, in one; d2 reverses at the
            // top of the second blend, where the section is cut.
            for (k, start) in starts.iter().enumerate() {
                for table in &start.tables {
                    assert!(
                        table.segments.len() <= 1,
                        "{model:?}: part {k} channel {} has {} segments",
                        table.channel,
                        table.segments.len()
                    );
                }
            }
            assert_eq!(
                starts.len(),
                3,
                "{model:?}: the lift, to d2's reversal, the rest"
            );
            let stopped = cycle(&lift, Corner::Stop, bounded, model).unwrap();
            assert_eq!(stopped.sections.len(), 3);
            assert!(stopped.max_deviation_mm() <= 0.05);
            assert!(
                blended.duration_s() < stopped.duration_s(),
                "{} s blended, {} s stopped",
                blended.duration_s(),
                stopped.duration_s()
            );
        }
    }

    #[test]
    fn a_section_too_long_for_one_table_area_is_split_into_parts_that_fit() {
        let mut robot = seed_robot();
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        let whole = cycle(
            &[pose(P2, 100.0)],
            Corner::Blend(20.0),
            bounded,
            FrequencyModel::Ideal,
        )
        .unwrap();
        // Up and across, then down: d2 reverses at the top of the blend while the others move,
        // so the section is two parts.
        let whole_starts = whole.sections[0].starts.len();
        assert_eq!(whole_starts, 2);
        let words = whole.sections[0]
            .starts
            .iter()
            .flat_map(|start| start.tables.iter().map(crate::table::encoded_words))
            .max()
            .unwrap();
        // Areas a little over half of what the largest table needs.
        let area = words / 2 + 10;
        robot.area_words = area;
        let req = over_p2(motion(&robot, bounded, FrequencyModel::Ideal));
        let split = plan_path(&robot, &req).unwrap_or_else(|e| panic!("area {area}: {e}"));
        let starts = &split.sections[0].starts;
        assert!(starts.len() > whole_starts + 1, "{} starts", starts.len());
        for (k, plan) in starts.iter().enumerate() {
            for (j, table) in plan.tables.iter().enumerate() {
                if !table.segments.is_empty() {
                    let used = crate::table::encoded_words(table);
                    assert!(used <= area, "start {k} joint {j}: {used} words > {area}");
                }
            }
        }
        for pair in starts.windows(2) {
            assert_eq!(pair[1].start_counts(), pair[0].end_counts());
        }
        assert!(
            split.max_deviation_mm() <= 0.05,
            "{}",
            split.max_deviation_mm()
        );
        assert_eq!(
            split.sections[0].end_counts(),
            whole.sections[0].end_counts()
        );
        // An area too small for any part of at least MIN_PART_S is refused naming the joint.
        robot.area_words = 30;
        let req = PathRequest {
            motion: motion(&robot, bounded, FrequencyModel::Ideal),
            ..req
        };
        let msg = plan_path(&robot, &req).unwrap_err().to_string();
        assert!(
            msg.starts_with("path section 1 (element 1-2): joint "),
            "{msg}"
        );
    }

    #[test]
    fn a_half_circle_is_planned_within_tolerance_and_slowed_for_its_radius() {
        let robot = seed_robot();
        let from = pose(P1, 0.0);
        let centre = from.position_mm - Vector3::new(100.0, 0.0, 0.0);
        let to = Pose {
            position_mm: centre - Vector3::new(100.0, 0.0, 0.0),
            a_rad: 0.0,
        };
        let req = |method, accel| PathRequest {
            from: Origin::Pose(from),
            start: None,
            elements: vec![(
                Element::Arc {
                    to,
                    by: ArcBy::Centre {
                        centre_mm: centre,
                        axis: Vector3::z(),
                        clockwise: false,
                    },
                },
                Corner::Stop,
            )],
            motion: motion(&robot, method, FrequencyModel::FpxDivider),
            path_accel_mm_s2: accel,
        };
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        let plan = plan_path(&robot, &req(bounded, 1_000.0)).unwrap();
        assert!(
            plan.max_deviation_mm() <= 0.05,
            "{}",
            plan.max_deviation_mm()
        );
        assert!((plan.path.length_mm() - 100.0 * std::f64::consts::PI).abs() < 1e-9);
        let whole = plan.path.length_mm();
        let cruise = plan.sections[0].starts[0].cruise_mm_s(0.0, whole);
        assert!(cruise > 239.0 && cruise <= 240.0, "{cruise} mm/s");
        // 100 mm/s^2 on r = 100 mm allows 100 mm/s, all the way round.
        let slow = plan_path(&robot, &req(bounded, 100.0)).unwrap();
        let start = &slow.sections[0].starts[0];
        let speed = start.cruise_mm_s(0.0, whole);
        assert!(speed > 99.0 && speed <= 100.0 + 1e-9, "{speed} mm/s");
        assert!(slow.duration_s() > whole / 100.0);
        let err = plan_path(&robot, &req(bounded, 0.0)).unwrap_err();
        assert_eq!(
            err.to_string(),
            "the path acceleration 0 mm/s^2 must be a number above 0"
        );
    }

    #[test]
    fn a_tight_blend_slows_the_tool_on_it_alone_within_the_centripetal_limit() {
        // Up and across to above P2, a 20 mm blend turning 133 deg (radius 8.6 mm), down to P2:
        // 5000 mm/s^2 allows 207.7 mm/s on the blend; the lines run at 240 mm/s.
        let accel = 5_000.0;
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let bounded = Method::BoundedError { tolerance_mm: 0.05 };
            let plan = cycle(&[pose(P2, 100.0)], Corner::Blend(20.0), bounded, model).unwrap();
            assert!(plan.valid());
            assert!(plan.max_deviation_mm() <= 0.05, "{model:?}");
            let blend = plan.path.pieces()[1];
            assert!(blend.element.is_none());
            let r = 1.0 / blend.primitive.curvature_per_mm();
            let allowed = (accel * r).sqrt();
            let (b0, b1) = (blend.start_mm, blend.start_mm + blend.primitive.length_mm());
            // The planned tool speed, by finite differences of the planned positions along every
            // start's time.
            let mut fastest_on_blend: f64 = 0.0;
            let mut fastest: f64 = 0.0;
            let dt = 1e-4;
            for start in plan.starts() {
                let steps = (start.duration_s() / dt) as usize;
                for i in 0..steps {
                    let t = i as f64 * dt;
                    let (p, q) = (
                        start.planned_position_mm(t),
                        start.planned_position_mm(t + dt),
                    );
                    let speed = (q - p).norm() / dt;
                    let s = start.course_mm(start.window.from_s + t);
                    if s > b0 && s < b1 {
                        fastest_on_blend = fastest_on_blend.max(speed);
                    }
                    fastest = fastest.max(speed);
                }
            }
            assert!(
                fastest_on_blend <= allowed * (1.0 + 1e-6),
                "{model:?}: {fastest_on_blend} mm/s on the blend, {allowed} allowed"
            );
            assert!(fastest_on_blend > allowed * 0.99, "{fastest_on_blend}");
            assert!(fastest > 239.0, "{model:?}: the lines at {fastest} mm/s");
            // The whole section slowed to the blend's speed would take longer.
            let length = plan.path.length_mm();
            assert!(
                plan.duration_s() < length / allowed,
                "{} s for {length} mm",
                plan.duration_s()
            );
        }
    }

    /// An S-curve through a blend too tight for its speed is the time-optimal motion averaged
    /// to its jerk: slowed for the blend alone, within its jerk, where on the trapezoid's pace
    /// (as it was) its change of speed into the blend passed the jerk many times over.
    #[test]
    fn an_s_curve_through_a_tight_blend_slows_for_it_alone_and_keeps_its_jerk() {
        // The blend of the test above: 207.7 mm/s allowed on it, 240 mm/s on the lines.
        let robot = seed_robot();
        let jerk_mm_s3 = 20_000.0;
        for method in [
            Method::ConstantPeriod,
            Method::BoundedError { tolerance_mm: 0.05 },
        ] {
            let req = over_p2(Motion {
                ramp: Ramp::SCurve { jerk_mm_s3 },
                ..motion(&robot, method, FrequencyModel::FpxDivider)
            });
            let plan = plan_path(&robot, &req).unwrap();
            assert!(plan.valid(), "{method:?}");
            for start in plan.starts() {
                let jerk = crate::testing::course_jerk(start);
                assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
                assert!(
                    start.pace.as_ref().is_some_and(Pace::from_rest),
                    "{method:?}"
                );
            }
            // Along the course: within the blend's speed on it, at the speed asked on a line.
            let blend = plan.path.pieces()[1];
            let allowed = (req.path_accel_mm_s2 / blend.primitive.curvature_per_mm()).sqrt();
            let (b0, b1) = (blend.start_mm, blend.start_mm + blend.primitive.length_mm());
            let (mut on_blend, mut fastest) = (0.0_f64, 0.0_f64);
            for start in plan.starts() {
                let at = |t: f64| start.course_mm(start.window.from_s + t);
                let dt = 1e-4;
                for i in 0..(start.duration_s() / dt) as usize {
                    let t = i as f64 * dt;
                    let speed = (at(t + dt) - at(t)) / dt;
                    if (b0..b1).contains(&at(t)) {
                        on_blend = on_blend.max(speed);
                    }
                    fastest = fastest.max(speed);
                }
            }
            assert!(on_blend <= allowed * (1.0 + 1e-6), "{method:?}: {on_blend}");
            assert!(fastest > 239.0, "{method:?}: the lines at {fastest} mm/s");
            // On the trapezoid's pace.
            let (_, stepped_jerk) = on_trapezoid_pace(&robot, &req, &plan);
            assert!(
                stepped_jerk > 3.0 * jerk_mm_s3,
                "{method:?}: {stepped_jerk}"
            );
        }
    }

    /// The seed robot with d2 (the lift, 40 pulses/mm) limited to 6 kHz, 150 mm/s straight up,
    /// and a lift of 100 mm blended into a level traverse of about 250 mm at 240 mm/s asked:
    /// the request for `motion` (its method, `over_speed` and ramp taken).
    fn lift_and_traverse() -> (Robot, impl Fn(Method, OverSpeed, Ramp) -> PathRequest) {
        let mut robot = seed_robot();
        robot.joints[1].max_freq_hz = 6_000;
        let asked = robot.motion;
        let level = Pose::from_mm_deg(P2[0], P2[1], P1[2] + 100.0, 0.0);
        let req = move |method, over_speed, ramp| {
            let motion = Motion {
                method,
                frequency_model: FrequencyModel::FpxDivider,
                over_speed,
                ramp,
                ..asked
            };
            blended_via(pose(P1, 100.0), level, motion)
        };
        (robot, req)
    }

    #[test]
    fn under_slow_down_a_joint_too_fast_on_one_stretch_slows_the_tool_there_alone() {
        let (robot, lift) = lift_and_traverse();
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        let req = |over_speed| lift(bounded, over_speed, Ramp::Trapezoid);
        let err = plan_path(&robot, &req(OverSpeed::Reject)).unwrap_err();
        assert!(err.to_string().contains("d2"), "{err}");
        let plan = plan_path(&robot, &req(OverSpeed::SlowDown)).unwrap();
        assert!(plan.valid());
        assert!(
            plan.max_deviation_mm() <= 0.05,
            "{}",
            plan.max_deviation_mm()
        );
        // No channel past its top frequency in the execution model.
        for start in plan.starts() {
            for row in start.row_timings() {
                let limit = f64::from(robot.joints[row.table].max_freq_hz);
                assert!(row.actual_hz <= limit, "{row:?}");
            }
            // The whole section was not slowed: its profile cruises at the speed asked.
            assert!(start.speed_factor > 0.99, "{}", start.speed_factor);
        }
        let first = plan.starts().next().unwrap();
        let lift = first.cruise_mm_s(0.0, 50.0);
        assert!(lift < 150.0 && lift > 140.0, "the lift at {lift} mm/s");
        let length = plan.path.length_mm();
        let traverse = plan
            .starts()
            .last()
            .unwrap()
            .cruise_mm_s(length - 100.0, length - 50.0);
        assert!(traverse > 239.0, "the traverse at {traverse} mm/s");
        // Faster than the whole section slowed to the lift's speed could be.
        assert!(
            plan.duration_s() < length / 150.0,
            "{} s",
            plan.duration_s()
        );
    }

    /// An S-curve that must slow on a stretch (under `slow-down`, where a channel would be too
    /// fast) is the time-optimal motion averaged to its jerk: a trapezoid's pace steps its
    /// acceleration on and off into the slow stretch, past any jerk (an S-curve run on that
    /// pace read 7.4 times its jerk on a line in the heavy properties, before). Slowed as a
    /// whole, it would keep its jerk too, but take longer; run on that pace, it takes about as
    /// long.
    #[test]
    fn under_slow_down_an_s_curve_slows_on_the_stretch_alone_and_keeps_its_jerk() {
        let (robot, lift) = lift_and_traverse();
        let jerk_mm_s3 = 5_000.0;
        for method in [
            Method::ConstantPeriod,
            Method::BoundedError { tolerance_mm: 0.05 },
        ] {
            let req = |ramp| lift(method, OverSpeed::SlowDown, ramp);
            let trapezoid = plan_path(&robot, &req(Ramp::Trapezoid)).unwrap();
            let s_curve_req = req(Ramp::SCurve { jerk_mm_s3 });
            let s_curve = plan_path(&robot, &s_curve_req).unwrap();
            assert!(trapezoid.valid() && s_curve.valid(), "{method:?}");
            for start in s_curve.starts() {
                let jerk = crate::testing::course_jerk(start);
                assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
                for row in start.row_timings() {
                    let limit = f64::from(robot.joints[row.table].max_freq_hz);
                    assert!(row.actual_hz <= limit, "{method:?} {row:?}");
                }
            }
            // The trapezoid's change into its slow stretch is far past that jerk.
            let stepped = trapezoid
                .starts()
                .map(crate::testing::course_jerk)
                .fold(0.0, f64::max);
            assert!(stepped > 10.0 * jerk_mm_s3, "{method:?}: {stepped} mm/s^3");
            // Slowed as a whole (what the sampled check does to an S-curve run as asked, no
            // longer slowed on the stretch), it keeps its jerk, and takes longer.
            let section = &s_curve.sections[0];
            let start = Start::at(&robot, s_curve_req.from).unwrap();
            let whole = planned_as_asked(
                &robot,
                &section.path,
                &start,
                s_curve_req.motion,
                s_curve_req.path_accel_mm_s2,
            )
            .unwrap();
            let whole_s: f64 = whole.iter().map(Plan::duration_s).sum();
            assert!(whole[0].speed_factor < 0.7, "{}", whole[0].speed_factor);
            for start in &whole {
                let jerk = crate::testing::course_jerk(start);
                assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
            }
            assert!(
                s_curve.duration_s() < 0.9 * whole_s,
                "{method:?}: {} s against {whole_s} s",
                s_curve.duration_s()
            );
            assert!(s_curve.duration_s() > trapezoid.duration_s(), "{method:?}");
            // Run on the trapezoid's pace (as it was), the S-curve passed its jerk many times
            // over, and took hardly less time: the average passes d2's top frequency after
            // the lift, and is timed again to the share of it the sampled check leaves.
            let (stepped_s, stepped_jerk) = on_trapezoid_pace(&robot, &s_curve_req, &s_curve);
            assert!(
                stepped_jerk > 10.0 * jerk_mm_s3,
                "{method:?}: {stepped_jerk}"
            );
            assert!(
                s_curve.duration_s() < 1.04 * stepped_s,
                "{method:?}: {} s against {stepped_s} s",
                s_curve.duration_s()
            );
        }
    }

    /// A part refused for its tolerance is cut again, without the planner searching for a
    /// tolerance that works; one that reaches the user names it, and it does plan the path.
    #[test]
    fn a_path_tolerance_below_the_pulse_grid_is_refused_naming_one_that_plans_it() {
        let above = [pose(P2, 100.0)];
        let asked = Method::BoundedError { tolerance_mm: 0.01 };
        let model = FrequencyModel::FpxDivider;
        let refused = cycle(&above, Corner::Blend(20.0), asked, model).unwrap_err();
        let PlanError::Section { source, .. } = &refused else {
            panic!("{refused}")
        };
        let PlanError::ToleranceTooSmall {
            floor_mm,
            works_mm: Some(works_mm),
            ..
        } = **source
        else {
            panic!("{refused}")
        };
        assert!(floor_mm > 0.01 && works_mm > floor_mm, "{refused}");
        assert!(
            refused
                .to_string()
                .contains(&format!("{works_mm} mm works"))
        );
        let works = Method::BoundedError {
            tolerance_mm: works_mm,
        };
        let plan = cycle(&above, Corner::Blend(20.0), works, model).unwrap();
        assert!(plan.valid() && plan.max_deviation_mm() <= works_mm);
    }

    #[test]
    fn a_section_that_leaves_a_joint_limit_is_refused_naming_its_elements() {
        let robot = seed_robot();
        let line = |to| Element::Line { to };
        let req = PathRequest {
            from: Origin::Pose(pose(P1, 0.0)),
            start: None,
            elements: vec![
                (line(pose(P1, 100.0)), Corner::Stop),
                (line(pose(P2, 100.0)), Corner::Blend(10.0)),
                (line(pose(P2, 2_000.0)), Corner::Stop),
            ],
            motion: motion(&robot, Method::ConstantPeriod, FrequencyModel::Ideal),
            path_accel_mm_s2: 2_000.0,
        };
        let msg = plan_path(&robot, &req).unwrap_err().to_string();
        assert!(msg.starts_with("path section 2 (element 2-3): "), "{msg}");
    }

    #[test]
    fn parts_planned_side_by_side_are_the_parts_planned_in_turn() {
        let robot = seed_robot();
        // Up and down three times, blended: d2 reverses at every blend, so the section is cut
        // into parts there.
        let elements = (1..=4)
            .map(|k| {
                let z = if k % 2 == 1 { 220.0 } else { 100.0 };
                let to = Pose::from_mm_deg(-800.0 + 160.0 * f64::from(k), 900.0, z, 0.0);
                let corner = if k == 4 {
                    Corner::Stop
                } else {
                    Corner::Blend(20.0)
                };
                (Element::Line { to }, corner)
            })
            .collect();
        let from = Pose::from_mm_deg(-800.0, 900.0, 100.0, 0.0);
        let start = Start::at(&robot, Origin::Pose(from)).unwrap();
        let spec = PathSpec {
            start: robot.kinematics.fk(&start.values),
            elements,
        };
        let section = Path::build(&spec).unwrap().sections().remove(0);
        let asked = motion(
            &robot,
            Method::BoundedError { tolerance_mm: 0.05 },
            FrequencyModel::FpxDivider,
        );
        let pace = Pace::new(
            &section,
            asked.speed_mm_s,
            5_000.0,
            asked.speed_mm_s / asked.accel_s,
            &[],
        );
        let course = Course::Path {
            path: section,
            pace,
        };
        let sampled = Sampled::new(&robot, &course, &start, asked).unwrap();
        let ahead = planned_ahead(&sampled, start.counts);
        assert!(ahead.len() >= 3, "{} parts planned ahead", ahead.len());

        let in_turn = parts_in_turn(&robot, &sampled, &start, Vec::new()).unwrap();
        let side_by_side = parts_in_turn(&robot, &sampled, &start, ahead).unwrap();
        assert_eq!(side_by_side, in_turn);

        // Parts planned ahead from counts the part before does not end on are planned again.
        let mut wrong = planned_ahead(&sampled, start.counts);
        for a in &mut wrong {
            a.counts[1] += 1;
            a.plan = sampled.plan(a.first, a.end, a.counts);
        }
        assert!(
            wrong
                .iter()
                .any(|a| a.plan.as_ref().is_ok_and(|p| !in_turn.contains(p)))
        );
        assert_eq!(
            parts_in_turn(&robot, &sampled, &start, wrong).unwrap(),
            in_turn
        );
    }
}
