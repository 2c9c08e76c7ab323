//! One CSV line per table row, with when the execution model says the row runs; for a path,
//! every start's rows, each line led by the start's number and its section.

use std::io::Write;

use super::starts::Start;
use crate::plan::Plan;
use crate::robot::Robot;

/// The columns every row has.
const ROW_COLUMNS: &str = "channel,joint,segment,row,frequency_hz,target,start_s,end_s";

/// Writes the header and one line per row: channel, joint, segment, row (both from 1),
/// frequency value, absolute target, start and end time in seconds.
pub(super) fn write(robot: &Robot, plan: &Plan, out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(out, "{ROW_COLUMNS}")?;
    write_rows(robot, plan, "", out)
}

/// Writes the header and one line per row of every start of a path: the start's number and
/// section (both from 1), then the columns of [`write`] (times from the start's own start), then
/// the row's start and end from the path's start (the starts back to back).
pub(super) fn write_starts(
    robot: &Robot,
    starts: &[Start<'_>],
    out: &mut dyn Write,
) -> std::io::Result<()> {
    writeln!(out, "start,section,{ROW_COLUMNS},path_start_s,path_end_s")?;
    for s in starts {
        let lead = format!("{},{},", s.number, s.section);
        for timing in &s.plan.row_timings() {
            write_row(robot, s.plan, timing, &lead, out)?;
            writeln!(
                out,
                ",{:.6},{:.6}",
                s.begins_s + timing.start_s,
                s.begins_s + timing.end_s
            )?;
        }
    }
    Ok(())
}

/// One line per row of `plan`, each led by `lead`.
fn write_rows(robot: &Robot, plan: &Plan, lead: &str, out: &mut dyn Write) -> std::io::Result<()> {
    for timing in &plan.row_timings() {
        write_row(robot, plan, timing, lead, out)?;
        writeln!(out)?;
    }
    Ok(())
}

/// The columns of one row, led by `lead`, without the line's end.
fn write_row(
    robot: &Robot,
    plan: &Plan,
    timing: &crate::sim::RowTiming,
    lead: &str,
    out: &mut dyn Write,
) -> std::io::Result<()> {
    let table = &plan.tables[timing.table];
    let row = table.segments[timing.segment].rows[timing.row];
    write!(
        out,
        "{lead}{},{},{},{},{},{},{:.6},{:.6}",
        table.channel,
        robot.joints[timing.table].name,
        timing.segment + 1,
        timing.row + 1,
        row.freq_hz,
        row.target,
        timing.start_s,
        timing.end_s
    )
}
