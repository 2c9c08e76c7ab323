//! PURE. An SVG picture of one move planned one or more ways ([`svg`]), of a path of lines and
//! arcs planned start by start ([`svg_path`]), or of several executed moves along one line
//! ([`svg_paths`]: the demo's moves replayed from the mock PLC's pulse trace), built as a string
//! (no IO): `plan --svg` and `demo` write it to a file.
//!
//! ```text
//! +---------------------------- title: robot, P1 -> P2, speed --------------------------+
//! | path in XY (deviation x k)              | path in XZ (deviation x k)                |
//! |   planned path + every executed path    |   planned path + every executed path      |
//! +-----------------------------------------+-------------------------------------------+
//! | deviation from the planned path against distance along it, tol.  | legend           |
//! +------------------------------------------------------------------+------------------+
//! ```
//! The planned path is a line, or lines and arcs with every blend's corner arc in its own
//! colour. The executed path is the tool position after every pulse event (forward kinematics
//! of the counts the execution model produces; a path's starts one after the other). It strays
//! from the planned path by hundredths of a millimetre, so the path panels magnify each
//! position's offset from it by one factor `k` (a 1-2-5 value, the same for every plan, said in
//! the panel titles); the deviation panel plots the offset's length unmagnified, the largest in
//! each short stretch of the path.
//!
//! Drawn with plotters' SVG backend only: text is SVG `<text>`, laid out with plotters' built-in
//! estimate, so no font library is needed.

mod draw;
pub mod pallet;
mod track;

use thiserror::Error;

use crate::geometry::{Line, Path as PlannedPath};
use crate::kinematics::JOINTS;
use crate::plan::Plan;
use crate::robot::{Method, Robot};
use crate::sim::PulseEvent;
use crate::table::FrequencyModel;

pub use draw::{HEIGHT_PX, WIDTH_PX};
pub use pallet::layers_svg;

/// Why no SVG could be drawn.
#[derive(Debug, Error)]
pub enum PlotError {
    /// No plan was given.
    #[error("nothing to draw: no plan")]
    NoPlan,
    /// plotters failed to draw.
    #[error("drawing the svg")]
    Draw(#[source] Box<dyn std::error::Error + Send + Sync>),
}

/// How one plan is drawn: its name and colour.
#[derive(Debug, Clone, PartialEq)]
struct Series {
    /// e.g. `bounded-error 0.05 mm, fpx-divider`.
    label: String,
    /// Red, green, blue.
    rgb: (u8, u8, u8),
    /// Every executed position, placed against the planned path.
    track: Vec<track::TrackPoint>,
}

/// The name a plan goes by in the legend.
fn label(plan: &Plan) -> String {
    let method = match plan.motion.method {
        Method::BoundedError { tolerance_mm } => format!("bounded-error {tolerance_mm} mm"),
        other => other.name().to_owned(),
    };
    format!("{method}, {}", plan.motion.frequency_model.name())
}

/// A hue per method, a darker and a lighter one per frequency model.
fn rgb(plan: &Plan) -> (u8, u8, u8) {
    let ideal = plan.motion.frequency_model == FrequencyModel::Ideal;
    match (plan.motion.method, ideal) {
        (Method::SeedExact, true) => (245, 140, 30),
        (Method::SeedExact, false) => (200, 30, 30),
        (Method::ConstantPeriod, true) => (60, 160, 230),
        (Method::ConstantPeriod, false) => (30, 50, 160),
        (Method::BoundedError { .. }, true) => (120, 190, 40),
        (Method::BoundedError { .. }, false) => (20, 110, 50),
    }
}

/// The tolerances of the bounded-error plans among `plans`, each once, mm.
fn tolerances(plans: &[&Plan]) -> Vec<f64> {
    let mut out: Vec<f64> = plans
        .iter()
        .filter_map(|p| p.motion.method.tolerance_mm())
        .collect();
    out.sort_by(f64::total_cmp);
    out.dedup();
    out
}

/// The largest 1-2-5 factor that keeps the largest offset within `share` of the path's length.
fn magnification(length_mm: f64, largest_offset_mm: f64, share: f64) -> f64 {
    if largest_offset_mm <= 0.0 || length_mm <= 0.0 {
        return 1.0;
    }
    let raw = share * length_mm / largest_offset_mm;
    if raw <= 1.0 {
        return 1.0;
    }
    let decade = 10f64.powf(raw.log10().floor());
    let step = [5.0, 2.0, 1.0]
        .into_iter()
        .find(|s| s * decade <= raw)
        .unwrap_or(1.0);
    step * decade
}

/// The title: robot, ends of the line, speed.
fn title(robot: &Robot, plan: &Plan) -> String {
    let p = |v: [f64; 4]| format!("({:.2}, {:.2}, {:.2})", v[0], v[1], v[2]);
    format!(
        "{}: {} to {} mm, {:.1} mm, {} mm/s",
        robot.name,
        p(plan.line.from.to_mm_deg()),
        p(plan.line.to.to_mm_deg()),
        plan.profile.length_mm,
        plan.motion.speed_mm_s
    )
}

/// Points a path panel keeps per plan, in stretches of the line (two a stretch at most).
const PATH_STRETCHES: usize = 400;
/// Stretches of the line the deviation panel takes the largest deviation of.
const DEVIATION_STRETCHES: usize = 300;

/// The SVG of `plans`, which must all be plans of the same move (the first one's line and profile
/// name it), drawn in the order given (the last on top).
pub fn svg(robot: &Robot, plans: &[&Plan]) -> Result<String, PlotError> {
    let first = plans.first().ok_or(PlotError::NoPlan)?;
    let line = PlannedPath::from(first.line);
    let series: Vec<Series> = plans
        .iter()
        .map(|plan| Series {
            label: label(plan),
            rgb: rgb(plan),
            track: track::executed(
                robot,
                &line,
                &line,
                start_counts(plan),
                &plan.execution().events,
            ),
        })
        .collect();
    let frame = Frame {
        path: line,
        noun: "line",
    };
    render(title(robot, first), frame, &series, tolerances(plans))
}

/// The SVG of a path planned as `starts` (its PLC starts in order, each starting where the one
/// before ends): the planned path (blends included) and the executed one, every start's pulses
/// one after the other, measured against the whole path.
pub fn svg_path(robot: &Robot, path: &PlannedPath, starts: &[&Plan]) -> Result<String, PlotError> {
    let first = starts.first().ok_or(PlotError::NoPlan)?;
    let mut points = Vec::new();
    for plan in starts {
        let run = track::executed(
            robot,
            path,
            path,
            start_counts(plan),
            &plan.execution().events,
        );
        points.extend(run);
    }
    let series = [Series {
        label: label(first),
        rgb: rgb(first),
        track: points,
    }];
    let p = |pose: crate::geometry::Pose| {
        let v = pose.to_mm_deg();
        format!("({:.2}, {:.2}, {:.2})", v[0], v[1], v[2])
    };
    let title = format!(
        "{}: path {} to {} mm, {} pieces, {:.1} mm, {} mm/s",
        robot.name,
        p(path.at(0.0)),
        p(path.at(path.length_mm())),
        path.pieces().len(),
        path.length_mm(),
        first.motion.speed_mm_s
    );
    let frame = Frame {
        path: path.clone(),
        noun: "path",
    };
    render(title, frame, &series, tolerances(starts))
}

/// Counts per joint a plan starts from.
fn start_counts(plan: &Plan) -> [i64; JOINTS] {
    std::array::from_fn(|j| plan.tables.get(j).map_or(0, |t| t.start))
}

/// One executed path to draw: the counts a move started from and every pulse after (a plan's run
/// in the execution model, or a PLC's pulse trace replayed), with the line it was planned on.
#[derive(Debug, Clone, Copy)]
pub struct Path<'a> {
    /// Legend text.
    pub label: &'a str,
    /// The line the move was planned on: its offsets are measured from it.
    pub line: Line,
    /// Counts per joint at the start.
    pub start: [i64; JOINTS],
    /// Every pulse after the start, in time order (`table` is the joint).
    pub events: &'a [PulseEvent],
    /// The move's path tolerance (a bounded-error move), drawn in the deviation panel.
    pub tolerance_mm: Option<f64>,
}

/// Colours of [`svg_paths`]'s series, in turn.
const PALETTE: [(u8, u8, u8); 6] = [
    (30, 50, 160),
    (200, 30, 30),
    (20, 130, 50),
    (235, 130, 20),
    (130, 60, 180),
    (40, 170, 200),
];

/// The SVG of several executed paths along one line, `frame` (moves back and forth on it): each
/// path's offsets from its own line, placed along `frame`, drawn in the order given.
pub fn svg_paths(
    robot: &Robot,
    title: &str,
    frame: Line,
    paths: &[Path<'_>],
) -> Result<String, PlotError> {
    if paths.is_empty() {
        return Err(PlotError::NoPlan);
    }
    let frame = PlannedPath::from(frame);
    let series: Vec<Series> = paths
        .iter()
        .zip(PALETTE.iter().cycle())
        .map(|(p, rgb)| Series {
            label: p.label.to_owned(),
            rgb: *rgb,
            track: track::executed(robot, &PlannedPath::from(p.line), &frame, p.start, p.events),
        })
        .collect();
    let mut tolerances: Vec<f64> = paths.iter().filter_map(|p| p.tolerance_mm).collect();
    tolerances.sort_by(f64::total_cmp);
    tolerances.dedup();
    let frame = Frame {
        path: frame,
        noun: "line",
    };
    render(title.to_owned(), frame, &series, tolerances)
}

/// The planned path a picture is drawn against, and what it is called.
struct Frame {
    /// A line, or lines and arcs.
    path: PlannedPath,
    /// "line" or "path".
    noun: &'static str,
}

/// Draws `series` against `frame`.
fn render(
    title: String,
    frame: Frame,
    series: &[Series],
    tolerances_mm: Vec<f64>,
) -> Result<String, PlotError> {
    let length_mm = frame.path.length_mm();
    let largest = series
        .iter()
        .flat_map(|s| s.track.iter().map(track::TrackPoint::deviation_mm))
        .fold(0.0, f64::max);
    let picture = draw::Picture {
        title,
        path: frame.path,
        noun: frame.noun,
        magnify: magnification(length_mm, largest, 0.08),
        paths: series
            .iter()
            .map(|s| track::thin(&s.track, length_mm, PATH_STRETCHES))
            .collect(),
        stretch_mm: length_mm / DEVIATION_STRETCHES as f64,
        envelopes: series
            .iter()
            .map(|s| track::envelope(&s.track, length_mm, DEVIATION_STRETCHES))
            .collect(),
        series,
        tolerances_mm,
    };
    draw::svg(&picture).map_err(PlotError::Draw)
}

#[cfg(test)]
mod tests;
