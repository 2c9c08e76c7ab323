//! Limits checked before anything moves: every joint's position over the whole path and every
//! channel's pulse frequency.
//!
//! A table moves each joint monotonically from one sampled count to the next, so the counts it
//! passes through are bounded by the sampled counts: checking every sample checks every position
//! the PLC will command.

use crate::geometry::Profile;
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::Robot;

use super::error::PlanError;
use super::samples::Samples;

/// Checks a joint move's target values against every joint's position limits (half a pulse of
/// slack, as for samples); a value that is not a number is beyond any limit.
pub fn check_target(robot: &Robot, to: &Joints) -> Result<(), PlanError> {
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

/// The counts that put the tool at `pose` (the inverse kinematics' own choice of turn, the
/// wrist at `pose`'s angle), checked against every joint's limits: what a move to `pose` must
/// reach, wherever it starts.
///
/// # Errors
/// The pose out of the robot's reach, or a joint beyond its limits there.
pub fn check_pose(robot: &Robot, pose: &crate::geometry::Pose) -> Result<[i64; JOINTS], PlanError> {
    let q = robot.kinematics.ik(pose, None)?;
    check_target(robot, &q)?;
    Ok(robot.counts_of(&q))
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
    // A joint's value grows (or falls) with its count: its fewest and most counts are its
    // extremes. Only if one is beyond a limit is the first sample beyond it looked for.
    let (mut fewest, mut most) = ([i64::MAX; JOINTS], [i64::MIN; JOINTS]);
    for c in counts {
        for j in 0..JOINTS {
            fewest[j] = fewest[j].min(c[j]);
            most[j] = most[j].max(c[j]);
        }
    }
    let within = |j: usize, count: i64| {
        let joint = &robot.joints[j];
        let value = joint.value_of(count);
        // Half a pulse of slack: a limit set exactly on a taught point must not trip on rounding.
        let slack = joint.step.abs() / 2.0;
        !(value < joint.min - slack || value > joint.max + slack)
    };
    if counts.is_empty() || (0..JOINTS).all(|j| within(j, fewest[j]) && within(j, most[j])) {
        return Ok(());
    }
    for (i, c) in counts.iter().enumerate() {
        for (j, joint) in robot.joints.iter().enumerate() {
            if !within(j, c[j]) {
                let value = joint.value_of(c[j]);
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
/// (`continuous`, for a fine sampling where rounding would dominate). The first such period and
/// joint, in time order, where several tie.
///
/// The bounded-error method checks every millisecond sample, so the loads (three divisions per
/// joint and period) are worked only where one can be the largest: a load grows with its
/// joint's change over the period, and over the periods of the common length a change more
/// than a few rounding errors short of the joint's largest gives a load below that largest's.
#[must_use]
pub(super) fn peak(robot: &Robot, samples: &Samples, profile: &Profile, continuous: bool) -> Peak {
    let loads = Loads::new(robot, samples, profile, continuous);
    let intervals = loads.intervals;
    // The periods of the common length: all but the last.
    let common = intervals.saturating_sub(1);
    let (largest, first_largest) = loads.largest_changes(common);
    // Every joint's largest load over the common periods, and the last period's.
    let at_largest: Joints =
        std::array::from_fn(|j| first_largest[j].map_or(f64::NAN, |i| loads.at(i).1[j]));
    let last = intervals.checked_sub(1).map(|i| loads.at(i).1);
    let top = at_largest
        .iter()
        .chain(last.iter().flatten())
        .fold(0.0_f64, |m, &l| m.max(l));
    let mut best = Peak {
        joint: 0,
        freq_hz: 0.0,
        t_s: 0.0,
        load: 0.0,
    };
    if top <= 0.0 {
        return best;
    }
    if top < 1e-200 {
        // Loads this small lose the relative precision the argument needs.
        for i in 0..intervals {
            loads.see(i, &mut best);
        }
        return best;
    }
    // A joint whose largest load is the top (none is above it) is a candidate where its change
    // is within a few rounding errors of its largest: a change further short gives less.
    let candidate: [Option<f64>; JOINTS] =
        std::array::from_fn(|j| (at_largest[j] >= top).then(|| largest[j] * (1.0 - 1e-9)));
    for i in 0..common {
        let change = loads.change(i);
        if (0..JOINTS).any(|j| candidate[j].is_some_and(|from| change[j] >= from)) {
            loads.see(i, &mut best);
        }
    }
    if let Some(i) = intervals.checked_sub(1) {
        loads.see(i, &mut best);
    }
    best
}

/// Every period's load on every joint ([`peak`]).
struct Loads<'a> {
    samples: &'a Samples,
    continuous: bool,
    intervals: usize,
    period_s: f64,
    last_period_s: f64,
    step: Joints,
    max_hz: Joints,
}

impl<'a> Loads<'a> {
    /// Each joint's largest change over the first `common` periods, and the first period
    /// where it is (`None`: there are none).
    fn largest_changes(&self, common: usize) -> ([f64; JOINTS], [Option<usize>; JOINTS]) {
        let mut largest = [0.0_f64; JOINTS];
        let mut first_largest = [None::<usize>; JOINTS];
        for i in 0..common {
            let change = self.change(i);
            for j in 0..JOINTS {
                if change[j] > largest[j] || (first_largest[j].is_none() && change[j] >= largest[j])
                {
                    (largest[j], first_largest[j]) = (change[j], Some(i));
                }
            }
        }
        (largest, first_largest)
    }

    fn new(robot: &Robot, samples: &'a Samples, profile: &Profile, continuous: bool) -> Self {
        Self {
            samples,
            continuous,
            intervals: samples.counts.len().saturating_sub(1),
            period_s: profile.period_s,
            last_period_s: profile.last_period_s,
            step: std::array::from_fn(|j| robot.joints[j].step),
            max_hz: std::array::from_fn(|j| f64::from(robot.joints[j].max_freq_hz)),
        }
    }

    /// Every joint's change over period `i`, by which its load grows.
    fn change(&self, i: usize) -> Joints {
        if self.continuous {
            let (a, b) = (&self.samples.values[i], &self.samples.values[i + 1]);
            std::array::from_fn(|j| (b[j] - a[j]).abs())
        } else {
            let (a, b) = (&self.samples.counts[i], &self.samples.counts[i + 1]);
            std::array::from_fn(|j| (b[j] - a[j]).abs() as f64)
        }
    }

    /// Every joint's frequency and load over period `i`.
    fn at(&self, i: usize) -> (Joints, Joints) {
        let pulses: Joints = if self.continuous {
            let (a, b) = (&self.samples.values[i], &self.samples.values[i + 1]);
            std::array::from_fn(|j| ((b[j] - a[j]) / self.step[j]).abs())
        } else {
            let (a, b) = (&self.samples.counts[i], &self.samples.counts[i + 1]);
            std::array::from_fn(|j| (b[j] - a[j]).abs() as f64)
        };
        let period = if i + 1 == self.intervals {
            self.last_period_s
        } else {
            self.period_s
        };
        let freq_hz: Joints = std::array::from_fn(|j| pulses[j] / period);
        (
            freq_hz,
            std::array::from_fn(|j| freq_hz[j] / self.max_hz[j]),
        )
    }

    /// Period `i` seen: a joint's load above `best`'s is the new best.
    fn see(&self, i: usize, best: &mut Peak) {
        let (freq_hz, load) = self.at(i);
        for j in 0..JOINTS {
            if load[j] > best.load {
                *best = Peak {
                    joint: j,
                    freq_hz: freq_hz[j],
                    t_s: (i + 1) as f64 * self.period_s,
                    load: load[j],
                };
            }
        }
    }
}

/// [`peak`] worked at every period.
#[cfg(test)]
fn peak_at_every_period(
    robot: &Robot,
    samples: &Samples,
    profile: &Profile,
    continuous: bool,
) -> Peak {
    let loads = Loads::new(robot, samples, profile, continuous);
    let mut best = Peak {
        joint: 0,
        freq_hz: 0.0,
        t_s: 0.0,
        load: 0.0,
    };
    for i in 0..loads.intervals {
        loads.see(i, &mut best);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::seed_robot;
    use proptest::prelude::*;

    fn profile(period_s: f64, last_period_s: f64) -> Profile {
        Profile {
            length_mm: 1.0,
            speed_mm_s: 1.0,
            accel_mm_s2: 1.0,
            accel_s: 0.0,
            period_s,
            ramp_periods: 0,
            cruise_end_periods: 0,
            last_period_s,
            jerk_s: 0.0,
        }
    }

    /// Samples whose every joint moves by one of a few sizes a period (so that the largest
    /// ties often, exactly or to a rounding), from a few counts apart.
    fn samples() -> impl Strategy<Value = Samples> {
        let step = prop::sample::select(vec![0.0, 1e-9, 0.5, 3.0, 3.0 + 1e-13, 7.25, -3.0, -7.25]);
        (
            prop::collection::vec(prop::array::uniform4(step), 0..40),
            prop::array::uniform4(-1e3..1e3_f64),
        )
            .prop_map(|(moves, start)| {
                let robot = seed_robot();
                let mut values = vec![start];
                for m in moves {
                    let q = *values.last().expect("a start");
                    values.push(std::array::from_fn(|j| {
                        q[j] + m[j] * robot.joints[j].step.abs()
                    }));
                }
                let counts = values.iter().map(|q| robot.counts_of(q)).collect();
                Samples { counts, values }
            })
    }

    proptest! {
        #[test]
        fn the_peak_read_at_its_candidates_is_the_peak_read_at_every_period(
            samples in samples(),
            continuous: bool,
            last in prop::sample::select(vec![0.001, 0.0015, 0.0005]),
        ) {
            let robot = seed_robot();
            let profile = profile(0.001, last);
            prop_assert_eq!(
                peak(&robot, &samples, &profile, continuous),
                peak_at_every_period(&robot, &samples, &profile, continuous)
            );
        }
    }

    /// Every joint's counts stepping by `steps` a sample from its limit's middle.
    fn counts_from_the_middle(steps: [i64; JOINTS], n: i64) -> Vec<[i64; JOINTS]> {
        let robot = seed_robot();
        let middle: [i64; JOINTS] = std::array::from_fn(|j| {
            robot.joints[j].count_of(f64::midpoint(robot.joints[j].min, robot.joints[j].max))
        });
        (0..n)
            .map(|i| std::array::from_fn(|j| middle[j] + i * steps[j]))
            .collect()
    }

    #[test]
    fn the_first_sample_beyond_a_limit_is_named_and_none_within_them() {
        let robot = seed_robot();
        let period_s = 0.01;
        assert!(
            check_positions(
                &robot,
                &counts_from_the_middle([1, -1, 1, -1], 50),
                period_s
            )
            .is_ok()
        );
        for j in 0..JOINTS {
            let joint = &robot.joints[j];
            // Towards either limit, fast enough to pass it within the samples.
            for way in [1_i64, -1] {
                let mut steps = [0; JOINTS];
                steps[j] = way * 1_000_000;
                let counts = counts_from_the_middle(steps, 2_000);
                let first = counts
                    .iter()
                    .position(|c| {
                        let v = joint.value_of(c[j]);
                        let slack = joint.step.abs() / 2.0;
                        v < joint.min - slack || v > joint.max + slack
                    })
                    .expect("a sample beyond the limit");
                match check_positions(&robot, &counts, period_s) {
                    Err(PlanError::OutOfLimit {
                        joint: name, t_s, ..
                    }) => {
                        assert_eq!(name, joint.name);
                        assert!(
                            (t_s - first as f64 * period_s).abs() < 1e-12,
                            "{t_s} {first}"
                        );
                    }
                    other => panic!("{j} {way}: {other:?}"),
                }
            }
        }
    }

    #[test]
    fn the_first_of_equal_peaks_is_the_peak() {
        let robot = seed_robot();
        let step = robot.joints[2].step;
        let values: Vec<Joints> = [0.0, 3.0, 6.0, 7.0, 10.0]
            .iter()
            .map(|&c| [0.0, 0.0, c * step, 0.0])
            .collect();
        let counts = values.iter().map(|q| robot.counts_of(q)).collect();
        let samples = Samples { counts, values };
        let peak = peak(&robot, &samples, &profile(0.001, 0.001), false);
        assert_eq!((peak.joint, peak.t_s), (2, 0.001));
        assert!((peak.freq_hz - 3000.0).abs() < 1e-9, "{peak:?}");
    }
}
