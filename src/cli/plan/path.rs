//! `linterpd plan --path FILE`: a path of lines, arcs and blended corners, planned section by
//! section between its stops; text or JSON (the path's primitives as planned, then one plan
//! document per section).

use std::io::Write;
use std::path::Path as FilePath;

use anyhow::Context;
use serde::Serialize;

use super::{Failure, Format, PlanArgs, json, method, motion, start_pose, tolerance};
use crate::config::PathDoc;
use crate::geometry::{Path, Primitive};
use crate::kinematics::Kinematics;
use crate::plan::{MoveRequest, Origin, PathPlan, PathRequest, plan_path};
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
    if args.output() == Format::Csv {
        return Err(bad(anyhow::anyhow!(
            "--format csv covers one move; for a path use --json (one plan document per section)"
        )));
    }
    let text = std::fs::read_to_string(file)
        .with_context(|| format!("reading {}", file.display()))
        .map_err(bad)?;
    let doc = PathDoc::from_toml(&text)
        .with_context(|| format!("{}", file.display()))
        .map_err(bad)?;
    let req = request(robot, args, &doc).map_err(bad)?;
    let planned = plan_path(robot, &req).map_err(|e| bad(e.into()))?;
    match args.output() {
        Format::Json => {
            let mut sections = Vec::with_capacity(planned.sections.len());
            for plan in planned.starts() {
                let one = MoveRequest {
                    from: Origin::Counts(plan.samples.counts[0]),
                    to: plan.line.to,
                    motion: req.motion,
                    seed_exact: false,
                };
                sections.push(json::document(robot, &one, plan));
            }
            let document = PathDocument {
                linterpd_plan: 1,
                path: primitives(&planned.path),
                duration_s: planned.duration_s(),
                path_deviation_mm: planned.max_deviation_mm(),
                rows: planned.starts().map(|p| p.figures.rows).sum(),
                valid: planned.valid(),
                sections,
            };
            let written: anyhow::Result<()> = (|| {
                serde_json::to_writer_pretty(&mut *out, &document)?;
                writeln!(out)?;
                Ok(())
            })();
            written
                .context("writing the plan")
                .map_err(Failure::Runtime)
        }
        _ => write_text(robot, &planned, out)
            .context("writing the plan")
            .map_err(Failure::Runtime),
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
        elements,
        motion,
        path_accel_mm_s2: accel,
    })
}

#[derive(Debug, Serialize)]
struct PathDocument {
    linterpd_plan: u32,
    /// The primitives as planned (blends as arcs).
    path: Vec<PrimitiveDoc>,
    duration_s: f64,
    path_deviation_mm: f64,
    rows: usize,
    valid: bool,
    sections: Vec<json::Document>,
}

#[derive(Debug, Serialize)]
struct PrimitiveDoc {
    kind: &'static str,
    /// The element it comes from (from 1); none for a blend.
    element: Option<usize>,
    from: [f64; 4],
    to: [f64; 4],
    length_mm: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    centre: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sweep_deg: Option<f64>,
}

fn primitives(path: &Path) -> Vec<PrimitiveDoc> {
    path.pieces()
        .iter()
        .map(|piece| {
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
            PrimitiveDoc {
                kind,
                element: piece.element,
                from: p.from().to_mm_deg(),
                to: p.to().to_mm_deg(),
                length_mm: p.length_mm(),
                centre,
                radius_mm,
                sweep_deg,
            }
        })
        .collect()
}

fn write_text(robot: &Robot, planned: &PathPlan, out: &mut dyn Write) -> std::io::Result<()> {
    let first = planned.starts().next().map(|p| p.motion);
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
        planned.sections.len()
    )?;
    for piece in planned.path.pieces() {
        let p = &piece.primitive;
        let source = piece
            .element
            .map_or_else(|| "blend".to_owned(), |e| format!("element {e}"));
        let [x, y, z, _] = p.to().to_mm_deg();
        match p {
            Primitive::Line(_) => writeln!(
                out,
                "  {source:<11} line {:>9.3} mm  to ({x:.3}, {y:.3}, {z:.3})",
                p.length_mm()
            )?,
            Primitive::Arc(a) => writeln!(
                out,
                "  {source:<11} arc  {:>9.3} mm  to ({x:.3}, {y:.3}, {z:.3}), radius {:.3} mm, {:.1} deg",
                p.length_mm(),
                a.radius_mm,
                a.sweep_rad.to_degrees()
            )?,
        }
    }
    writeln!(out, "sections")?;
    for (i, section) in planned.sections.iter().enumerate() {
        let plan = &section.starts[0];
        writeln!(
            out,
            "  {}: {:.3} mm at {:.1} mm/s, {:.3} s, {} start(s)",
            i + 1,
            plan.profile.length_mm,
            plan.profile.speed_mm_s,
            plan.profile.duration_s(),
            section.starts.len(),
        )?;
        for (k, plan) in section.starts.iter().enumerate() {
            let f = &plan.figures;
            writeln!(
                out,
                "     {}.{}: {:.3} to {:.3} s{}, {} rows, path deviation {:.4} mm{}",
                i + 1,
                k + 1,
                plan.window.from_s,
                plan.window.to_s,
                if plan.window.ends_at_speed {
                    ", chained at speed into the next"
                } else {
                    ""
                },
                f.rows,
                f.path_deviation_mm,
                if plan.valid() { "" } else { ", NOT VALID" }
            )?;
        }
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
