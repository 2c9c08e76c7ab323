//! A section whose parts would chain at speed behind a part too short for it, planned with a
//! stop there instead.
//!
//! Two cuts can fall a sample apart (a joint's slow last rows before it reverses need a later
//! F174 segment, and it reverses a sample after: the first is cut where that segment begins,
//! the second at the reversal), leaving a part of one sample interval between them (50 ms).
//! The PLC cannot have the next part written, read back and started while so short a part
//! runs (a start over a serial link at 115200 baud takes about 0.15 s), and none of the three
//! can run as one start: the part before would hold the segment, the part after the reversal.
//! So a part shorter than [`MIN_PART_S`] with another part behind it is not chained: the tool
//! comes to rest where it ends (at a reversal, where that joint stands still anyway), and the
//! section is planned as two, each from rest, each of them again if it still has one. Where
//! the halves cannot be planned, or after [`MAX_ADDED_STOPS`], the section is kept as it was
//! planned: the daemon's pace check then refuses its start if the link cannot make it.

use crate::geometry::Path;
use crate::robot::{Motion, Robot};

use super::super::error::PlanError;
use super::super::planned::Plan;
use super::super::start::Start;
use super::parts::MIN_PART_S;
use super::{SectionPlan, section};

/// The most stops added to one section of the path as written.
pub(super) const MAX_ADDED_STOPS: usize = 4;

/// Plans `section` from `start` into one section, or several with a stop added where a part
/// too short to chain behind would have been (see the module's docs).
pub(super) fn plan(
    robot: &Robot,
    section: &Path,
    start: &Start,
    motion: Motion,
    path_accel_mm_s2: f64,
) -> Result<Vec<SectionPlan>, PlanError> {
    stopped(
        robot,
        section,
        start,
        (motion, path_accel_mm_s2),
        MAX_ADDED_STOPS,
    )
}

/// [`plan`], adding at most `stops_left` stops.
fn stopped(
    robot: &Robot,
    section: &Path,
    start: &Start,
    (motion, accel): (Motion, f64),
    stops_left: usize,
) -> Result<Vec<SectionPlan>, PlanError> {
    let starts = section::plan(robot, section, start, motion, accel)?;
    let halves = (stops_left > 0)
        .then(|| too_short_ends_mm(&starts))
        .flatten()
        .and_then(|s_mm| section.with_stop_at(s_mm));
    if let Some(halves) = halves {
        let mut planned = Vec::new();
        let mut from = Start {
            values: start.values,
            counts: start.counts,
        };
        for half in halves.sections() {
            let Ok(more) = stopped(robot, &half, &from, (motion, accel), stops_left - 1) else {
                break;
            };
            let end = more[more.len() - 1].end_counts();
            from = Start {
                values: robot.values_of(&end),
                counts: end,
            };
            planned.extend(more);
        }
        if planned.last().map(SectionPlan::end_counts) == Some(end_counts(&starts)) {
            return Ok(planned);
        }
    }
    Ok(vec![SectionPlan {
        path: section.clone(),
        starts,
    }])
}

/// The counts the last of `starts` ends on.
fn end_counts(starts: &[Plan]) -> [i64; crate::kinematics::JOINTS] {
    starts[starts.len() - 1].end_counts()
}

/// Where along its section the first part shorter than [`MIN_PART_S`] with a part behind it
/// ends, mm (`None`: every part chained behind is long enough).
fn too_short_ends_mm(starts: &[Plan]) -> Option<f64> {
    let (_, behind_last) = starts.split_last()?;
    behind_last
        .iter()
        .find(|p| p.duration_s() < MIN_PART_S - 1e-9)
        .map(|p| p.course_mm(p.window.to_s))
}
