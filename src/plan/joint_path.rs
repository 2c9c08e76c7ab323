//! A straight line in joint space, what a joint move follows: every joint from its start value
//! to its target in proportion, the tool wherever forward kinematics puts it.

use crate::geometry::{Polyline, Pose};
use crate::kinematics::{Arm, Joints, Kinematics};

/// A straight line in joint space: every joint moves in proportion, from `from` to `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointPath {
    /// Joint values at the start, rad or mm.
    pub from: Joints,
    /// Joint values at the end, rad or mm.
    pub to: Joints,
    /// The robot's kinematics, for where the tool is along the way.
    model: Arm,
}

impl JointPath {
    /// The path from `from` to `to` for a robot of kinematics `model`.
    #[must_use]
    pub fn new(model: &Arm, from: Joints, to: Joints) -> Self {
        Self {
            from,
            to,
            model: model.clone(),
        }
    }

    /// Joint values at fraction `u` (0 to 1) of the way; exactly `to` at 1.
    #[must_use]
    pub fn joints_at(&self, u: f64) -> Joints {
        if u >= 1.0 {
            return self.to;
        }
        std::array::from_fn(|j| self.from[j] + (self.to[j] - self.from[j]) * u.max(0.0))
    }

    /// The tool's pose at fraction `u` of the way.
    #[must_use]
    pub fn pose_at(&self, u: f64) -> Pose {
        self.model.fk(&self.joints_at(u))
    }

    /// The tool point's path as a polyline of `chords` equal steps of the joints.
    pub(super) fn trace(&self, chords: usize) -> Polyline {
        Polyline::new(
            (0..=chords)
                .map(|i| self.pose_at(i as f64 / chords as f64).position_mm)
                .collect(),
        )
    }
}
