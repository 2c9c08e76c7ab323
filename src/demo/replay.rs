//! PURE. A move's pulses cut out of the mock PLC's pulse trace and replayed through the robot's
//! forward kinematics against its planned line: the measured figures.
//!
//! Moves run one after another, so in a trace sorted by time each move's pulses follow the
//! previous move's: a move has exactly as many pulses as its plan's execution (a row emits
//! |target - count| pulses whatever its timing). Its start is the scan at which the PLC started
//! it: the mock emits a start's first pulse exactly when the execution model does, so the offset
//! between the two first pulses, rounded to a whole scan, is the start time.

use crate::geometry::ToolPath;
use crate::kinematics::JOINTS;
use crate::mock::PulsePoint;
use crate::plan::Plan;
use crate::robot::Robot;
use crate::sim::{Execution, Figures, PulseEvent, measure};

/// One move as the mock PLC played it.
#[derive(Debug, Clone, PartialEq)]
pub struct Played {
    /// Its pulses, time from its start, `table` the joint.
    pub execution: Execution,
    /// When the PLC started it, s of mock time.
    pub start_s: f64,
    /// Counts per joint after its last pulse.
    pub end_counts: [i64; JOINTS],
    /// The figures of its replay against its plan's line and profile.
    pub figures: Figures,
}

/// Sorts `trace` by time (ties by channel) and cuts it into one run per plan, in order: `None` if
/// the pulse counts disagree (a move did not run to its end).
#[must_use]
pub fn cut(trace: &[PulsePoint], plans: &[&Plan]) -> Option<Vec<Vec<PulsePoint>>> {
    let mut sorted = trace.to_vec();
    sorted.sort_by(|a, b| {
        a.time_s
            .total_cmp(&b.time_s)
            .then(a.channel.cmp(&b.channel))
    });
    let lengths: Vec<usize> = plans.iter().map(|p| p.execution().events.len()).collect();
    let wanted: usize = lengths.iter().sum();
    if wanted != sorted.len() {
        return None;
    }
    let mut rest = sorted.as_slice();
    let mut out = Vec::with_capacity(plans.len());
    for length in lengths {
        let (run, after) = rest.split_at(length);
        out.push(run.to_vec());
        rest = after;
    }
    Some(out)
}

/// Replays one move's pulses (`run`, in time order) as played for `plan` by a PLC scanning every
/// `scan_s`.
#[must_use]
pub fn replay(robot: &Robot, plan: &Plan, run: &[PulsePoint], scan_s: f64) -> Played {
    let start_s = start_time(plan, run, scan_s);
    let joint_of = |channel: u8| robot.joints.iter().position(|j| j.channel == channel);
    let events: Vec<PulseEvent> = run
        .iter()
        .filter_map(|p| {
            Some(PulseEvent {
                t_s: p.time_s - start_s,
                table: joint_of(p.channel)?,
                count: p.count,
            })
        })
        .collect();
    let mut end_counts: [i64; JOINTS] = std::array::from_fn(|j| plan.tables[j].start);
    let mut finish_s = vec![None; JOINTS];
    for e in &events {
        end_counts[e.table] = e.count;
        finish_s[e.table] = Some(e.t_s);
    }
    let execution = Execution {
        events,
        rows: Vec::new(),
        finish_s,
    };
    let planned = |t: f64| plan.planned_position_mm(t);
    let tool_path: &dyn ToolPath = match &plan.path {
        Some(path) => path,
        None => &plan.line,
    };
    let figures = measure(
        robot,
        &plan.tables,
        &execution,
        tool_path,
        &planned,
        plan.duration_s(),
    );
    Played {
        execution,
        start_s,
        end_counts,
        figures,
    }
}

/// The scan at which the PLC started `plan`'s run: the first traced pulse less the first
/// planned one, to the nearest scan.
fn start_time(plan: &Plan, run: &[PulsePoint], scan_s: f64) -> f64 {
    let first = plan.execution().events.first().copied();
    let (Some(traced), Some(planned)) = (run.first(), first) else {
        return run.first().map_or(0.0, |p| p.time_s);
    };
    ((traced.time_s - planned.t_s) / scan_s).round() * scan_s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::plan::{MoveRequest, Origin, plan_move};
    use crate::robot::seed_robot;

    fn plan() -> Plan {
        let robot = seed_robot();
        let request = MoveRequest {
            from: Origin::Pose(Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0)),
            to: Pose::from_mm_deg(-936.57, 541.03, 56.0, 0.0),
            motion: robot.motion,
        };
        plan_move(&robot, &request).unwrap()
    }

    /// The plan's own events as a trace started at `start_s`.
    fn traced(plan: &Plan, start_s: f64) -> Vec<PulsePoint> {
        plan.execution()
            .events
            .iter()
            .map(|e| PulsePoint {
                time_s: e.t_s + start_s,
                channel: e.table as u8,
                count: e.count,
            })
            .collect()
    }

    #[test]
    fn a_trace_of_the_plan_itself_measures_what_the_plan_predicts() {
        let p = plan();
        let played = replay(&seed_robot(), &p, &traced(&p, 1.234), 0.002);
        assert!((played.start_s - 1.234).abs() < 1e-9);
        assert!((played.figures.path_deviation_mm - p.figures.path_deviation_mm).abs() < 1e-12);
        assert!((played.figures.tracking_error_mm - p.figures.tracking_error_mm).abs() < 1e-9);
        assert_eq!(played.end_counts, p.end_counts());
    }

    #[test]
    fn two_runs_are_cut_where_the_first_plans_pulses_end() {
        let p = plan();
        let mut trace = traced(&p, 5.0);
        trace.extend(traced(&p, 0.5));
        let runs = cut(&trace, &[&p, &p]).unwrap();
        assert_eq!(runs[0].len(), p.execution().events.len());
        assert!(runs[0].last().unwrap().time_s < runs[1][0].time_s);
        assert!(cut(&trace[1..], &[&p, &p]).is_none());
    }
}
