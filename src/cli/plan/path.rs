//! `linterpd plan --path FILE`: a path of lines, arcs and blended corners, planned section by
//! section between its stops; text, JSON (`path_json.rs`: the path's primitives as planned with
//! their figures, then one plan document per start) or CSV (every start's rows), and `--svg`
//! (the planned path and the executed one).

use std::io::Write;
use std::path::Path as FilePath;

use anyhow::Context;

use super::starts::{Start, elements_between, holding, starts};
use super::{Failure, Format, PlanArgs, csv, method, motion, path_json, start_pose, tolerance};
use crate::config::PathDoc;
use crate::geometry::{Piece, Primitive};
use crate::kinematics::Kinematics;
use crate::plan::{Origin, PathPlan, PathRequest, Plan, plan_path};
use crate::robot::Robot;
use crate::table::FrequencyModel;

/// Runs `linterpd plan --path FILE`.
pub(super) fn run(
    robot: &Robot,
    args: &PlanArgs,
    file: &FilePath,
    out: &mut dyn Write,
) -> Result<(), Failure> {
    let bad = Failure::BadInput;
    let text = crate::config::files::read_regular(file).map_err(|e| bad(e.into()))?;
    let doc = PathDoc::from_toml(&text)
        .with_context(|| format!("{}", file.display()))
        .map_err(bad)?;
    let req = request(robot, args, &doc).map_err(bad)?;
    let planned = plan_path(robot, &req).map_err(|e| bad(e.into()))?;
    write_planned(robot, args, &req, &planned, out)
}

/// Writes the path `planned` from `req` in the format `args` asks for, and its SVG.
pub(super) fn write_planned(
    robot: &Robot,
    args: &PlanArgs,
    req: &PathRequest,
    planned: &PathPlan,
    out: &mut dyn Write,
) -> Result<(), Failure> {
    let starts = starts(planned);
    let written: anyhow::Result<()> = match args.output() {
        Format::Json => (|| {
            let document = path_json::document(robot, req, planned, &starts);
            serde_json::to_writer_pretty(&mut *out, &document)?;
            writeln!(out)?;
            Ok(())
        })(),
        Format::Csv => csv::write_starts(robot, &starts, out).map_err(Into::into),
        Format::Text => write_text(robot, planned, &starts, out).map_err(Into::into),
    };
    written
        .context("writing the plan")
        .map_err(Failure::Runtime)?;
    match &args.svg {
        Some(svg) => super::write_svg(svg, || {
            let plans: Vec<&Plan> = starts.iter().map(|s| s.plan).collect();
            crate::plot::svg_path(robot, &planned.path, &plans)
        }),
        None => Ok(()),
    }
}

/// The path request the file and the arguments describe.
fn request(robot: &Robot, args: &PlanArgs, doc: &PathDoc) -> anyhow::Result<PathRequest> {
    let no_names = |_: &str| None;
    let from = match (&args.from, doc.start_pose(0.0, &no_names)) {
        (Some(text), _) => start_pose(robot, text)?,
        (None, Ok(Some(pose))) => pose,
        (None, Ok(None)) => anyhow::bail!("the path file gives no `start`: give --from X,Y,Z"),
        (None, Err(e)) => Err(e).context(
            "taught positions are the daemon's: give --from X,Y,Z, or run the path with `linterpd run`",
        )?,
    };
    let elements = doc.resolve(from, &no_names).context(
        "taught positions are the daemon's: write coordinates, or run the path with `linterpd run`",
    )?;
    let mut motion = motion(robot.motion, args)?;
    motion.method = method(motion.method, args.method, tolerance(args)?)?;
    if let Some(model) = args.frequency_model {
        motion.frequency_model = FrequencyModel::from(model);
    }
    // Without a limit in the file, arcs may pull as hard as the profile pushes.
    let accel = doc
        .path_accel_mm_s2
        .unwrap_or(motion.speed_mm_s / motion.accel_s);
    robot
        .kinematics
        .ik(&from, None)
        .context("the path's start")?;
    Ok(PathRequest {
        from: Origin::Pose(from),
        start: Some(from),
        elements,
        motion,
        path_accel_mm_s2: accel,
    })
}

fn write_text(
    robot: &Robot,
    planned: &PathPlan,
    starts: &[Start<'_>],
    out: &mut dyn Write,
) -> std::io::Result<()> {
    let first = starts.first().map(|s| s.plan.motion);
    writeln!(out, "robot    {}", robot.name)?;
    if let Some(m) = first {
        writeln!(
            out,
            "method   {}, frequency model {}",
            m.method.name(),
            m.frequency_model.name()
        )?;
    }
    writeln!(
        out,
        "path     {:.3} mm in {} primitives, {} section(s) between stops",
        planned.path.length_mm(),
        planned.path.pieces().len(),
        starts.last().map_or(0, |s| s.section)
    )?;
    for piece in planned.path.pieces() {
        write_piece(piece, starts, out)?;
    }
    writeln!(out, "starts")?;
    for start in starts {
        write_start(planned, start, out)?;
    }
    writeln!(
        out,
        "total    {:.3} s of motion, path deviation {:.4} mm (execution model)",
        planned.duration_s(),
        planned.max_deviation_mm()
    )?;
    if planned.valid() {
        writeln!(out, "valid    yes: every table passed F174 validation")
    } else {
        writeln!(out, "valid    NO, must not be sent to a PLC")
    }
}

/// One primitive of the path: where it comes from, its kind and length, where it ends, and the
/// speed its start slows to on it.
fn write_piece(piece: &Piece, starts: &[Start<'_>], out: &mut dyn Write) -> std::io::Result<()> {
    let p = &piece.primitive;
    let end_mm = piece.start_mm + p.length_mm();
    let start = holding(starts, piece.start_mm + p.length_mm() / 2.0);
    let (slowest, cruise) = (
        start.cruise_mm_s(piece.start_mm, end_mm),
        start.plan.profile.speed_mm_s,
    );
    let slowed = if slowest < cruise - 0.05 {
        format!(", slowed to {slowest:.1} mm/s")
    } else {
        String::new()
    };
    let source = match (piece.element, piece.waypoint) {
        (Some(e), _) => format!("element {e}"),
        (None, Some(w)) => format!("blend {w}"),
        (None, None) => "blend".to_owned(),
    };
    let [x, y, z, _] = p.to().to_mm_deg();
    match p {
        Primitive::Line(_) => writeln!(
            out,
            "  {source:<11} line {:>9.3} mm  to ({x:.3}, {y:.3}, {z:.3}){slowed}",
            p.length_mm()
        ),
        Primitive::Arc(a) => writeln!(
            out,
            "  {source:<11} arc  {:>9.3} mm  to ({x:.3}, {y:.3}, {z:.3}), radius {:.3} mm, {:.1} deg{slowed}",
            p.length_mm(),
            a.radius_mm,
            a.sweep_rad.to_degrees()
        ),
    }
}

/// One start of the path: its section and elements, length, speed, time, rows and figures.
fn write_start(planned: &PathPlan, start: &Start<'_>, out: &mut dyn Write) -> std::io::Result<()> {
    let (plan, f) = (start.plan, &start.plan.figures);
    writeln!(
        out,
        "  {} (section {}, element {}){}: {:.3} mm at {:.1} mm/s, {:.3} s, {} rows, path \
         deviation {:.4} mm, tracking error {:.4} mm{}",
        start.number,
        start.section,
        elements_between(&planned.path, start.begins_mm, start.ends_mm()),
        if plan.window.begins_at_speed() {
            ", chained at speed"
        } else {
            ""
        },
        start.ends_mm() - start.begins_mm,
        plan.profile.speed_mm_s,
        plan.duration_s(),
        f.rows,
        f.path_deviation_mm,
        f.tracking_error_mm,
        if plan.valid() { "" } else { ", NOT VALID" }
    )
}
