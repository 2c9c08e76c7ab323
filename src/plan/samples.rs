//! The samples of a move at every interpolation point: on a line, the pose at every point (eq.
//! 6-7) and its joint values by inverse kinematics (revolute joints kept continuous from the
//! start); on a joint-space path, the joint values in proportion. Each joint's absolute count is
//! rounded from its absolute value, so nothing drifts.

use crate::geometry::{Pose, Profile};
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::Robot;

use super::PlanError;
use super::course::JointPath;

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
    for i in 1..=n {
        let pose = pose_at(profile.distance_at_point_mm(i as u32));
        let q = robot.kinematics.ik(&pose, Some(&near))?;
        counts.push(robot.counts_of(&q));
        values.push(q);
        near = q;
    }
    Ok(Samples { counts, values })
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
    for i in 1..=n {
        let u = if i == n {
            1.0
        } else {
            profile.distance_at_point_mm(i) / profile.length_mm
        };
        let q = path.joints_at(u);
        counts.push(robot.counts_of(&q));
        values.push(q);
    }
    Samples { counts, values }
}
