//! The demo's pick-and-place cycle on the seed robot: from P1 up 100 mm, across to 100 mm above
//! P2, down to P2 (240 mm/s, Ta 200 ms, bounded-error 0.05 mm), once with 20 mm blends and once
//! with a stop at every waypoint, each run by the daemon's path route (`submit_path`) against
//! the mock and measured from its pulse trace: the cycle time (from the PLC's first start to
//! the last pulse) and every start's path deviation from the planned path, blends included.

use serde_json::json;

use super::{BATCH_LIMIT, DemoError, DemoMove, P1, P2, as_reported, cut, measure_waits, replay};

use crate::daemon::{MoveOrder, PathOrder, RobotHandle, Stage};
use crate::kinematics::JOINTS;
use crate::mock::PulsePoint;
use crate::plan::{Plan, plan_path};
use crate::robot::Robot;

use super::rig::Rig;

/// The tolerance the cycle is planned to, mm.
pub const CYCLE_TOLERANCE_MM: f64 = 0.05;
/// The blend radius at the two corners, mm.
pub const CYCLE_BLEND_MM: f64 = 20.0;
/// The path's acceleration limit across arcs, mm/s^2.
const CYCLE_PATH_ACCEL: &str = "5000mm/s2";

/// One run of the cycle.
#[derive(Debug, Clone)]
pub struct Cycle {
    /// What the report calls it.
    pub name: &'static str,
    /// Every start the daemon ran for it, in order.
    pub starts: Vec<DemoMove>,
    /// From the PLC's first start to the last pulse, s (mock time).
    pub cycle_s: f64,
}

impl Cycle {
    /// The largest path deviation measured over its starts, mm.
    #[must_use]
    pub fn deviation_mm(&self) -> f64 {
        self.starts
            .iter()
            .map(|m| m.played.figures.path_deviation_mm)
            .fold(0.0, f64::max)
    }
}

/// The cycle's path document: `corner` at the two waypoints on the way, a stop at P2.
fn document(corner: &serde_json::Value) -> serde_json::Value {
    let mut up = json!({"line": [P1[0], P1[1], P1[2] + 100.0]});
    let mut across = json!({"line": [P2[0], P2[1], P2[2] + 100.0]});
    for element in [&mut up, &mut across] {
        if let (Some(map), Some(c)) = (element.as_object_mut(), corner.as_object()) {
            map.extend(c.clone());
        }
    }
    json!({
        "start": P1,
        "path_accel": CYCLE_PATH_ACCEL,
        "element": [up, across, {"line": P2, "stop": true}],
    })
}

/// Runs the cycle blended and stopped, each from P1 (a line move takes the robot there first).
pub(super) async fn run_cycles(
    handle: &RobotHandle,
    rig: &Rig,
    scan_s: f64,
) -> Result<Vec<Cycle>, DemoError> {
    let blended = json!({"blend": format!("{CYCLE_BLEND_MM}mm")});
    let stopped = json!({"stop": true});
    let mut out = Vec::new();
    for (name, corner) in [
        ("pick and place, 20 mm blends", blended),
        ("pick and place, stopped at every waypoint", stopped),
    ] {
        back_to_p1(handle, rig, name).await?;
        out.push(run_cycle(handle, rig, scan_s, name, &document(&corner)).await?);
    }
    Ok(out)
}

/// A line move to P1, its pulses taken out of the trace.
async fn back_to_p1(handle: &RobotHandle, rig: &Rig, name: &'static str) -> Result<(), DemoError> {
    let order = MoveOrder {
        to: Some(P1.to_vec()),
        ..MoveOrder::default()
    };
    let id = handle
        .submit(order)
        .await
        .map_err(|source| DemoError::Refused { name, source })?;
    let report = handle.wait(id, BATCH_LIMIT).await;
    match report {
        Some(r) if r.stage == Stage::Done => {}
        other => {
            return Err(DemoError::NotDone {
                name,
                stage: other.as_ref().map_or(Stage::Queued, |r| r.stage),
                why: other
                    .and_then(|r| r.error)
                    .unwrap_or_else(|| "timed out".into()),
            });
        }
    }
    rig.mock.with(crate::mock::MockPlc::take_pulses);
    Ok(())
}

async fn run_cycle(
    handle: &RobotHandle,
    rig: &Rig,
    scan_s: f64,
    name: &'static str,
    doc: &serde_json::Value,
) -> Result<Cycle, DemoError> {
    let order = PathOrder {
        path: doc.clone(),
        tolerance_mm: Some(CYCLE_TOLERANCE_MM),
        ..PathOrder::default()
    };
    let ids = handle
        .submit_path(&order)
        .await
        .map_err(|source| DemoError::Refused { name, source })?;
    let reports = done(handle, name, ids).await?;
    let plans = replan(handle.robot(), name, &order, &reports)?;
    let runs = played_runs(rig, name, &plans)?;
    let mut starts: Vec<DemoMove> = reports
        .into_iter()
        .zip(plans)
        .zip(runs)
        .enumerate()
        .map(|(i, ((report, plan), run))| DemoMove {
            name,
            chained: i > 0,
            chain: None,
            played: replay(handle.robot(), &plan, &run, scan_s),
            report,
            plan,
        })
        .collect();
    measure_waits(&mut starts, &rig.mock.with(|m| m.starts().to_vec()));
    Ok(Cycle::of(name, starts))
}

impl Cycle {
    /// Cycle `name` of `starts`, timed from the first start to the last one's finish.
    fn of(name: &'static str, starts: Vec<DemoMove>) -> Self {
        let first = starts.first().map_or(0.0, |m| m.played.start_s);
        let end = starts
            .last()
            .map_or(0.0, |m| m.played.start_s + m.played.figures.finish_s);
        Self {
            name,
            starts,
            cycle_s: end - first,
        }
    }
}

/// The mock's pulses since the last take, cut into the runs of `plans`.
fn played_runs(
    rig: &Rig,
    name: &'static str,
    plans: &[Plan],
) -> Result<Vec<Vec<PulsePoint>>, DemoError> {
    let trace = rig.mock.with(crate::mock::MockPlc::take_pulses);
    cut(&trace, &plans.iter().collect::<Vec<_>>()).ok_or_else(|| {
        DemoError::Trace(format!(
            "{name}: {} pulses do not match the plans",
            trace.len()
        ))
    })
}

/// The reports of the path's starts `ids`, each once it is done; the first that is not, refused.
async fn done(
    handle: &RobotHandle,
    name: &'static str,
    ids: Vec<crate::daemon::MoveId>,
) -> Result<Vec<crate::daemon::MoveReport>, DemoError> {
    let mut reports = Vec::new();
    for id in ids {
        let report = handle
            .wait(id, BATCH_LIMIT)
            .await
            .unwrap_or_else(|| unreachable!("move {id} was just submitted and reports are kept"));
        if report.stage != Stage::Done {
            return Err(DemoError::NotDone {
                name,
                stage: report.stage,
                why: report.error.clone().unwrap_or_else(|| "timed out".into()),
            });
        }
        reports.push(report);
    }
    Ok(reports)
}

/// The daemon's plans of the path's starts, made again from the counts the first was planned
/// from (the same plans: it must agree with every report's prediction).
fn replan(
    robot: &Robot,
    name: &'static str,
    order: &PathOrder,
    reports: &[crate::daemon::MoveReport],
) -> Result<Vec<Plan>, DemoError> {
    let trace_error = |why: String| DemoError::Trace(format!("{name}: {why}"));
    let start = reports
        .first()
        .and_then(|r| r.start_counts)
        .ok_or_else(|| trace_error("no start counts".into()))?;
    let counts: [i64; JOINTS] =
        std::array::from_fn(|j| start[usize::from(robot.joints[j].channel)]);
    let req = order
        .request(
            robot,
            &crate::daemon::OrderLimits::of(robot),
            counts,
            &|_| None,
        )
        .map_err(|e| trace_error(e.to_string()))?;
    let planned = plan_path(robot, &req).map_err(|e| trace_error(e.to_string()))?;
    let plans: Vec<Plan> = planned.starts().cloned().collect();
    let same = plans.len() == reports.len()
        && plans
            .iter()
            .zip(reports)
            .all(|(plan, report)| as_reported(plan, report));
    if !same {
        return Err(trace_error(
            "planned again, the path differs from the daemon's plan".into(),
        ));
    }
    Ok(plans)
}
