//! The demo's report (text) and picture (SVG).

use std::io::{self, Write};

use super::{CYCLE_BLEND_MM, CYCLE_TOLERANCE_MM, ChainWait, Demo, DemoMove, P1, P2};
use crate::plot::{Path, PlotError, svg_paths};
use crate::robot::{Method, Motion, Robot};

/// `(x, y, z)` to two decimals.
fn point(p: [f64; 3]) -> String {
    format!("({:.2}, {:.2}, {:.2})", p[0], p[1], p[2])
}

/// The method and motion a move was planned with.
fn motion(m: &Motion) -> String {
    let method = match m.method {
        Method::ConstantPeriod => format!("constant-period dT {:.0} ms", m.period_s * 1e3),
        Method::SeedExact => format!("seed-exact dT {:.0} ms", m.period_s * 1e3),
        Method::BoundedError { tolerance_mm } => format!("bounded-error {tolerance_mm} mm"),
    };
    format!(
        "{method}, V {} mm/s, Ta {:.0} ms",
        m.speed_mm_s,
        m.accel_s * 1e3
    )
}

fn seconds(s: Option<f64>) -> String {
    s.map_or_else(|| "-".into(), |s| format!("{s:.3} s"))
}

/// A stage as the API spells it.
fn stage(stage: crate::daemon::Stage) -> String {
    serde_json::to_value(stage)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_else(|| format!("{stage:?}"))
}

fn header(demo: &Demo, out: &mut dyn Write) -> io::Result<()> {
    let name = demo.options.link.name();
    let mut link = demo.options.baud.map_or_else(
        || format!("{name}, no line speed emulated"),
        |b| format!("{name} over an emulated {b}-baud serial line"),
    );
    if !demo.options.read_back {
        link.push_str(", uploads not read back");
    }
    writeln!(
        out,
        "linterpd demo: robot {}, run by the daemon's own move path against a mock FP-X in",
        demo.robot.name
    )?;
    writeln!(
        out,
        "process ({link}; scan {:.0} ms; channels {}).",
        demo.scan_s * 1e3,
        demo.robot.motion.frequency_model.name()
    )?;
    writeln!(
        out,
        "P1 = {} mm (wrist at 0), P2 = {} mm.",
        point(P1),
        point(P2)
    )?;
    writeln!(
        out,
        "Path deviation: measured = the mock's pulse trace replayed through forward kinematics;"
    )?;
    writeln!(out, "predicted = the planner's execution model.")
}

/// What a chained move's wait on the trace says: no idle time, or how long the PLC idled.
fn chain_wait(chain: &ChainWait) -> String {
    let started_ms = chain.started_after_s * 1e3;
    if chain.seen_after_s < 0.0 {
        format!(
            "waiting in the PLC {:.0} ms before the move before ended; started {started_ms:.1} ms after it: no idle time",
            -chain.seen_after_s * 1e3
        )
    } else {
        format!(
            "reached the PLC {:.1} ms after the move before ended (its upload outlasted that move): the PLC idled; started {started_ms:.1} ms after it",
            chain.seen_after_s * 1e3
        )
    }
}

fn one(robot: &Robot, n: usize, m: &DemoMove, out: &mut dyn Write) -> io::Result<()> {
    let r = &m.report;
    let p = r
        .predicted
        .unwrap_or_else(|| unreachable!("a done move was planned"));
    writeln!(out)?;
    writeln!(out, "{n}. {}: {}", m.name, motion(&m.plan.motion))?;
    // The trace's motion; the daemon's (`motion_s`) runs to the poll that saw the move end,
    // later while the next move's upload holds the line.
    let polled = r.motion_s.map_or_else(String::new, |s| {
        format!("; the daemon saw it end after {s:.3} s")
    });
    writeln!(
        out,
        "   {}: {} rows, {} words, upload {}, motion {:.3} s on the trace (planned {:.3} s{polled})",
        stage(r.stage),
        p.rows,
        p.words,
        seconds(r.upload_s),
        m.played.figures.finish_s,
        p.duration_s,
    )?;
    if let Some(chain) = &m.chain {
        writeln!(out, "   {}", chain_wait(chain))?;
    }
    let measured = m.played.figures.path_deviation_mm;
    writeln!(
        out,
        "   path deviation: measured {measured:.4} mm, predicted {:.4} mm (differ by {:.2} µm)",
        p.path_deviation_mm,
        (measured - p.path_deviation_mm).abs() * 1e3
    )?;
    let (error, from_trace) = m.final_error_pulses(robot);
    writeln!(
        out,
        "   final error: {error:?} pulses{}",
        if from_trace {
            " (from the trace: the daemon does not read a chained move's end)"
        } else {
            ""
        }
    )
}

/// Writes the report: a header, then a few lines per move and a closing line.
pub fn write_report(demo: &Demo, out: &mut dyn Write) -> io::Result<()> {
    header(demo, out)?;
    for (i, m) in demo.moves.iter().enumerate() {
        one(&demo.robot, i + 1, m, out)?;
    }
    let worst = demo
        .moves
        .iter()
        .filter_map(|m| {
            let p = m.report.predicted?;
            Some((m.played.figures.path_deviation_mm - p.path_deviation_mm).abs())
        })
        .fold(0.0, f64::max);
    writeln!(out)?;
    writeln!(
        out,
        "{} moves done; measured and predicted path deviations differ by at most {:.2} µm",
        demo.moves.len(),
        worst * 1e3
    )?;
    writeln!(
        out,
        "(they can differ only where a channel has several segments: the mock starts the next\n\
         one at its next scan, the planner at once)."
    )?;
    cycles(demo, out)?;
    super::drives::write(&demo.drives, out)
}

/// The pick-and-place cycle, blended and stopped, and how much shorter blending makes it.
fn cycles(demo: &Demo, out: &mut dyn Write) -> io::Result<()> {
    if demo.cycles.is_empty() {
        return Ok(());
    }
    writeln!(out)?;
    writeln!(
        out,
        "Pick and place: P1 up 100 mm, across to 100 mm above P2, down to P2; bounded-error \
         {CYCLE_TOLERANCE_MM} mm,"
    )?;
    writeln!(
        out,
        "measured on the trace (cycle = the PLC's first start to the last pulse):"
    )?;
    for c in &demo.cycles {
        let chained = c
            .starts
            .iter()
            .filter(|m| m.plan.window.begins_at_speed())
            .count();
        writeln!(
            out,
            "  {}: {} starts ({chained} chained at speed), cycle {:.3} s, path deviation {:.4} mm",
            c.name,
            c.starts.len(),
            c.cycle_s,
            c.deviation_mm()
        )?;
    }
    if let [blended, stopped] = demo.cycles.as_slice() {
        writeln!(
            out,
            "  {CYCLE_BLEND_MM} mm blends make the cycle {:.1} % shorter",
            (1.0 - blended.cycle_s / stopped.cycle_s) * 100.0
        )?;
    }
    Ok(())
}

/// The picture: every move's executed path (from the trace) along P1P2 and its deviation.
pub fn picture(robot: &Robot, moves: &[DemoMove]) -> Result<String, PlotError> {
    let Some(first) = moves.first() else {
        return Err(PlotError::NoPlan);
    };
    let labels: Vec<String> = moves
        .iter()
        .enumerate()
        .map(|(i, m)| {
            format!(
                "{}. {}: {:.3} mm",
                i + 1,
                m.name,
                m.played.figures.path_deviation_mm
            )
        })
        .collect();
    let paths: Vec<Path<'_>> = moves
        .iter()
        .zip(&labels)
        .map(|(m, label)| Path {
            label,
            line: m.plan.line,
            start: std::array::from_fn(|j| m.plan.tables[j].start),
            events: &m.played.execution.events,
            tolerance_mm: m.plan.motion.method.tolerance_mm(),
        })
        .collect();
    let title = format!(
        "linterpd demo: {}, {} moves between P1 and P2 as the mock PLC played them",
        robot.name,
        moves.len()
    );
    svg_paths(robot, &title, first.plan.line, &paths)
}
