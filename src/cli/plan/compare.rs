//! `linterpd plan --compare`: one move planned every way, figures side by side.
//!
//! The ways are seed-exact (the paper as printed), constant-period (the robot's or `--period`'s
//! period) and bounded-error (`--tolerance`, else the robot's, else [`DEFAULT_TOLERANCE_MM`]),
//! each under both frequency models. A way that cannot be planned (say a tolerance below the
//! pulse grid's floor) shows its error in its row; only a move that no way can plan is bad input.
//! A line cut into starts where a joint reverses (`plan::plan_line`) is one row:
//! rows, words and bytes over its starts, the worst of their deviations, and how many starts.
//!
//! **Upload bytes** are the bytes of the MEWTOCOL-COM command frames that write a plan's table
//! images: every moving channel's words (directory and segments) in `%` frames of at most 24 words
//! (`% 01 #WDD sssss eeeee` + 4 hex a word + BCC + CR; PLC.md §1, "Sizing"), each channel's area
//! chunked on its own. The PLC's replies, the command block and a `<` link's longer frames are not
//! counted: it is the cost of one upload over the slowest framing.

use std::io::Write;

use anyhow::{Context, anyhow};
use serde::Serialize;

use super::json::FiguresDoc;
use super::{Format, PlanArgs, base_request, tolerance, variant, write_svg};
use crate::cli::Failure;
use crate::mewtocol::{Command, Header, Station, max_write_words};
use crate::plan::{MoveRequest, Origin, Plan, PlanError, plan_line, plan_move};
use crate::robot::{Method, Robot};
use crate::sim::Figures;
use crate::table::{ChannelTable, FrequencyModel, encoded_words};

/// The bounded-error tolerance when neither `--tolerance` nor the robot gives one, mm.
pub(super) const DEFAULT_TOLERANCE_MM: f64 = 0.05;

/// One way of planning the move.
#[derive(Debug, Clone, Copy)]
struct Way {
    method: Method,
    model: FrequencyModel,
}

impl Way {
    fn name(self) -> String {
        match self.method {
            Method::BoundedError { tolerance_mm } => format!("bounded-error {tolerance_mm} mm"),
            other => other.name().to_owned(),
        }
    }

    fn tolerance_mm(self) -> Option<f64> {
        self.method.tolerance_mm()
    }

    fn seed_exact(self) -> bool {
        self.method.is_seed_exact()
    }
}

/// A way and what planning it gave.
struct Entry {
    way: Way,
    outcome: Result<Planned, PlanError>,
}

/// What one way planned: its starts, and their figures as one.
struct Planned {
    starts: Vec<Plan>,
    figures: Figures,
}

impl Planned {
    /// `starts` (at least one) with their figures together: rows, words and time added up, the
    /// worst deviation, error and skew of any, the end error of the last.
    fn new(starts: Vec<Plan>) -> Self {
        let mut figures = starts[0].figures;
        for f in starts[1..].iter().map(|p| p.figures) {
            figures.path_deviation_mm = figures.path_deviation_mm.max(f.path_deviation_mm);
            figures.tracking_error_mm = figures.tracking_error_mm.max(f.tracking_error_mm);
            figures.sampled_deviation_mm = figures.sampled_deviation_mm.max(f.sampled_deviation_mm);
            figures.end_skew_ms = figures.end_skew_ms.max(f.end_skew_ms);
            figures.end_error_mm = f.end_error_mm;
            figures.finish_s += f.finish_s;
            figures.rows += f.rows;
            figures.words += f.words;
        }
        Self { starts, figures }
    }

    fn valid(&self) -> bool {
        self.starts.iter().all(Plan::valid)
    }

    fn upload_bytes(&self) -> usize {
        self.starts.iter().map(upload_bytes).sum()
    }
}

/// Runs `linterpd plan --compare`.
pub(super) fn run(robot: &Robot, args: &PlanArgs, out: &mut dyn Write) -> Result<(), Failure> {
    if args.output() == Format::Csv {
        return Err(Failure::BadInput(anyhow!(
            "--compare writes --format text or json, not csv"
        )));
    }
    let base = base_request(robot, args).map_err(Failure::BadInput)?;
    let tolerance_mm = tolerance(args)
        .map_err(Failure::BadInput)?
        .or(robot.motion.method.tolerance_mm())
        .unwrap_or(DEFAULT_TOLERANCE_MM);
    let entries: Vec<Entry> = ways(tolerance_mm)
        .into_iter()
        .map(|way| {
            let req = variant(&base, way.method, way.model);
            let outcome = if way.seed_exact() {
                plan_move(robot, &req).map(|plan| vec![plan])
            } else {
                plan_line(robot, &req).map(|planned| planned.starts().cloned().collect())
            };
            Entry {
                way,
                outcome: outcome.map(Planned::new),
            }
        })
        .collect();
    if let Some(Err(first)) = entries.first().map(|e| &e.outcome)
        && entries.iter().all(|e| e.outcome.is_err())
    {
        // No way plans it: the move itself is the problem.
        return Err(Failure::BadInput(first.clone().into()));
    }
    write(robot, &base, &entries, args.output(), out)
        .context("writing the comparison")
        .map_err(Failure::Runtime)?;
    match &args.svg {
        Some(path) => {
            // A line cut into starts is drawn by `plan --to` (the path it runs as), not here.
            let plans: Vec<&Plan> = entries
                .iter()
                .filter_map(|e| e.outcome.as_ref().ok())
                .filter(|p| p.starts.len() == 1)
                .map(|p| &p.starts[0])
                .collect();
            write_svg(path, || crate::plot::svg(robot, &plans))
        }
        None => Ok(()),
    }
}

/// Every way, in the order they are printed: seed-exact, constant-period, bounded-error, each
/// under `ideal` then `fpx-divider`.
fn ways(tolerance_mm: f64) -> Vec<Way> {
    let methods = [
        Method::SeedExact,
        Method::ConstantPeriod,
        Method::BoundedError { tolerance_mm },
    ];
    let models = [FrequencyModel::Ideal, FrequencyModel::FpxDivider];
    methods
        .into_iter()
        .flat_map(|method| models.into_iter().map(move |model| Way { method, model }))
        .collect()
}

/// Bytes of the `%` frames that write every moving channel's table image (see the module docs).
fn upload_bytes(plan: &Plan) -> usize {
    plan.tables
        .iter()
        .filter(|t| !t.segments.is_empty())
        .map(table_upload_bytes)
        .sum()
}

fn table_upload_bytes(table: &ChannelTable) -> usize {
    let header = Header::Percent;
    let station = Station::new(1).expect("station 01 exists");
    let words = encoded_words(table);
    let per_frame = max_write_words(header);
    (0..words)
        .step_by(per_frame)
        .map(|from| {
            // The frame's length depends on how many words it carries, not on their values or
            // address (always five digits).
            let chunk = vec![0; per_frame.min(words - from)];
            Command::write_dt(from as u32, chunk)
                .and_then(|c| c.to_frame(header, station))
                .expect("a chunk of at most one frame's words at a valid address")
                .encoded_len()
        })
        .sum()
}

fn write(
    robot: &Robot,
    base: &MoveRequest,
    entries: &[Entry],
    format: Format,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    if format == Format::Json {
        serde_json::to_writer_pretty(&mut *out, &document(robot, base, entries))?;
        writeln!(out)?;
        return Ok(());
    }
    write_text(robot, base, entries, out)?;
    Ok(())
}

fn pose_text(p: [f64; 4]) -> String {
    format!("({:.3}, {:.3}, {:.3}) mm", p[0], p[1], p[2])
}

fn write_text(
    robot: &Robot,
    base: &MoveRequest,
    entries: &[Entry],
    out: &mut dyn Write,
) -> std::io::Result<()> {
    let m = base.motion;
    writeln!(out, "robot    {}", robot.name)?;
    if let Some(plan) = entries
        .iter()
        .find_map(|e| e.outcome.as_ref().ok())
        .map(|p| &p.starts[0])
    {
        writeln!(
            out,
            "move     {} -> {}, {:.3} mm",
            pose_text(plan.line.from.to_mm_deg()),
            pose_text(plan.line.to.to_mm_deg()),
            plan.profile.length_mm
        )?;
    }
    writeln!(
        out,
        "motion   {} mm/s, ramps {:.3} s, period {:.3} s, over-speed {}",
        m.speed_mm_s,
        m.accel_s,
        m.period_s,
        m.over_speed.name()
    )?;
    writeln!(
        out,
        "upload   bytes of the MEWTOCOL-COM % frames writing the tables (24 words a WDD frame)\n"
    )?;
    write_heading(out)?;
    for entry in entries {
        write_row(entry, out)?;
    }
    Ok(())
}

/// The table's column names.
fn write_heading(out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<24} {:<11} {:>5} {:>5} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>5}",
        "method",
        "model",
        "rows",
        "words",
        "upload B",
        "path mm",
        "track mm",
        "sample mm",
        "skew ms",
        "end mm",
        "valid"
    )
}

fn write_row(entry: &Entry, out: &mut dyn Write) -> std::io::Result<()> {
    write!(
        out,
        "{:<24} {:<11} ",
        entry.way.name(),
        entry.way.model.name()
    )?;
    let planned = match &entry.outcome {
        Ok(planned) => planned,
        Err(e) => return writeln!(out, "error: {e}"),
    };
    let f = planned.figures;
    let starts = match planned.starts.len() {
        1 => String::new(),
        n => format!(" ({n} starts chained at speed)"),
    };
    writeln!(
        out,
        "{:>5} {:>5} {:>8} {:>9.4} {:>9.4} {:>9.4} {:>9.3} {:>8.4} {:>5}{starts}",
        f.rows,
        f.words,
        planned.upload_bytes(),
        f.path_deviation_mm,
        f.tracking_error_mm,
        f.sampled_deviation_mm,
        f.end_skew_ms,
        f.end_error_mm,
        if planned.valid() { "yes" } else { "NO" }
    )
}

/// The whole comparison document.
#[derive(Debug, Serialize)]
struct Document {
    linterpd_compare: u32,
    robot: String,
    #[serde(rename = "move")]
    move_: MoveDoc,
    upload: UploadDoc,
    plans: Vec<PlanDoc>,
}

#[derive(Debug, Serialize)]
struct MoveDoc {
    #[serde(skip_serializing_if = "Option::is_none")]
    from: Option<[f64; 4]>,
    to: [f64; 4],
    speed_mm_s: f64,
    accel_s: f64,
    period_s: f64,
    over_speed: &'static str,
}

#[derive(Debug, Serialize)]
struct UploadDoc {
    protocol: &'static str,
    header: &'static str,
    words_per_frame: usize,
}

#[derive(Debug, Serialize)]
struct PlanDoc {
    method: &'static str,
    seed_exact: bool,
    frequency_model: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    tolerance_mm: Option<f64>,
    valid: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    problems: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    speed_factor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    figures: Option<FiguresDoc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    upload_bytes: Option<usize>,
    /// PLC starts, when more than one (a line cut where a joint reverses).
    #[serde(skip_serializing_if = "Option::is_none")]
    starts: Option<usize>,
}

fn document(robot: &Robot, base: &MoveRequest, entries: &[Entry]) -> Document {
    let m = base.motion;
    Document {
        linterpd_compare: 1,
        robot: robot.name.clone(),
        move_: MoveDoc {
            from: match base.from {
                Origin::Pose(p) => Some(p.to_mm_deg()),
                Origin::Counts(_) => None,
            },
            to: base.to.to_mm_deg(),
            speed_mm_s: m.speed_mm_s,
            accel_s: m.accel_s,
            period_s: m.period_s,
            over_speed: m.over_speed.name(),
        },
        upload: UploadDoc {
            protocol: "mewtocol-com",
            header: "%",
            words_per_frame: max_write_words(Header::Percent),
        },
        plans: entries.iter().map(plan_doc).collect(),
    }
}

fn plan_doc(entry: &Entry) -> PlanDoc {
    let way = entry.way;
    let mut doc = PlanDoc {
        method: way.method.name(),
        seed_exact: way.seed_exact(),
        frequency_model: way.model.name(),
        tolerance_mm: way.tolerance_mm(),
        valid: false,
        error: None,
        problems: Vec::new(),
        speed_factor: None,
        figures: None,
        upload_bytes: None,
        starts: None,
    };
    match &entry.outcome {
        Ok(planned) => {
            doc.valid = planned.valid();
            doc.problems = planned
                .starts
                .iter()
                .flat_map(|p| p.problems.iter().cloned())
                .collect();
            doc.speed_factor = Some(planned.starts[0].speed_factor);
            doc.figures = Some(FiguresDoc::from(planned.figures));
            doc.upload_bytes = Some(planned.upload_bytes());
            doc.starts = (planned.starts.len() > 1).then_some(planned.starts.len());
        }
        Err(e) => doc.error = Some(e.to_string()),
    }
    doc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{ControlCode, Direction, Duty, FrequencyRange, OutputMethod, Row, Segment};

    fn table(rows: usize) -> ChannelTable {
        ChannelTable {
            channel: 0,
            start: 0,
            segments: vec![Segment {
                control: ControlCode {
                    output: OutputMethod::PulseSign,
                    direction: Direction::Up,
                    absolute: true,
                    range: FrequencyRange::High,
                    duty: Duty::Half,
                },
                rows: (1..=rows)
                    .map(|i| Row {
                        freq_hz: 1_000,
                        target: i as i64,
                    })
                    .collect(),
            }],
        }
    }

    #[test]
    fn upload_of_a_table_is_its_words_in_24_word_frames() {
        let t = table(20);
        let words = encoded_words(&t);
        let frames = words.div_ceil(24);
        // '%' + station (2) + "#WDD" (4) + two 5-digit addresses (10) + BCC (2) + CR = 20 bytes a
        // frame, and 4 hex digits a word.
        assert_eq!(table_upload_bytes(&t), frames * 20 + words * 4);
    }

    #[test]
    fn six_ways_seed_exact_first_bounded_error_last() {
        let ways = ways(0.05);
        assert_eq!(ways.len(), 6);
        assert!(ways[0].seed_exact() && ways[1].seed_exact());
        assert_eq!(ways[5].tolerance_mm(), Some(0.05));
        assert_eq!(ways[0].tolerance_mm(), None);
        assert_eq!(ways[4].model, FrequencyModel::Ideal);
    }
}
