//! Limits checked before anything moves: every joint's position over the whole path and every
//! channel's pulse frequency.
//!
//! A table moves each joint monotonically from one sampled count to the next, so the counts it
//! passes through are bounded by the sampled counts: checking every sample checks every position
//! the PLC will command.

use crate::geometry::Profile;
use crate::kinematics::{JOINTS, Joints};
use crate::robot::Robot;

use super::{PlanError, Samples};

/// Checks a joint move's target values against every joint's position limits (half a pulse of
/// slack, as for samples); a value that is not a number is beyond any limit.
pub(super) fn check_target(robot: &Robot, to: &Joints) -> Result<(), PlanError> {
    for (joint, &value) in robot.joints.iter().zip(to) {
        let slack = joint.step.abs() / 2.0;
        if !(joint.min - slack..=joint.max + slack).contains(&value) {
            return Err(PlanError::TargetOutOfLimit {
                joint: joint.name.clone(),
                value: joint.user(value),
                min: shown(joint.user(joint.min)),
                max: shown(joint.user(joint.max)),
                unit: joint.kind.user_unit(),
            });
        }
    }
    Ok(())
}

/// A limit as the user wrote it: the config's degrees went to radians and back, which leaves
/// `-701.0000000000001`; a micro-unit is far below any limit's meaning.
fn shown(limit: f64) -> f64 {
    (limit * 1e6).round() / 1e6
}

/// Checks every joint's count at every sample against its position limits.
pub(super) fn check_positions(
    robot: &Robot,
    counts: &[[i64; JOINTS]],
    period_s: f64,
) -> Result<(), PlanError> {
    for (i, c) in counts.iter().enumerate() {
        for (j, joint) in robot.joints.iter().enumerate() {
            let value = joint.value_of(c[j]);
            // Half a pulse of slack: a limit set exactly on a taught point must not trip on rounding.
            let slack = joint.step.abs() / 2.0;
            if value < joint.min - slack || value > joint.max + slack {
                return Err(PlanError::OutOfLimit {
                    joint: joint.name.clone(),
                    value: joint.user(value),
                    min: shown(joint.user(joint.min)),
                    max: shown(joint.user(joint.max)),
                    unit: joint.kind.user_unit(),
                    t_s: i as f64 * period_s,
                });
            }
        }
    }
    Ok(())
}

/// The fastest period of the fastest joint, relative to its channel's maximum.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Peak {
    /// Joint index.
    pub joint: usize,
    /// Its frequency, Hz.
    pub freq_hz: f64,
    /// When that period ends, s.
    pub t_s: f64,
    /// `freq_hz / max_freq_hz`: above 1 means too fast.
    pub load: f64,
}

/// The period in which a channel comes nearest (or furthest beyond) its maximum frequency: from
/// the rounded counts (a constant-period row plays exactly those), or from the exact joint values
/// (`continuous`, for a fine sampling where rounding would dominate).
#[must_use]
pub(super) fn peak(robot: &Robot, samples: &Samples, profile: &Profile, continuous: bool) -> Peak {
    let period_s = profile.period_s;
    let last = samples.counts.len().saturating_sub(2);
    let mut best = Peak {
        joint: 0,
        freq_hz: 0.0,
        t_s: 0.0,
        load: 0.0,
    };
    // The joints side by side: the bounded-error method checks every millisecond sample.
    let step: Joints = std::array::from_fn(|j| robot.joints[j].step);
    let max_hz: Joints = std::array::from_fn(|j| f64::from(robot.joints[j].max_freq_hz));
    for i in 0..samples.counts.len().saturating_sub(1) {
        let pulses: Joints = if continuous {
            let (a, b) = (&samples.values[i], &samples.values[i + 1]);
            std::array::from_fn(|j| ((b[j] - a[j]) / step[j]).abs())
        } else {
            let (a, b) = (&samples.counts[i], &samples.counts[i + 1]);
            std::array::from_fn(|j| (b[j] - a[j]).abs() as f64)
        };
        let period = if i == last {
            profile.last_period_s
        } else {
            period_s
        };
        let freq_hz: Joints = std::array::from_fn(|j| pulses[j] / period);
        let load: Joints = std::array::from_fn(|j| freq_hz[j] / max_hz[j]);
        for j in 0..JOINTS {
            if load[j] > best.load {
                best = Peak {
                    joint: j,
                    freq_hz: freq_hz[j],
                    t_s: (i + 1) as f64 * period_s,
                    load: load[j],
                };
            }
        }
    }
    best
}

/// The error for a peak beyond its channel's maximum.
#[must_use]
pub(super) fn over_speed(robot: &Robot, peak: &Peak) -> PlanError {
    let joint = &robot.joints[peak.joint];
    PlanError::OverSpeed {
        joint: joint.name.clone(),
        freq_hz: peak.freq_hz,
        t_s: peak.t_s,
        channel: joint.channel,
        max_hz: joint.max_freq_hz,
    }
}
