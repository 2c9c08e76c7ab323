//! PURE. A move request becomes pulse tables, checked against every limit and judged by the
//! execution model before anyone may send it.
//!
//! ```text
//! request -> course (a line, a path section, a joint path) and its start (start.rs)
//!         -> the strategy: candidate timings in order, the fastest plan every drive follows
//!            (strategy.rs; each planned by its course: line.rs, path/section.rs, joint_move.rs)
//!         -> the course timed: as asked, time-optimal, averaged, slowed (dynamics/)
//!         -> profile s(t) -> samples (IK, absolute counts) -> limits, slow-down (sampled.rs)
//!         -> one start, or a section's parts (part.rs, path/parts.rs)
//!         -> spans per joint (constant-period) or rows in windows (bounded/)
//!         -> segments (direction, range, duty, frequencies) -> validation -> every drive judged
//!            (dynamics/rows.rs) -> sim -> figures (judge.rs) -> Plan (planned.rs)
//! ```
//!
//! A joint-space move ([`plan_joint_move`]) goes through the same profile, limits, rows,
//! segments, frequencies and bounded-error method as a line; only its samples come from the
//! joints in proportion instead of inverse kinematics (`course.rs`). Its figures measure the tool
//! against the tool's own path under the planned joints (forward kinematics), so a bounded-error
//! joint move's tolerance is the tool point's largest distance from that path, as for a line.

mod bounded;
mod constant_period;
mod course;
mod dynamics;
mod error;
mod joint_move;
mod joint_path;
mod judge;
mod limits;
mod line;
mod line_parts;
mod part;
mod path;
mod planned;
mod sampled;
mod samples;
mod seed_exact;
pub mod segments;
mod start;
mod strategy;

use crate::geometry::Pose;
use crate::kinematics::{JOINTS, Joints};
use crate::robot::{Motion, Robot};

pub use error::{Creep, PlanError};
pub use joint_path::JointPath;
pub use limits::{check_pose, check_target};
pub use line_parts::{MovePlan, line_as_path, plan_line};
pub use path::{
    MIN_PART_S, PathPlan, PathRequest, SECTION_START_SLACK_MM, SectionPlan, plan_path, plan_section,
};
pub use planned::{DriveFigures, Plan, Window};
pub use samples::Samples;

/// Where a move starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Origin {
    /// A pose (a plan made ahead of time): the start counts are the nearest to it.
    Pose(Pose),
    /// The counts the PLC reports (a move about to run): the line starts at their pose.
    Counts([i64; JOINTS]),
}

/// One straight-line move to plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveRequest {
    /// Where the move starts.
    pub from: Origin,
    /// The target pose.
    pub to: Pose,
    /// The motion settings (`Method::SeedExact` plans the paper as printed: comparison only,
    /// never valid for a PLC).
    pub motion: Motion,
}

/// One joint-space move to plan: every joint from where it starts to its target value, all on
/// one trapezoid (they reach their targets together).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMoveRequest {
    /// Where the move starts.
    pub from: Origin,
    /// Every joint's target value, rad or mm, in the joints' order.
    pub to: Joints,
    /// The motion settings: the speed is the tool's along its path (see the module `course`).
    pub motion: Motion,
}

/// Plans one move for `robot`: the fastest of the strategy's candidate timings that every drive
/// follows (`strategy.rs`).
pub fn plan_move(robot: &Robot, req: &MoveRequest) -> Result<Plan, PlanError> {
    let line = line::LineMove::new(robot, req)?;
    let strategy = strategy::Strategy::for_course(robot, &req.motion, strategy::Kind::Line)?;
    strategy::plan_fastest(&line, &strategy)
}

/// Plans one joint-space move for `robot`: the target is checked against every joint's limits
/// (the joints move in proportion, so the start and the target bound every position between).
pub fn plan_joint_move(robot: &Robot, req: &JointMoveRequest) -> Result<Plan, PlanError> {
    let joints = joint_move::JointMove::new(robot, req)?;
    let strategy = strategy::Strategy::for_course(robot, &req.motion, strategy::Kind::Joints)?;
    strategy::plan_fastest(&joints, &strategy).map_err(|e| {
        if e.too_big() {
            PlanError::JointMoveTooLong {
                source: Box::new(e),
            }
        } else {
            e
        }
    })
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tool_tests;
