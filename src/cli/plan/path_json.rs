//! The JSON document of a planned path (`"linterpd_plan": 1`, fields only ever added): the
//! primitives as planned (blends as arcs) with what the execution model says of each, a line of
//! figures per start, and one plan document per start.
//!
//! A primitive's `path_deviation_mm` is the largest distance from the planned path of the
//! executed positions (after every pulse event) whose nearest point of the path lies on it; its
//! `start_s` and `end_s` are when the planned motion enters and leaves it, from the path's start
//! with the starts back to back; its `cruise_mm_s` is the slowest the tool is planned to go on it
//! while the profile cruises (a tight arc's `sqrt(path_accel * r)`). A start's `speed_mm_s` is
//! its profile's cruising speed, the tool's on lines away from tight arcs.

use serde::Serialize;

use super::json;
use super::starts::{Start, elements_between, holding, time_at_mm};
use crate::geometry::{Path, Piece, Primitive};
use crate::plan::{MoveRequest, Origin, PathPlan, PathRequest};
use crate::robot::Robot;

#[derive(Debug, Serialize)]
pub(super) struct PathDocument {
    linterpd_plan: u32,
    /// The primitives as planned (blends as arcs).
    path: Vec<PrimitiveDoc>,
    duration_s: f64,
    path_deviation_mm: f64,
    tracking_error_mm: f64,
    rows: usize,
    valid: bool,
    /// One line of figures per start.
    starts: Vec<StartDoc>,
    /// One plan document per start.
    sections: Vec<json::Document>,
}

#[derive(Debug, Serialize)]
struct PrimitiveDoc {
    kind: &'static str,
    /// The element it comes from (from 1); none for a blend.
    element: Option<usize>,
    /// A blend: the waypoint it rounds (the end of element n); none for an element's piece.
    waypoint: Option<usize>,
    /// The section it belongs to, from 1.
    section: usize,
    from: [f64; 4],
    to: [f64; 4],
    length_mm: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    centre: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sweep_deg: Option<f64>,
    start_s: f64,
    end_s: f64,
    /// The slowest planned speed on it while the profile cruises (lower on a tight arc and
    /// where the tool slows for one), mm/s.
    cruise_mm_s: f64,
    path_deviation_mm: f64,
}

#[derive(Debug, Serialize)]
struct StartDoc {
    start: usize,
    section: usize,
    /// The elements it runs, "2" or "2-4".
    elements: String,
    begins_mm: f64,
    length_mm: f64,
    begins_s: f64,
    duration_s: f64,
    speed_mm_s: f64,
    rows: usize,
    path_deviation_mm: f64,
    tracking_error_mm: f64,
    valid: bool,
    /// Whether the PLC starts it at speed, chained behind the start before it (a part of a
    /// section cut into several starts).
    chained_at_speed: bool,
}

/// The document of `planned`, planned from `req`, run as `starts`.
pub(super) fn document(
    robot: &Robot,
    req: &PathRequest,
    planned: &PathPlan,
    starts: &[Start<'_>],
) -> PathDocument {
    let deviations = deviation_by_piece(robot, &planned.path, starts);
    let path = planned
        .path
        .pieces()
        .iter()
        .zip(deviations)
        .map(|(piece, deviation)| primitive_doc(piece, starts, deviation))
        .collect();
    let sections = starts
        .iter()
        .map(|s| {
            let one = MoveRequest {
                from: Origin::Counts(s.plan.samples.counts[0]),
                to: s.plan.line.to,
                motion: req.motion,
            };
            json::document(robot, &one, s.plan)
        })
        .collect();
    PathDocument {
        linterpd_plan: 1,
        path,
        duration_s: planned.duration_s(),
        path_deviation_mm: planned.max_deviation_mm(),
        tracking_error_mm: starts
            .iter()
            .map(|s| s.plan.figures.tracking_error_mm)
            .fold(0.0, f64::max),
        rows: starts.iter().map(|s| s.plan.figures.rows).sum(),
        valid: planned.valid(),
        starts: starts.iter().map(|s| start_doc(&planned.path, s)).collect(),
        sections,
    }
}

fn start_doc(path: &Path, s: &Start<'_>) -> StartDoc {
    let (plan, f) = (s.plan, &s.plan.figures);
    StartDoc {
        start: s.number,
        section: s.section,
        elements: elements_between(path, s.begins_mm, s.ends_mm()),
        begins_mm: s.begins_mm,
        length_mm: s.ends_mm() - s.begins_mm,
        begins_s: s.begins_s,
        duration_s: plan.duration_s(),
        chained_at_speed: plan.window.begins_at_speed(),
        speed_mm_s: plan.profile.speed_mm_s,
        rows: f.rows,
        path_deviation_mm: f.path_deviation_mm,
        tracking_error_mm: f.tracking_error_mm,
        valid: plan.valid(),
    }
}

fn primitive_doc(piece: &Piece, starts: &[Start<'_>], deviation_mm: f64) -> PrimitiveDoc {
    let p = &piece.primitive;
    let (kind, centre, radius_mm, sweep_deg) = match p {
        Primitive::Line(_) => ("line", None, None, None),
        Primitive::Arc(a) => (
            "arc",
            Some(a.centre_mm.into()),
            Some(a.radius_mm),
            Some(a.sweep_rad.to_degrees()),
        ),
    };
    let end_mm = piece.start_mm + p.length_mm();
    PrimitiveDoc {
        kind,
        element: piece.element,
        waypoint: piece.waypoint,
        section: holding(starts, piece.start_mm + p.length_mm() / 2.0).section,
        from: p.from().to_mm_deg(),
        to: p.to().to_mm_deg(),
        length_mm: p.length_mm(),
        centre,
        radius_mm,
        sweep_deg,
        start_s: time_at_mm(starts, piece.start_mm),
        end_s: time_at_mm(starts, end_mm),
        cruise_mm_s: holding(starts, piece.start_mm + p.length_mm() / 2.0)
            .cruise_mm_s(piece.start_mm, end_mm),
        path_deviation_mm: deviation_mm,
    }
}

/// Per piece of `path`: the largest distance from its start's planned path of the executed
/// positions (every start's, from its start counts, after every pulse event) nearest to it.
fn deviation_by_piece(robot: &Robot, path: &Path, starts: &[Start<'_>]) -> Vec<f64> {
    let pieces = path.pieces();
    let mut worst = vec![0.0_f64; pieces.len()];
    for start in starts {
        let own = start.own_path();
        let mut counts: [i64; crate::kinematics::JOINTS] =
            std::array::from_fn(|j| start.plan.tables.get(j).map_or(0, |t| t.start));
        let mut measure = |counts: &[i64; crate::kinematics::JOINTS]| {
            let p = robot.pose_of(counts).position_mm;
            let along = own.nearest_mm(&p);
            let off = (own.at(along).position_mm - p).norm();
            let global = start.section_mm + along;
            let i = pieces
                .partition_point(|piece| piece.start_mm <= global)
                .saturating_sub(1);
            worst[i] = worst[i].max(off);
        };
        measure(&counts);
        for e in &start.plan.execution().events {
            counts[e.table] = e.count;
            measure(&counts);
        }
    }
    worst
}
