//! The drawing: plotters on its SVG backend, three panels and a legend (layout in `mod.rs`).

use std::ops::Range;

use nalgebra::Vector3;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::Series;
use super::track::TrackPoint;
use crate::geometry::{Path, Primitive};

/// Width of the picture, px.
pub const WIDTH_PX: u32 = 1280;
/// Height of the picture, px.
pub const HEIGHT_PX: u32 = 960;

const FONT: &str = "sans-serif";
/// Height of the top row (the path panels), px.
const TOP_PX: u32 = 470;
/// Width of the legend column, px.
const LEGEND_PX: u32 = 300;
const AXIS_GREY: RGBColor = RGBColor(90, 90, 90);
const GRID: RGBColor = RGBColor(232, 232, 232);
const GRID_BOLD: RGBColor = RGBColor(205, 205, 205);
const TOLERANCE: RGBColor = RGBColor(190, 0, 160);
const BLEND: RGBColor = RGBColor(230, 120, 0);
/// The largest turn between two points of a drawn arc, degrees.
const ARC_STEP_DEG: f64 = 2.0;

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Failed = Box<dyn std::error::Error + Send + Sync>;

/// Everything the drawing needs, prepared.
pub(super) struct Picture<'a> {
    pub(super) title: String,
    /// The planned path: a line, or lines and arcs (blends included).
    pub(super) path: Path,
    /// What the planned path is called: "line" or "path".
    pub(super) noun: &'static str,
    /// Factor on every offset from the planned path in the path panels.
    pub(super) magnify: f64,
    /// Per series: the thinned executed path.
    pub(super) paths: Vec<Vec<TrackPoint>>,
    /// Length of the stretches of the path the deviation panel takes the largest of, mm.
    pub(super) stretch_mm: f64,
    /// Per series: (distance along the path, largest deviation) of each stretch.
    pub(super) envelopes: Vec<Vec<(f64, f64)>>,
    pub(super) series: &'a [Series],
    pub(super) tolerances_mm: Vec<f64>,
}

fn colour(rgb: (u8, u8, u8)) -> RGBColor {
    RGBColor(rgb.0, rgb.1, rgb.2)
}

/// The picture as an SVG document.
pub(super) fn svg(picture: &Picture<'_>) -> Result<String, Failed> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (WIDTH_PX, HEIGHT_PX)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(&picture.title, (FONT, 22).into_font().color(&BLACK))?;
        let (top, bottom) = root.split_vertically(TOP_PX);
        let (xy, xz) = top.split_horizontally(WIDTH_PX / 2);
        path_panel(&xy, picture, [0, 1], ["X (mm)", "Y (mm)"])?;
        path_panel(&xz, picture, [0, 2], ["X (mm)", "Z (mm)"])?;
        let (deviation, legend) = bottom.split_horizontally(WIDTH_PX - LEGEND_PX);
        deviation_panel(&deviation, picture)?;
        legend_panel(&legend, picture)?;
        root.present()?;
    }
    Ok(out)
}

/// A position in the panel's plane: the foot on the planned path plus the magnified offset.
fn projected(picture: &Picture<'_>, p: &TrackPoint, axes: [usize; 2]) -> (f64, f64) {
    let v = picture.path.at(p.along_mm).position_mm + p.offset_mm * picture.magnify;
    (v[axes[0]], v[axes[1]])
}

/// Points along a primitive close enough together for their chords to draw it: a line's ends,
/// an arc every [`ARC_STEP_DEG`] at most.
pub(super) fn outline(primitive: &Primitive) -> Vec<Vector3<f64>> {
    match primitive {
        Primitive::Line(l) => vec![l.from.position_mm, l.to.position_mm],
        Primitive::Arc(a) => {
            let steps = (a.sweep_rad.to_degrees() / ARC_STEP_DEG).ceil().max(1.0) as usize;
            (0..=steps)
                .map(|i| a.at(a.length_mm() * i as f64 / steps as f64).position_mm)
                .collect()
        }
    }
}

/// The whole planned path as points, piece after piece.
fn path_outline(path: &Path) -> Vec<Vector3<f64>> {
    let mut points: Vec<Vector3<f64>> = Vec::new();
    for piece in path.pieces() {
        let more = outline(&piece.primitive);
        let skip = usize::from(!points.is_empty());
        points.extend(more.into_iter().skip(skip));
    }
    points
}

/// Every blend's corner arc: the waypoint it rounds, its radius and its points.
fn blends(path: &Path) -> Vec<(usize, f64, Vec<Vector3<f64>>)> {
    path.pieces()
        .iter()
        .filter_map(|piece| match (piece.waypoint, piece.primitive) {
            (Some(w), Primitive::Arc(a)) => Some((w, a.radius_mm, outline(&piece.primitive))),
            _ => None,
        })
        .collect()
}

/// The range of `values` with a margin of `pad` of its width (at least 1 mm) each side.
fn padded(values: impl Iterator<Item = f64>, pad: f64) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let margin = ((hi - lo) * pad).max(1.0);
    (lo - margin)..(hi + margin)
}

/// `x` and `y` widened so one mm is as long on both axes of a `w` by `h` px plot.
fn equal_scale(x: Range<f64>, y: Range<f64>, w: f64, h: f64) -> (Range<f64>, Range<f64>) {
    let widen = |r: Range<f64>, span: f64| {
        let mid = f64::midpoint(r.start, r.end);
        (mid - span / 2.0)..(mid + span / 2.0)
    };
    let mm_per_px = ((x.end - x.start) / w).max((y.end - y.start) / h);
    (widen(x, mm_per_px * w), widen(y, mm_per_px * h))
}

/// How a panel's axes are labelled: their names, how many labels each has and with how many
/// decimals, and the room left of the y axis for its labels, px.
struct Axes {
    names: [String; 2],
    labels: [usize; 2],
    decimals: [usize; 2],
    y_label_px: u32,
}

/// A panel's chart on `area` over `ranges` (x, y), with its caption and mesh drawn the panels'
/// one way.
fn chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: String,
    (x, y): (Range<f64>, Range<f64>),
    axes: &Axes,
) -> Result<ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>, Failed> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 16))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(axes.y_label_px)
        .build_cartesian_2d(x, y)?;
    let [x_decimals, y_decimals] = axes.decimals;
    chart
        .configure_mesh()
        .x_desc(axes.names[0].as_str())
        .y_desc(axes.names[1].as_str())
        .x_labels(axes.labels[0])
        .y_labels(axes.labels[1])
        .x_label_formatter(&|v| format!("{v:.x_decimals$}"))
        .y_label_formatter(&|v| format!("{v:.y_decimals$}"))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .light_line_style(GRID)
        .bold_line_style(GRID_BOLD)
        .axis_style(AXIS_GREY)
        .draw()?;
    Ok(chart)
}

fn path_panel(
    area: &Area<'_>,
    picture: &Picture<'_>,
    axes: [usize; 2],
    names: [&str; 2],
) -> Result<(), Failed> {
    let planned = path_outline(&picture.path);
    let points: Vec<Vec<(f64, f64)>> = picture
        .paths
        .iter()
        .map(|path| path.iter().map(|p| projected(picture, p, axes)).collect())
        .collect();
    let ranges = path_ranges(area, &points, &planned, axes);
    let caption = format!(
        "path in {}{} plane (offsets from the {} x{})",
        &names[0][..1],
        &names[1][..1],
        picture.noun,
        picture.magnify
    );
    let axes_drawn = Axes {
        names: [names[0].to_owned(), names[1].to_owned()],
        labels: [6, 6],
        decimals: [0, 0],
        y_label_px: 64,
    };
    let mut chart = chart(area, caption, ranges, &axes_drawn)?;
    for (pts, s) in points.into_iter().zip(picture.series) {
        chart.draw_series(LineSeries::new(pts, colour(s.rgb).stroke_width(2)))?;
    }
    let flat = |v: &Vector3<f64>| (v[axes[0]], v[axes[1]]);
    chart.draw_series(LineSeries::new(
        planned.iter().map(flat),
        BLACK.stroke_width(1),
    ))?;
    for (_, _, arc) in blends(&picture.path) {
        chart.draw_series(LineSeries::new(arc.iter().map(flat), BLEND.stroke_width(1)))?;
    }
    Ok(())
}

/// The x and y ranges of a path panel: every executed point and the `planned` outline, padded,
/// on one scale in both directions.
fn path_ranges(
    area: &Area<'_>,
    points: &[Vec<(f64, f64)>],
    planned: &[Vector3<f64>],
    axes: [usize; 2],
) -> (Range<f64>, Range<f64>) {
    let all = || {
        points
            .iter()
            .flatten()
            .copied()
            .chain(planned.iter().map(|e| (e[axes[0]], e[axes[1]])))
    };
    let (w, h) = area.dim_in_pixel();
    equal_scale(
        padded(all().map(|p| p.0), 0.06),
        padded(all().map(|p| p.1), 0.06),
        f64::from(w) - 110.0,
        f64::from(h) - 110.0,
    )
}

fn deviation_panel(area: &Area<'_>, picture: &Picture<'_>) -> Result<(), Failed> {
    let length_mm = picture.path.length_mm();
    let caption = format!(
        "deviation from the {noun}, true scale (largest in each {:.2} mm of the {noun})",
        picture.stretch_mm,
        noun = picture.noun
    );
    let axes = Axes {
        names: [
            format!("distance along the {} (mm)", picture.noun),
            "deviation (mm)".to_owned(),
        ],
        labels: [10, 8],
        decimals: [0, 3],
        y_label_px: 74,
    };
    let mut chart = chart(
        area,
        caption,
        (0.0..length_mm, 0.0..deviation_top(picture)),
        &axes,
    )?;
    for &tolerance in &picture.tolerances_mm {
        let style = TOLERANCE.stroke_width(1);
        chart.draw_series(DashedLineSeries::new(
            [(0.0, tolerance), (length_mm, tolerance)],
            8,
            5,
            style,
        ))?;
    }
    for (env, s) in picture.envelopes.iter().zip(picture.series) {
        chart.draw_series(LineSeries::new(
            env.iter().copied(),
            colour(s.rgb).stroke_width(2),
        ))?;
    }
    Ok(())
}

/// The top of the deviation panel's y axis: above every envelope and tolerance.
fn deviation_top(picture: &Picture<'_>) -> f64 {
    let top = picture
        .envelopes
        .iter()
        .flatten()
        .map(|p| p.1)
        .chain(picture.tolerances_mm.iter().copied())
        .fold(0.0, f64::max);
    if top > 0.0 { top * 1.12 } else { 0.01 }
}

/// The legend: a line sample and the label of every series, then the planned line or path, its
/// blends and the tolerance.
fn legend_panel(area: &Area<'_>, picture: &Picture<'_>) -> Result<(), Failed> {
    let mut y = 60;
    let entry = |y: i32, rgb: RGBColor, width: u32, text: &str| -> Result<(), Failed> {
        area.draw(&PathElement::new(
            vec![(12, y), (46, y)],
            rgb.stroke_width(width),
        ))?;
        area.draw(&Text::new(
            text.to_owned(),
            (54, y),
            (FONT, 14)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
        Ok(())
    };
    area.draw(&Text::new(
        "executed paths",
        (12, y - 30),
        (FONT, 15).into_font().style(FontStyle::Bold),
    ))?;
    for s in picture.series {
        entry(y, colour(s.rgb), 3, &s.label)?;
        y += 26;
    }
    entry(y, BLACK, 1, &format!("planned {}", picture.noun))?;
    for (waypoint, radius_mm, _) in blends(&picture.path) {
        y += 26;
        let text = format!("blend at waypoint {waypoint}, radius {radius_mm:.2} mm");
        entry(y, BLEND, 1, &text)?;
    }
    for &tolerance in &picture.tolerances_mm {
        y += 26;
        entry(y, TOLERANCE, 1, &format!("tolerance {tolerance} mm"))?;
    }
    Ok(())
}
