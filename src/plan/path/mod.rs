//! Paths through waypoints: the path is built (lines, arcs, blended corners), cut at every stop
//! into sections, and each section planned as one move along it ([`section`]), each starting
//! from the counts the one before it ends on, so the PLC can chain them through its waiting
//! start. A section that cannot run as one start is cut into parts chained at speed
//! ([`parts`]); where that would chain behind a part too short for the PLC to have the next
//! one ready, the tool stops there instead and the section is planned as two ([`short`]).

mod parts;
mod section;
mod short;

use crate::geometry::{Corner, Element, Path, PathSpec, Pose};
use crate::kinematics::{JOINTS, Kinematics};
use crate::robot::{Method, Motion, Robot};

use super::Origin;
use super::error::PlanError;
use super::planned::Plan;
use super::start::Start;

pub use parts::MIN_PART_S;

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
    /// The sections, in order; each starts from the previous one's end counts. A section of
    /// the path may be planned as two or more, with a stop where a part too short to chain
    /// behind would have been (see `short.rs`).
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
    pub fn end_counts(&self) -> [i64; JOINTS] {
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
        let planned = short::plan(robot, &section, &start, req.motion, req.path_accel_mm_s2)
            .map_err(|source| PlanError::Section {
                section: n + 1,
                elements: covered(&section),
                source: Box::new(source),
            })?;
        let end = planned[planned.len() - 1].end_counts();
        start = Start {
            values: robot.values_of(&end),
            counts: end,
        };
        sections.extend(planned);
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
    counts: [i64; JOINTS],
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
    section::plan(robot, section, &start, motion, path_accel_mm_s2)
}

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
mod tests;
