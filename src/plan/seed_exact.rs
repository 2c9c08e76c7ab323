//! The paper as printed, for comparison only: one table per moving channel, one row per period,
//! frequency = pulses / dT, and the "+1" rule (a target equal to the previous one gets 1 added).
//! Its tables are planned and simulated but never valid for an FP-X; [`problems`] says why.

use crate::robot::Joint;
use crate::table::{ChannelTable, Direction, Row};

use super::segments::{range_for_all, segment};

/// The seed's table for one joint, or an empty one when the joint never moves.
#[must_use]
pub(super) fn table(joint: &Joint, counts: &[i64], period_s: f64) -> ChannelTable {
    let start = counts[0];
    let mut empty = ChannelTable {
        channel: joint.channel,
        start,
        segments: Vec::new(),
    };
    if counts.iter().all(|&c| c == start) {
        return empty;
    }
    let mut prev = start;
    let mut rows = Vec::with_capacity(counts.len());
    for &c in &counts[1..] {
        let target = if c == prev { prev + 1 } else { c };
        let pulses = (target - prev).abs() as f64;
        rows.push(Row {
            freq_hz: (pulses / period_s).round().max(1.0) as u32,
            target,
        });
        prev = target;
    }
    let freqs: Vec<f64> = rows.iter().map(|r| f64::from(r.freq_hz)).collect();
    let first_move = rows
        .iter()
        .map(|r| r.target)
        .find(|&t| t != start)
        .unwrap_or(start);
    let direction = Direction::of(first_move - start).unwrap_or(Direction::Up);
    empty
        .segments
        .push(segment(joint, direction, range_for_all(&freqs), rows));
    empty
}

/// Why seed-exact tables must not be sent to an FP-X, beyond what table validation finds.
#[must_use]
pub(super) fn problems() -> Vec<String> {
    vec![
        "seed-exact tables reproduce the paper for comparison only and are never sent to a PLC"
            .into(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::JointKind;
    use crate::table::{ChannelLimits, OutputMethod, TableProblem, problems};

    fn joint() -> Joint {
        Joint {
            name: "theta1".into(),
            channel: 0,
            kind: JointKind::Revolute,
            step: 1e-4,
            offset: 0.0,
            min: -1.0,
            max: 1.0,
            max_freq_hz: 100_000,
            output: OutputMethod::CwCcw,
            dynamics: crate::robot::Dynamics::default(),
        }
    }

    #[test]
    fn plus_one_rule_makes_a_reversal_inside_one_table() {
        // Counts 0 0 0 1: the +1 rule writes 1, then the real count 0 goes back against it.
        let t = table(&joint(), &[0, 0, 0, 1], 0.05);
        let targets: Vec<i64> = t.segments[0].rows.iter().map(|r| r.target).collect();
        assert_eq!(targets, vec![1, 0, 1]);
        let found = problems(
            &t,
            ChannelLimits {
                max_freq_hz: 100_000,
                area_words: 2_000,
            },
        );
        assert!(
            found
                .iter()
                .any(|p| matches!(p, TableProblem::AgainstDirection { .. })),
            "{found:?}"
        );
    }

    #[test]
    fn frequency_is_pulses_over_the_period() {
        let t = table(&joint(), &[0, 10, 30], 0.05);
        let freqs: Vec<u32> = t.segments[0].rows.iter().map(|r| r.freq_hz).collect();
        assert_eq!(freqs, vec![200, 400]);
    }
}
