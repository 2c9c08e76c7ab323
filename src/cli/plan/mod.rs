//! `linterpd plan`: plan one move from a config file and print its tables and figures as text,
//! JSON or CSV; or, with `--compare`, plan it every way and print the figures side by side. `--svg`
//! also draws the path and its deviation.

mod compare;
mod csv;
mod json;
mod path;
mod path_json;
mod starts;
mod text;

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Args, ValueEnum};

use super::args::{MethodArg, PoseArg, parse_length_mm, parse_pose, parse_ramp, parse_speed_mm_s};
use super::{Failure, bad_input};
use crate::config::{Config, parse_duration_s};
use crate::geometry::Pose;
use crate::plan::{MovePlan, MoveRequest, Origin, PathPlan, Plan, line_as_path, plan_line};
use crate::robot::{Method, Motion, OverSpeed, Robot};
use crate::table::FrequencyModel;

/// Arguments of `linterpd plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The configuration file.
    #[arg(
        long,
        env = "LINTERPD_CONFIG",
        default_value = "/etc/linterpd/linterpd.toml"
    )]
    pub config: PathBuf,
    /// The robot to plan for (needed when the file holds several).
    #[arg(long)]
    pub robot: Option<String>,
    /// Start pose: X,Y,Z or X,Y,Z,A in mm and degrees. Without A the wrist joint sits at 0.
    /// (With `--path`, only when the file gives no `start`.)
    #[arg(long, allow_hyphen_values = true, required_unless_present = "path")]
    pub from: Option<String>,
    /// Target pose: X,Y,Z or X,Y,Z,A in mm and degrees. Without A the tool keeps the start angle.
    #[arg(long, allow_hyphen_values = true, required_unless_present = "path")]
    pub to: Option<String>,
    /// Plan a path file (lines, arcs, blended corners; see config/examples/) instead of one
    /// line: a regular file of at most 1 MiB.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["to", "compare", "seed_exact"])]
    pub path: Option<PathBuf>,
    /// Speed along the line, e.g. `240mm/s` or `240` (mm/s; default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub speed: Option<String>,
    /// Acceleration time, e.g. `200ms` (default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub accel_time: Option<String>,
    /// Interpolation period, e.g. `50ms` (default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub period: Option<String>,
    /// Planning method.
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Largest path deviation a bounded-error plan may have, e.g. `0.05mm` (a plain number is
    /// mm; default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub tolerance: Option<String>,
    /// Reproduce the paper as printed (comparison only; never valid for a PLC).
    #[arg(long)]
    pub seed_exact: bool,
    /// What the PLC's channels really output (default: the robot's).
    #[arg(long, value_enum)]
    pub frequency_model: Option<ModelArg>,
    /// What to do when a channel would be too fast (default: the robot's).
    #[arg(long, value_enum)]
    pub over_speed: Option<OverSpeedArg>,
    /// The ramps' shape: `trapezoid`, or `s-curve` with the path's jerk, e.g. `s-curve:20000`
    /// (mm/s^3; default: the robot's).
    #[arg(long)]
    pub profile: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// Print JSON: the same as `--format json`.
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
    /// Plan the move seed-exact, constant-period and bounded-error, each under both frequency
    /// models, and print their figures side by side (text or json).
    #[arg(long, conflicts_with_all = ["method", "seed_exact", "frequency_model"])]
    pub compare: bool,
    /// Also write an SVG of the planned path and the executed one (XY, XZ) and its deviation
    /// along the path to this file.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

/// `--frequency-model`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ModelArg {
    /// The channel outputs the value written.
    Ideal,
    /// The FP-X's clock divider (derived, unverified on hardware).
    FpxDivider,
}

/// `--over-speed`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum OverSpeedArg {
    /// Refuse the move.
    Reject,
    /// Lower the move's speed until every channel fits.
    SlowDown,
}

/// `--format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A readable summary with every table.
    Text,
    /// One JSON document (`linterpd_plan: 1`), stable for scripts.
    Json,
    /// One line per table row.
    Csv,
}

impl PlanArgs {
    /// The output format `--format` or `--json` asks for.
    #[must_use]
    pub fn output(&self) -> Format {
        if self.json { Format::Json } else { self.format }
    }
}

/// Runs `linterpd plan`.
pub fn run(args: &PlanArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let config = Config::load(&args.config).map_err(bad_input)?;
    let robot = config.robot(args.robot.as_deref()).map_err(bad_input)?;
    if args.compare {
        return compare::run(robot, args, out);
    }
    if let Some(file) = &args.path {
        return path::run(robot, args, file, out);
    }
    let request = request(robot, args).map_err(Failure::BadInput)?;
    let planned = plan_line(robot, &request).map_err(bad_input)?;
    // A line that cannot run as one start: shown as the path it runs as, after why.
    if let Some((parts, note)) = cut_note(&planned) {
        if args.output() == Format::Text {
            writeln!(out, "{note}")
                .context("writing the plan")
                .map_err(Failure::Runtime)?;
        }
        return path::write_planned(robot, args, &line_as_path(&request), parts, out);
    }
    let MovePlan::One(plan) = planned else {
        unreachable!("cut_note names every line planned in parts")
    };
    write(robot, &request, &plan, args.output(), out)
        .context("writing the plan")
        .map_err(Failure::Runtime)?;
    match &args.svg {
        Some(path) => write_svg(path, || crate::plot::svg(robot, &[&plan])),
        None => Ok(()),
    }
}

/// The path of parts a line runs as, with a line saying why it is cut; `None` for one start.
fn cut_note(planned: &MovePlan) -> Option<(&PathPlan, String)> {
    match planned {
        MovePlan::One(_) => None,
        MovePlan::Parts {
            path,
            joint,
            reverses,
            at_mm,
        } => {
            let what = if *reverses {
                "reverses"
            } else {
                "changes frequency range"
            };
            let note = format!(
                "cut      where joint {joint} {what}, {at_mm:.1} mm along the line, while the \
                 others move: in one start its next F174 segment would begin up to a PLC scan \
                 late, off the line"
            );
            Some((path, note))
        }
        MovePlan::Long { path, one_start } => {
            let parts = path.starts().count();
            let note = format!(
                "cut      into {parts} parts chained at speed, each whole in its areas: as one \
                 start, {one_start}"
            );
            Some((path, note))
        }
    }
}

/// Draws the SVG and writes it to `path`.
fn write_svg(
    path: &Path,
    draw: impl FnOnce() -> Result<String, crate::plot::PlotError>,
) -> Result<(), Failure> {
    let svg = draw()
        .context("drawing the svg")
        .map_err(Failure::Runtime)?;
    std::fs::write(path, svg)
        .with_context(|| format!("writing {}", path.display()))
        .map_err(Failure::Runtime)
}

fn write(
    robot: &Robot,
    request: &MoveRequest,
    plan: &Plan,
    format: Format,
    out: &mut dyn std::io::Write,
) -> anyhow::Result<()> {
    match format {
        Format::Text => text::write(robot, plan, out)?,
        Format::Json => {
            serde_json::to_writer_pretty(&mut *out, &json::document(robot, request, plan))?;
            writeln!(out)?;
        }
        Format::Csv => csv::write(robot, plan, out)?,
    }
    Ok(())
}

/// The move request the arguments describe, the robot's defaults filling the gaps.
fn request(robot: &Robot, args: &PlanArgs) -> anyhow::Result<MoveRequest> {
    let base = base_request(robot, args)?;
    let method = method(base.motion.method, args.method, tolerance(args)?)?;
    let model = args
        .frequency_model
        .map_or(base.motion.frequency_model, FrequencyModel::from);
    let method = if args.seed_exact {
        Method::SeedExact
    } else {
        method
    };
    Ok(variant(&base, method, model))
}

/// `base` planned with `method` under `model`.
fn variant(base: &MoveRequest, method: Method, model: FrequencyModel) -> MoveRequest {
    MoveRequest {
        motion: Motion {
            method,
            frequency_model: model,
            ..base.motion
        },
        ..*base
    }
}

/// What every way of planning the move shares: its ends, speed, ramps, period and over-speed
/// policy; the method and frequency model are the robot's, and the plan is not seed-exact.
fn base_request(robot: &Robot, args: &PlanArgs) -> anyhow::Result<MoveRequest> {
    let motion = motion(robot.motion, args)?;
    let from = start_pose(robot, args.from.as_deref().unwrap_or_default())?;
    let to_arg: PoseArg = parse_pose(args.to.as_deref().unwrap_or_default()).context("--to")?;
    let [x, y, z] = to_arg.xyz_mm;
    let to = Pose::from_mm_deg(x, y, z, 0.0);
    let to = Pose {
        a_rad: to_arg.a_deg.map_or(from.a_rad, f64::to_radians),
        ..to
    };
    Ok(MoveRequest {
        from: Origin::Pose(from),
        to,
        motion,
    })
}

/// `--from`: the pose written, or with the wrist at 0 when no angle is given.
fn start_pose(robot: &Robot, text: &str) -> anyhow::Result<Pose> {
    let from_arg: PoseArg = parse_pose(text).context("--from")?;
    let [x, y, z] = from_arg.xyz_mm;
    match from_arg.a_deg {
        Some(a) => Ok(Pose::from_mm_deg(x, y, z, a)),
        None => robot.pose_with_wrist_at_zero(x, y, z).context("--from"),
    }
}

/// `--tolerance`, if given.
fn tolerance(args: &PlanArgs) -> anyhow::Result<Option<f64>> {
    args.tolerance
        .as_deref()
        .map(parse_length_mm)
        .transpose()
        .context("--tolerance")
}

/// The robot's motion defaults with `--speed`, `--accel-time`, `--period` and `--over-speed`.
fn motion(defaults: Motion, args: &PlanArgs) -> anyhow::Result<Motion> {
    let mut m = defaults;
    if let Some(text) = &args.speed {
        m.speed_mm_s = parse_speed_mm_s(text).context("--speed")?;
    }
    if let Some(text) = &args.accel_time {
        m.accel_s = parse_duration_s(text).context("--accel-time")?;
    }
    if let Some(text) = &args.period {
        m.period_s = parse_duration_s(text).context("--period")?;
    }
    if let Some(policy) = args.over_speed {
        m.over_speed = match policy {
            OverSpeedArg::Reject => OverSpeed::Reject,
            OverSpeedArg::SlowDown => OverSpeed::SlowDown,
        };
    }
    if let Some(text) = &args.profile {
        m.ramp = parse_ramp(text).context("--profile")?;
    }
    Ok(m)
}

/// The method `--method` and `--tolerance` ask for, the robot's `default` filling the gaps.
fn method(
    default: Method,
    asked: Option<MethodArg>,
    tolerance: Option<f64>,
) -> anyhow::Result<Method> {
    Ok(match (asked, default, tolerance) {
        (Some(MethodArg::ConstantPeriod), _, None) => Method::ConstantPeriod,
        (Some(MethodArg::BoundedError) | None, _, Some(tolerance_mm))
        | (Some(MethodArg::BoundedError), Method::BoundedError { tolerance_mm }, None) => {
            Method::BoundedError { tolerance_mm }
        }
        (Some(MethodArg::BoundedError), Method::ConstantPeriod | Method::SeedExact, None) => {
            anyhow::bail!(
                "--method bounded-error needs --tolerance (e.g. 0.05mm); the robot's config gives none"
            )
        }
        (Some(MethodArg::ConstantPeriod), _, Some(_)) => {
            anyhow::bail!("--tolerance only applies to --method bounded-error")
        }
        (None, method, None) => method,
    })
}

impl From<ModelArg> for FrequencyModel {
    fn from(model: ModelArg) -> Self {
        match model {
            ModelArg::Ideal => Self::Ideal,
            ModelArg::FpxDivider => Self::FpxDivider,
        }
    }
}
