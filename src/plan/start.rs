//! PURE. Where a move starts: the joint values it is planned from and the counts that stand
//! for them.

use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::Robot;

use super::Origin;
use super::error::PlanError;

/// Where a move starts: joint values and the counts that stand for them.
pub(super) struct Start {
    pub(super) values: Joints,
    pub(super) counts: [i64; JOINTS],
}

impl Start {
    /// The start `origin` gives: a pose's joint values and their nearest counts, or counts and
    /// the values they stand for.
    pub(super) fn at(robot: &Robot, origin: Origin) -> Result<Self, PlanError> {
        Ok(match origin {
            Origin::Pose(pose) => {
                let values = robot.kinematics.ik(&pose, None)?;
                Self {
                    values,
                    counts: robot.counts_of(&values),
                }
            }
            Origin::Counts(counts) => Self {
                values: robot.values_of(&counts),
                counts,
            },
        })
    }
}
