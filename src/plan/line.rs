//! PURE. A line move as the strategy plans it ([`Timed`]): resolved from its request (where it
//! starts, checked for reach and length), and planned under one timing at a time: as asked,
//! along the line; time-optimal or averaged, as a path of that one line at its pace
//! ([`dynamics::timed_line`]); slowed as a whole, checked on its samples before any rows.

use crate::geometry::{Line, Pace, Path, Profile, ProfileRequest};
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::{Motion, Ramp, Robot};

use super::course::Course;
use super::dynamics::{self, Averaging, Shares};
use super::error::PlanError;
use super::part::{plan_course, plan_course_checked};
use super::planned::Plan;
use super::sampled::{grid_s, probe};
use super::start::Start;
use super::strategy::{Timed, Timing};
use super::{MoveRequest, Origin};

/// A line move to plan: the line, where it starts and the motion asked.
pub(super) struct LineMove<'a> {
    robot: &'a Robot,
    line: Line,
    start: Start,
    motion: Motion,
}

impl<'a> LineMove<'a> {
    /// The line `req` asks `robot` for.
    ///
    /// # Errors
    /// A target that is not a number, a start or a line out of reach, a line of no length.
    pub(super) fn new(robot: &'a Robot, req: &MoveRequest) -> Result<Self, PlanError> {
        let (line, values, counts) = resolve_line(robot, req)?;
        robot.kinematics.check_line(&line)?;
        if line.length_mm() < 1e-6 {
            let p = line.from.position_mm;
            return Err(PlanError::ZeroLength {
                x: p.x,
                y: p.y,
                z: p.z,
            });
        }
        Ok(Self {
            robot,
            line,
            start: Start { values, counts },
            motion: req.motion,
        })
    }

    /// Plans `course` (the line, or the line at a pace) with `motion`: one start.
    fn plan_course(&self, course: &Course, motion: Motion) -> Result<Plan, PlanError> {
        plan_course(self.robot, course, &self.start, motion)
    }

    /// The S-curve asked slowed as a whole to share `k` of its accelerations, refused on its
    /// samples where a joint's planned acceleration is clearly over its `max_accel`, and on the
    /// planned motion where it is over it or over its `max_jerk`.
    fn slowed(&self, k: f64) -> Result<Plan, PlanError> {
        let robot = self.robot;
        let check = |accels: &[f64; JOINTS], factor: f64| {
            dynamics::clearly_over_max_accel(robot, accels, factor * k.sqrt() * 100.0)
        };
        let course = Course::Line(self.line);
        let slowed = dynamics::slowed(&self.motion, k);
        let mut plan = plan_course_checked(robot, &course, &self.start, slowed, Some(&check))?;
        plan.speed_factor *= k.sqrt();
        dynamics::within_limits(robot, &mut plan)?;
        Ok(plan)
    }

    /// How long the S-curve asked takes along the line unslowed, on the grid its method samples
    /// it on (`None` for a trapezoid, or if it cannot be profiled).
    fn unslowed_s_curve_s(&self) -> Option<f64> {
        let Ramp::SCurve { jerk_mm_s3 } = self.motion.ramp else {
            return None;
        };
        let request = ProfileRequest {
            length_mm: self.line.length_mm(),
            speed_mm_s: self.motion.speed_mm_s,
            accel_s: self.motion.accel_s,
            period_s: grid_s(&self.motion),
        };
        Profile::s_curve(request, jerk_mm_s3)
            .ok()
            .map(|p| p.duration_s())
    }
}

impl Timed for LineMove<'_> {
    type Planned = Plan;

    fn plan(&self, timing: Timing) -> Result<Plan, PlanError> {
        match timing {
            Timing::AsAsked => self.plan_course(&Course::Line(self.line), self.motion),
            Timing::TimeOptimal {
                rows_any_length,
                accel_share,
            } => {
                let shares = Shares {
                    accel: accel_share,
                    ..Shares::WHOLE
                };
                let (path, pace) = self.timed(&self.motion, shares, rows_any_length)?;
                self.plan_course(&Course::Path { path, pace }, self.motion)
            }
            Timing::Averaged { rows_any_length } => {
                dynamics::averaged(self, &self.motion, f64::INFINITY, rows_any_length)
            }
            Timing::Slowed { k } => self.slowed(k),
        }
    }

    fn duration_s(plan: &Plan) -> f64 {
        plan.duration_s()
    }

    fn fastest_s(&self, timing: Timing) -> Option<f64> {
        match timing {
            Timing::Slowed { .. } => self.unslowed_s_curve_s(),
            Timing::AsAsked | Timing::TimeOptimal { .. } | Timing::Averaged { .. } => None,
        }
    }
}

impl Averaging for LineMove<'_> {
    type Planned = Plan;

    fn timed(
        &self,
        motion: &Motion,
        shares: Shares,
        rows_any_length: bool,
    ) -> Result<(Path, Pace), PlanError> {
        dynamics::timed_line(
            self.robot,
            &self.line,
            &self.start.values,
            motion,
            rows_any_length,
            shares,
        )
    }

    fn plan(&self, path: &Path, pace: Pace, motion: Motion) -> Result<Plan, PlanError> {
        let course = Course::Path {
            path: path.clone(),
            pace,
        };
        let mut plan = self.plan_course(&course, motion)?;
        plan.motion.ramp = self.motion.ramp;
        dynamics::within_limits(self.robot, &mut plan)?;
        Ok(plan)
    }

    fn probe(&self, path: &Path, pace: Pace, motion: Motion) -> Option<(f64, f64)> {
        let course = Course::Path {
            path: path.clone(),
            pace,
        };
        probe(self.robot, &course, &self.start, motion)
    }
}

/// A line request's line, and the joint values and counts it starts from.
type Resolved = (Line, Joints, [i64; JOINTS]);

/// Where `req` starts, as a line to its target: from a pose (its joint values and their
/// nearest counts), or from counts (their values and pose).
pub(super) fn resolve_line(robot: &Robot, req: &MoveRequest) -> Result<Resolved, PlanError> {
    crate::kinematics::check_finite(&req.to)?;
    match req.from {
        Origin::Pose(from) => {
            let q = robot.kinematics.ik(&from, None)?;
            Ok((Line { from, to: req.to }, q, robot.counts_of(&q)))
        }
        Origin::Counts(counts) => {
            let q = robot.values_of(&counts);
            Ok((
                Line {
                    from: robot.kinematics.fk(&q),
                    to: req.to,
                },
                q,
                counts,
            ))
        }
    }
}
