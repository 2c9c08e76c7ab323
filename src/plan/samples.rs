//! The samples of a move at every interpolation point: on a line, the pose at every point (eq.
//! 6-7) and its joint values by inverse kinematics (revolute joints kept continuous from the
//! start); on a joint-space path, the joint values in proportion. Each joint's absolute count is
//! rounded from its absolute value, so nothing drifts.

use crate::geometry::{Pose, Profile};
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::Robot;

use super::error::PlanError;
use super::joint_path::JointPath;

/// Counts of every joint at every interpolation point 0..=N.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    /// `counts[i][j]`: joint j's count at point i.
    pub counts: Vec<[i64; JOINTS]>,
    /// `values[i][j]`: joint j's exact value at point i, rad or mm (before rounding).
    pub values: Vec<Joints>,
}

impl Samples {
    /// Joint `j`'s counts over the points.
    #[must_use]
    pub fn joint(&self, j: usize) -> Vec<i64> {
        self.counts.iter().map(|c| c[j]).collect()
    }
}

/// Samples a Cartesian path (`pose_at` a distance along it) at every period of the profile.
/// Point 0 takes `start_counts` (where the robot is), point N is exactly the path's end.
pub(super) fn sample(
    robot: &Robot,
    pose_at: &dyn Fn(f64) -> Pose,
    profile: &Profile,
    start_values: &Joints,
    start_counts: [i64; JOINTS],
) -> Result<Samples, PlanError> {
    let n = profile.periods() as usize;
    let mut counts = Vec::with_capacity(n + 1);
    let mut values = Vec::with_capacity(n + 1);
    counts.push(start_counts);
    values.push(*start_values);
    let mut near = *start_values;
    let counter = robot.counter();
    for i in 1..=n {
        let pose = pose_at(profile.distance_at_point_mm(i as u32));
        let q = robot.kinematics.ik(&pose, Some(&near))?;
        counts.push(counter.counts_of(&q));
        values.push(q);
        near = q;
    }
    let mut samples = Samples { counts, values };
    hold_until_the_path_comes(robot, &mut samples);
    Ok(samples)
}

/// A start whose counts are a pulse off the rounding of the path's first point (a robot a
/// fraction of a millimetre from a path's stated start): a joint that is a pulse ahead of where
/// the path puts it waits there, at its count, until the path comes to it, instead of stepping
/// a pulse back and then forward (a reversal of one pulse, which would cut the start into a
/// part of a few milliseconds). Only the samples before the joint is two pulses from its
/// start are held; the plan's figures then judge the result against the path as ever.
fn hold_until_the_path_comes(robot: &Robot, samples: &mut Samples) {
    let Samples { counts, values } = samples;
    let Some(&from) = counts.first() else {
        return;
    };
    let last = counts.len() - 1;
    for j in 0..JOINTS {
        let away = counts
            .iter()
            .position(|c| (c[j] - from[j]).abs() >= 2)
            .unwrap_or(last);
        let way = (counts[away][j] - from[j]).signum();
        for k in 1..away {
            if (counts[k][j] - from[j]) * way < 0 {
                counts[k][j] = from[j];
                values[k][j] = robot.joints[j].value_of(from[j]);
            }
        }
    }
}

/// Samples a joint-space path at every period of the profile: every joint at the same fraction
/// of its way (the profile's distance over its length). Point 0 takes `start_counts`, point N is
/// exactly the path's end.
pub(super) fn sample_joints(
    robot: &Robot,
    path: &JointPath,
    profile: &Profile,
    start_counts: [i64; JOINTS],
) -> Samples {
    let n = profile.periods();
    let mut counts = Vec::with_capacity(n as usize + 1);
    let mut values = Vec::with_capacity(n as usize + 1);
    counts.push(start_counts);
    values.push(path.from);
    let counter = robot.counter();
    for i in 1..=n {
        let u = if i == n {
            1.0
        } else {
            profile.distance_at_point_mm(i) / profile.length_mm
        };
        let q = path.joints_at(u);
        counts.push(counter.counts_of(&q));
        values.push(q);
    }
    Samples { counts, values }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::seed_robot;

    fn samples(d3: &[i64]) -> Samples {
        let robot = seed_robot();
        let counts: Vec<[i64; JOINTS]> = d3.iter().map(|&c| [7, 8, c, 9]).collect();
        let values = counts.iter().map(|c| robot.values_of(c)).collect();
        Samples { counts, values }
    }

    #[test]
    fn a_joint_a_pulse_ahead_of_the_path_waits_for_it_instead_of_stepping_back() {
        let robot = seed_robot();
        let mut s = samples(&[100, 99, 99, 100, 101, 103, 106]);
        hold_until_the_path_comes(&robot, &mut s);
        let d3: Vec<i64> = s.counts.iter().map(|c| c[2]).collect();
        assert_eq!(d3, [100, 100, 100, 100, 101, 103, 106]);
        assert!((s.values[1][2] - robot.joints[2].value_of(100)).abs() < 1e-12);
        // A pulse behind: it steps forward at once, nothing is held.
        let mut s = samples(&[100, 101, 102, 104]);
        hold_until_the_path_comes(&robot, &mut s);
        assert_eq!(s.counts[1][2], 101);
        // A real reversal further on is the path's own: kept.
        let mut s = samples(&[100, 102, 104, 102, 99]);
        hold_until_the_path_comes(&robot, &mut s);
        let d3: Vec<i64> = s.counts.iter().map(|c| c[2]).collect();
        assert_eq!(d3, [100, 102, 104, 102, 99]);
    }
}
