//! PURE. A joint-space move as the strategy plans it ([`Timed`]): every joint in proportion on
//! one trapezoid, under drive limits the one the slowest joint allows
//! ([`dynamics::joint_move_motion`]), its planned motion checked against every joint's limits.

use crate::robot::Robot;

use super::JointMoveRequest;
use super::course::Course;
use super::dynamics;
use super::error::PlanError;
use super::limits;
use super::part::plan_course;
use super::planned::Plan;
use super::start::Start;
use super::strategy::{Timed, Timing};

/// A joint move to plan: its course in joint space, where it starts and what it asks.
pub(super) struct JointMove<'a> {
    robot: &'a Robot,
    req: &'a JointMoveRequest,
    start: Start,
    course: Course,
}

impl<'a> JointMove<'a> {
    /// The joint move `req` asks `robot` for: the target is checked against every joint's
    /// limits (the joints move in proportion, so the start and the target bound every position
    /// between).
    ///
    /// # Errors
    /// A start out of reach, a target beyond a joint's limits, a move that goes nowhere.
    pub(super) fn new(robot: &'a Robot, req: &'a JointMoveRequest) -> Result<Self, PlanError> {
        let start = Start::at(robot, req.from)?;
        limits::check_target(robot, &req.to)?;
        let course = Course::joints(robot, start.values, req.to);
        if robot.counts_of(&req.to) == start.counts || course.length_mm() < 1e-9 {
            return Err(PlanError::NoTravel {
                counts: start.counts,
            });
        }
        Ok(Self {
            robot,
            req,
            start,
            course,
        })
    }
}

impl Timed for JointMove<'_> {
    type Planned = Plan;

    /// A joint move's one timing is its time-optimal trapezoid (the strategy lists no other).
    fn plan(&self, timing: Timing) -> Result<Plan, PlanError> {
        let Timing::TimeOptimal {
            rows_any_length, ..
        } = timing
        else {
            unreachable!("a joint move is planned time-optimally alone, not {timing:?}");
        };
        let motion = dynamics::joint_move_motion(
            self.robot,
            &self.start.values,
            &self.req.to,
            self.course.length_mm(),
            self.req.motion,
            rows_any_length,
        )?;
        let mut plan = plan_course(self.robot, &self.course, &self.start, motion)?;
        dynamics::within_limits(self.robot, &mut plan)?;
        Ok(plan)
    }

    fn duration_s(plan: &Plan) -> f64 {
        plan.duration_s()
    }

    fn fastest_s(&self, _: Timing) -> Option<f64> {
        None
    }
}
