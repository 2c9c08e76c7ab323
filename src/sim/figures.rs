//! The accuracy figures of an executed start (ACCURACY.md, "Figures"), evaluated exactly at every
//! pulse event, where the pose changes.

use nalgebra::Vector3;

use super::Execution;
use crate::geometry::ToolPath;
use crate::kinematics::{JOINTS, Kinematics};
use crate::robot::Robot;
use crate::table::{ChannelTable, encoded_words};

/// The seed's sampling period for the "sampled deviation" figure, s.
pub const SAMPLE_PERIOD_S: f64 = 0.010;

/// How well an executed start follows its line.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Figures {
    /// Largest distance from the executed pose to the planned path (the segment P1P2 of a line
    /// move), at every pulse event, mm.
    pub path_deviation_mm: f64,
    /// Largest distance from the executed pose to the planned pose at the same time, mm.
    pub tracking_error_mm: f64,
    /// Path deviation sampled every 10 ms, as the seed measured it, mm.
    pub sampled_deviation_mm: f64,
    /// Largest difference between the channels' finish times, ms.
    pub end_skew_ms: f64,
    /// Distance from the final pose to P2, mm.
    pub end_error_mm: f64,
    /// When the last pulse of the start landed, s.
    pub finish_s: f64,
    /// Table rows over all channels.
    pub rows: usize,
    /// DT words of every channel area the start writes.
    pub words: usize,
}

/// Measures an execution of `tables` (one per joint, in joint order) against the planned `path`
/// (a line move's [`crate::geometry::Line`]) and the planned position `planned(t)`.
///
/// # Panics
/// Never: without a limit the measurement always completes.
#[must_use]
pub fn measure(
    robot: &Robot,
    tables: &[ChannelTable],
    exec: &Execution,
    path: &dyn ToolPath,
    planned: &dyn Fn(f64) -> Vector3<f64>,
    planned_duration_s: f64,
) -> Figures {
    measure_within(
        robot,
        tables,
        exec,
        path,
        planned,
        planned_duration_s,
        f64::INFINITY,
    )
    .expect("no limit")
}

/// [`measure`], giving up (`None`) as soon as the path deviation passes `path_limit_mm`.
#[must_use]
pub fn measure_within(
    robot: &Robot,
    tables: &[ChannelTable],
    exec: &Execution,
    path: &dyn ToolPath,
    planned: &dyn Fn(f64) -> Vector3<f64>,
    planned_duration_s: f64,
    path_limit_mm: f64,
) -> Option<Figures> {
    let mut counts: [i64; JOINTS] = std::array::from_fn(|j| tables.get(j).map_or(0, |t| t.start));
    let position = |c: &[i64; JOINTS]| robot.kinematics.fk(&robot.values_of(c)).position_mm;
    path.restart();
    let mut p = position(&counts);
    let mut deviation = path.distance_mm(&p);
    let mut tracking = (p - planned(0.0)).norm();
    let mut sampled: f64 = 0.0;
    let mut next_sample = 0.0;
    for e in &exec.events {
        while next_sample < e.t_s {
            sampled = sampled.max(path.distance_mm(&p));
            next_sample += SAMPLE_PERIOD_S;
        }
        // The planned pose moves while the executed one holds: check both ends of the hold.
        let target = planned(e.t_s);
        tracking = tracking.max((p - target).norm());
        counts[e.table] = e.count;
        p = position(&counts);
        deviation = deviation.max(path.distance_mm(&p));
        if deviation > path_limit_mm {
            return None;
        }
        tracking = tracking.max((p - target).norm());
    }
    let finish_s = exec.events.last().map_or(0.0, |e| e.t_s);
    tracking = tracking.max((p - planned(planned_duration_s.max(finish_s))).norm());
    while next_sample <= planned_duration_s.max(finish_s) + 1e-12 {
        sampled = sampled.max(path.distance_mm(&p));
        next_sample += SAMPLE_PERIOD_S;
    }
    let finishes: Vec<f64> = exec.finish_s.iter().flatten().copied().collect();
    let skew = finishes.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - finishes.iter().copied().fold(f64::INFINITY, f64::min);
    Some(Figures {
        path_deviation_mm: deviation,
        tracking_error_mm: tracking,
        sampled_deviation_mm: sampled,
        end_skew_ms: if finishes.is_empty() { 0.0 } else { skew * 1e3 },
        end_error_mm: (p - path.end_mm()).norm(),
        finish_s,
        rows: tables.iter().map(ChannelTable::rows).sum(),
        words: tables
            .iter()
            .filter(|t| !t.segments.is_empty())
            .map(encoded_words)
            .sum(),
    })
}
