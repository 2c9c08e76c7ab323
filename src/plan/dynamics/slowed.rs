//! PURE. An S-curve under drive limits: the move or path section is planned as it would be
//! without them (the S-curve's seven phases at the asked speed, acceleration and jerk), and
//! where a joint's drive could not follow its rows the whole motion is slowed in time until it
//! can. Slowing time by `1 / sqrt(k)` takes every speed (the tool's and each joint's) to
//! `sqrt(k)` of itself, every acceleration to `k` (a joint's `q' s'' + q'' s'^2` alike) and
//! every jerk to `k^1.5`: the shape of the motion stays, and what each drive is asked for
//! shrinks with `k`. The planner's strategy takes the largest `k` found (to within 5 %) whose
//! tables the drives follow (`crate::plan::strategy`). It is not time-optimal: the time-optimal
//! timing steps its acceleration on and off, which a jerk limit forbids.

use crate::kinematics::JOINTS;
use crate::plan::error::PlanError;
use crate::plan::planned::Plan;
use crate::robot::{Motion, Ramp, Robot};

use super::jerk::peak_jerks;

/// How far a joint's planned acceleration (measured on the samples) may pass its `max_accel`.
const ACCEL_SLACK: f64 = 0.02;

/// Whether every joint's planned motion in `plan` (at `speed_factor` of the speed asked for)
/// keeps within its `max_accel` (and [`ACCEL_SLACK`]) and its `max_jerk`; if not, the refusal
/// naming the first joint over one. The jerks are measured ([`peak_jerks`]) when a joint has a
/// `max_jerk`, and kept in the plan's figures.
///
/// The rows alone do not show an acceleration: a row's frequency is known only to a pulse over
/// its length, so short rows (bounded-error's, a few ms) leave room for steps well over the
/// limit. A time-optimal timing keeps the planned motion within it by construction; a slowed
/// S-curve is checked.
pub(in crate::plan) fn within_limits(robot: &Robot, plan: &mut Plan) -> Result<(), PlanError> {
    let speed_pct = plan.speed_factor * 100.0;
    for (joint, d) in robot.joints.iter().zip(&plan.drive) {
        if let Some(a) = joint.dynamics.max_accel {
            let max_accel = joint.user(a).abs();
            if d.peak_accel > max_accel * (1.0 + ACCEL_SLACK) {
                return Err(PlanError::SCurveOverMaxAccel {
                    joint: joint.name.clone(),
                    accel: d.peak_accel,
                    max_accel,
                    unit: joint.kind.user_unit(),
                    speed_pct,
                });
            }
        }
    }
    if robot.joints.iter().all(|j| j.dynamics.max_jerk.is_none()) {
        return Ok(());
    }
    let jerks = peak_jerks(robot, plan)?;
    for ((joint, d), jerk) in robot.joints.iter().zip(&mut plan.drive).zip(jerks) {
        d.peak_jerk = Some(jerk);
        if let Some(j) = joint.dynamics.max_jerk {
            let max_jerk = joint.user(j).abs();
            if jerk > max_jerk {
                return Err(PlanError::OverMaxJerk {
                    joint: joint.name.clone(),
                    jerk,
                    max_jerk,
                    unit: joint.kind.user_unit(),
                    speed_pct,
                });
            }
        }
    }
    Ok(())
}

/// How far over its `max_accel` a joint's planned acceleration must be for
/// [`clearly_over_max_accel`] to refuse the motion before its rows are made.
const CLEARLY_OVER: f64 = 1.1;

/// The refusal [`within_limits`] would give, found on the samples before any rows are made,
/// where a joint's planned acceleration is clearly over its `max_accel` ([`CLEARLY_OVER`], well
/// past [`ACCEL_SLACK`]: the samples are the whole course's, a start's may differ at its ends).
/// A bounded-error plan whose rows a drive refuses runs its narrowed tries first: a motion
/// refused anyway is spared them. `speed_pct` is the speed the motion is at.
pub(in crate::plan) fn clearly_over_max_accel(
    robot: &Robot,
    accels: &[f64; JOINTS],
    speed_pct: f64,
) -> Result<(), PlanError> {
    for (joint, &accel) in robot.joints.iter().zip(accels) {
        if let Some(a) = joint.dynamics.max_accel {
            let max_accel = joint.user(a).abs();
            if accel > max_accel * CLEARLY_OVER {
                return Err(PlanError::SCurveOverMaxAccel {
                    joint: joint.name.clone(),
                    accel,
                    max_accel,
                    unit: joint.kind.user_unit(),
                    speed_pct,
                });
            }
        }
    }
    Ok(())
}

/// Refuses a trapezoid for a robot with a joint's `max_jerk`: only an S-curve keeps it.
pub(in crate::plan) fn jerk_needs_s_curve(robot: &Robot, ramp: Ramp) -> Result<(), PlanError> {
    if matches!(ramp, Ramp::SCurve { .. }) {
        return Ok(());
    }
    match robot.joints.iter().find(|j| j.dynamics.max_jerk.is_some()) {
        Some(joint) => Err(PlanError::JerkNeedsSCurve {
            joint: joint.name.clone(),
            max_jerk: joint
                .user(joint.dynamics.max_jerk.unwrap_or_default())
                .abs(),
            unit: joint.kind.user_unit(),
        }),
        None => Ok(()),
    }
}

/// `asked` slowed in time to share `k` of its accelerations.
#[must_use]
pub(in crate::plan) fn slowed(asked: &Motion, k: f64) -> Motion {
    let ramp = match asked.ramp {
        Ramp::SCurve { jerk_mm_s3 } => Ramp::SCurve {
            jerk_mm_s3: jerk_mm_s3 * k.powf(1.5),
        },
        Ramp::Trapezoid => Ramp::Trapezoid,
    };
    Motion {
        speed_mm_s: asked.speed_mm_s * k.sqrt(),
        accel_s: asked.accel_s / k.sqrt(),
        ramp,
        ..*asked
    }
}
