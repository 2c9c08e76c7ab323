//! The readable plan: the move and its profile, every channel's segments and rows, the figures.

use std::io::{self, Write};

use crate::kinematics::Kinematics;
use crate::plan::Plan;
use crate::robot::Robot;
use crate::sim::RowTiming;
use crate::table::{Direction, Duty, FrequencyRange, Segment};

fn range_text(range: FrequencyRange) -> &'static str {
    match range {
        FrequencyRange::Low => "range 0 (1.5 Hz-9.8 kHz)",
        FrequencyRange::Mid => "range 1 (48 Hz-100 kHz)",
        FrequencyRange::High => "range 2 (191 Hz-100 kHz)",
    }
}

fn pose_text(p: [f64; 4]) -> String {
    format!(
        "({:.3}, {:.3}, {:.3}) mm, a {:.4} deg",
        p[0], p[1], p[2], p[3]
    )
}

/// Writes the whole plan.
pub(super) fn write(robot: &Robot, plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    let params: Vec<String> = robot
        .kinematics
        .params()
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    writeln!(
        out,
        "robot    {} ({}; {})",
        robot.name,
        robot.kinematics.name(),
        params.join(", ")
    )?;
    writeln!(out, "from     {}", pose_text(plan.line.from.to_mm_deg()))?;
    writeln!(out, "to       {}", pose_text(plan.line.to.to_mm_deg()))?;
    let method = if plan.motion.method.is_seed_exact() {
        "seed-exact (the paper as printed)"
    } else {
        plan.motion.method.name()
    };
    writeln!(
        out,
        "method   {method}, frequency model {}",
        plan.motion.frequency_model.name()
    )?;
    write_profile(plan, out)?;
    let timings = plan.row_timings();
    for (j, table) in plan.tables.iter().enumerate() {
        write_channel(robot, plan, &timings, j, out)?;
        if table.segments.is_empty() {
            writeln!(out, "  (does not move: no table)")?;
        }
    }
    write_figures(plan, out)?;
    write_drives(robot, plan, out)
}

/// Every moving joint's drive: its peaks against its limits.
pub(super) fn write_drives(robot: &Robot, plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    writeln!(
        out,
        "drives   (peaks of the planned motion and the rows; limits from the config)"
    )?;
    for ((joint, d), table) in robot.joints.iter().zip(&plan.drive).zip(&plan.tables) {
        if table.segments.is_empty() {
            continue;
        }
        let unit = joint.kind.user_unit();
        let accel = joint.dynamics.max_accel.map_or(String::new(), |a| {
            format!(" (max_accel {})", joint.user(a).abs())
        });
        let step = d.step_load.map_or(String::new(), |l| {
            format!(
                ", largest row step {:.0} % of what max_accel allows",
                l * 100.0
            )
        });
        let start = joint
            .dynamics
            .start_hz
            .map_or(String::new(), |hz| format!(" (start_hz {hz})"));
        let jerk = d.peak_jerk.map_or(String::new(), |v| {
            let max = joint.dynamics.max_jerk.map_or(String::new(), |m| {
                format!(" (max_jerk {})", joint.user(m).abs())
            });
            format!(", jerk {v:.0} {unit}/s^3{max}")
        });
        writeln!(
            out,
            "  {:<8} {:.0} Hz, {:.2} {unit}/s, {:.1} {unit}/s^2{accel}{step}{jerk}; from and \
             to standstill {:.0} Hz{start}",
            joint.name, d.peak_hz, d.peak_speed, d.peak_accel, d.rest_hz
        )?;
    }
    Ok(())
}

fn write_profile(plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    let p = &plan.profile;
    if plan
        .pace
        .as_ref()
        .is_some_and(crate::geometry::Pace::from_rest)
    {
        return write_paced_profile(plan, out);
    }
    if p.jerk_s > 0.0 {
        writeln!(
            out,
            "profile  s-curve: {:.3} mm at {:.3} mm/s, ramps {:.3} s (at most {:.1} mm/s^2, jerk \
             phases {:.3} s), period {:.3} s: {} periods, {:.3} s",
            p.length_mm,
            p.speed_mm_s,
            p.accel_s,
            p.accel_mm_s2,
            p.jerk_s,
            p.period_s,
            p.periods(),
            p.duration_s()
        )?;
        return write_slowed(plan, out);
    }
    writeln!(
        out,
        "profile  {:.3} mm at {:.3} mm/s, ramps {:.3} s ({:.1} mm/s^2), period {:.3} s: {} periods, {:.3} s",
        p.length_mm,
        p.speed_mm_s,
        p.accel_s,
        p.accel_mm_s2,
        p.period_s,
        p.periods(),
        p.duration_s()
    )?;
    write_slowed(plan, out)
}

/// The profile of a motion timed along its pace from rest: an S-curve under drive limits, or on
/// a path section whose speed changes along it, is the time-optimal motion averaged to its jerk.
fn write_paced_profile(plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    let p = &plan.profile;
    let shape = match plan.motion.ramp {
        crate::robot::Ramp::SCurve { jerk_mm_s3 } => format!(
            "s-curve (jerk {jerk_mm_s3:.0} mm/s^3), the time-optimal motion averaged to that \
                 jerk"
        ),
        crate::robot::Ramp::Trapezoid => "time-optimal under the drive limits".to_owned(),
    };
    writeln!(
        out,
        "profile  {shape}: {:.3} mm at up to {:.3} mm/s, period {:.3} s: {} periods, {:.3} s",
        plan.pace
            .as_ref()
            .map_or(p.length_mm, crate::geometry::Pace::path_length_mm),
        p.speed_mm_s,
        p.period_s,
        p.periods(),
        p.duration_s()
    )?;
    write_slowed(plan, out)
}

fn write_slowed(plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    if plan.speed_factor < 1.0 {
        writeln!(
            out,
            "         slowed down to {:.1} % of the speed asked for (over-speed policy slow-down, \
             or an S-curve slowed until its drives follow it)",
            plan.speed_factor * 100.0
        )?;
    }
    Ok(())
}

fn write_channel(
    robot: &Robot,
    plan: &Plan,
    timings: &[RowTiming],
    j: usize,
    out: &mut dyn Write,
) -> io::Result<()> {
    let table = &plan.tables[j];
    let joint = &robot.joints[j];
    writeln!(
        out,
        "\nchannel {} {} ({} {} per pulse): count {} -> {}, {} segment(s), {} rows",
        table.channel,
        joint.name,
        joint.user(joint.step),
        joint.kind.user_unit(),
        table.start,
        table.end(),
        table.segments.len(),
        table.rows()
    )?;
    for (si, seg) in table.segments.iter().enumerate() {
        let timings = timings.iter().filter(|r| r.table == j && r.segment == si);
        write_segment(si, seg, timings, out)?;
    }
    Ok(())
}

/// Segment `si` of a channel: its control code and its rows, each with its `timings`.
fn write_segment<'a>(
    si: usize,
    seg: &Segment,
    timings: impl Iterator<Item = &'a RowTiming>,
    out: &mut dyn Write,
) -> io::Result<()> {
    let c = seg.control;
    writeln!(
        out,
        "  segment {}: {}, {}, duty {}, control code {:#06x}",
        si + 1,
        if c.direction == Direction::Up {
            "up"
        } else {
            "down"
        },
        range_text(c.range),
        if c.duty == Duty::Quarter {
            "1/4"
        } else {
            "1/2"
        },
        c.value()
    )?;
    writeln!(
        out,
        "    {:>4} {:>9} {:>12} {:>9} {:>9}",
        "row", "freq Hz", "target", "start s", "end s"
    )?;
    for (row, timing) in seg.rows.iter().zip(timings) {
        writeln!(
            out,
            "    {:>4} {:>9} {:>12} {:>9.4} {:>9.4}",
            timing.row + 1,
            row.freq_hz,
            row.target,
            timing.start_s,
            timing.end_s
        )?;
    }
    Ok(())
}

fn write_figures(plan: &Plan, out: &mut dyn Write) -> io::Result<()> {
    let f = &plan.figures;
    writeln!(
        out,
        "\nfigures (execution model, {})",
        plan.motion.frequency_model.name()
    )?;
    writeln!(
        out,
        "  path deviation      {:.4} mm  (at every pulse event)",
        f.path_deviation_mm
    )?;
    writeln!(
        out,
        "  tracking error      {:.4} mm  (against the planned pose in time)",
        f.tracking_error_mm
    )?;
    writeln!(
        out,
        "  sampled deviation   {:.4} mm  (every 10 ms, as the seed measured)",
        f.sampled_deviation_mm
    )?;
    writeln!(out, "  end skew            {:.3} ms", f.end_skew_ms)?;
    writeln!(out, "  end error           {:.4} mm", f.end_error_mm)?;
    writeln!(out, "  last pulse at       {:.4} s", f.finish_s)?;
    writeln!(out, "  rows / words        {} / {}", f.rows, f.words)?;
    if plan.valid() {
        writeln!(out, "valid    yes: every table passed F174 validation")
    } else {
        writeln!(out, "valid    NO, must not be sent to a PLC:")?;
        for p in &plan.problems {
            writeln!(out, "  - {p}")?;
        }
        Ok(())
    }
}
