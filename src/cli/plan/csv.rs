//! One CSV line per table row, with when the execution model says the row runs.

use std::io::Write;

use crate::plan::Plan;
use crate::robot::Robot;

/// Writes the header and one line per row: channel, joint, segment, row (both from 1),
/// frequency value, absolute target, start and end time in seconds.
pub(super) fn write(robot: &Robot, plan: &Plan, out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        out,
        "channel,joint,segment,row,frequency_hz,target,start_s,end_s"
    )?;
    for timing in &plan.execution.rows {
        let table = &plan.tables[timing.table];
        let row = table.segments[timing.segment].rows[timing.row];
        writeln!(
            out,
            "{},{},{},{},{},{},{:.6},{:.6}",
            table.channel,
            robot.joints[timing.table].name,
            timing.segment + 1,
            timing.row + 1,
            row.freq_hz,
            row.target,
            timing.start_s,
            timing.end_s
        )?;
    }
    Ok(())
}
