//! PURE. A joint's jerk as its planned motion asks for it, over [`JERK_SPAN_S`] (`τ`): its
//! position's third difference at steps of `τ`, `(q(t+3τ) - 3q(t+2τ) + 3q(t+τ) - q(t)) / τ³`
//! (its speed over `τ`, that speed's change over `τ`, and that change's over `τ`), at every
//! millisecond `t` of the start. The joints are sampled every millisecond along the plan's
//! course (by inverse kinematics on a line or path, in proportion on a joint move), whatever the
//! method's own samples: constant-period's points are a period apart, far too coarse for a jerk.
//!
//! On a motion whose jerk holds for `3τ` the figure is that jerk exactly (the third difference
//! of a cubic): an S-curve's jerk phases read as themselves. Where the planned acceleration
//! steps at once (a line into an arc at speed, the pace's ramp before a tight arc) it reads as
//! that step over `τ`, and where a joint's acceleration grows without bound (a SCARA leaving its
//! stretched-out singularity) it stays finite: a figure of the motion, not of the sampling, and
//! what a drive's position loop, which smooths faster changes, is asked to follow.

use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::{JERK_SPAN_S, Robot};

use crate::plan::error::PlanError;
use crate::plan::planned::Plan;

/// The step between the joints' samples, s.
const STEP_S: f64 = 0.001;

/// Every joint's largest planned jerk in `plan`, in user units/s^3 (deg or mm).
pub(in crate::plan) fn peak_jerks(robot: &Robot, plan: &Plan) -> Result<[f64; JOINTS], PlanError> {
    let duration_s = plan.duration_s();
    let n = (duration_s / STEP_S).ceil().max(1.0) as usize;
    let step_s = duration_s / n as f64;
    let span = (JERK_SPAN_S / step_s).round().max(1.0) as usize;
    let mut near = plan.samples.values[0];
    let mut q = Vec::with_capacity(n + 1);
    for i in 0..=n {
        near = joints_at(robot, plan, i as f64 * step_s, &near)?;
        q.push(near);
    }
    let tau_s = span as f64 * step_s;
    let mut peak = [0.0_f64; JOINTS];
    for i in 0..(q.len().saturating_sub(3 * span)) {
        let [q0, q1, q2, q3] = [i, i + span, i + 2 * span, i + 3 * span].map(|k| q[k]);
        for j in 0..JOINTS {
            let third = q3[j] - 3.0 * q2[j] + 3.0 * q1[j] - q0[j];
            peak[j] = peak[j].max(third.abs() / tau_s.powi(3));
        }
    }
    Ok(std::array::from_fn(|j| robot.joints[j].user(peak[j]).abs()))
}

/// The joints where `plan` puts them at `t_s` of its start, near `near`.
fn joints_at(robot: &Robot, plan: &Plan, t_s: f64, near: &Joints) -> Result<Joints, PlanError> {
    let profile_s = plan.window.from_s + t_s;
    if let Some(path) = &plan.joint_path {
        let s_mm = plan.profile.distance_mm(profile_s);
        return Ok(path.joints_at(s_mm / plan.profile.length_mm));
    }
    let pose = match &plan.path {
        Some(path) => path.at(plan.course_mm(profile_s)),
        None => plan.line.at(plan.profile.distance_mm(profile_s)),
    };
    Ok(robot.kinematics.ik(&pose, Some(near))?)
}
