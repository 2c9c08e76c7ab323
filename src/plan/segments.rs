//! From a joint's planned rows ("spans": a target and when its last pulse should land) to F174
//! segments: split at every direction reversal, split again where no frequency range covers a
//! stretch, give each segment the finest range that covers it, duty 1/4 where the FP-X needs it,
//! and choose every frequency under the frequency model so the row ends as near its planned time
//! as the model allows, carrying each row's time residual into the next.

use crate::robot::Joint;
use crate::table::{
    ControlCode, Direction, Duty, FrequencyModel, FrequencyRange, Row, Segment,
    quarter_duty_from_hz,
};

/// A planned row: reach `target` with the last pulse landing at `end_s`, having begun at `start_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Absolute target count.
    pub target: i64,
    /// Planned start of the row, s.
    pub start_s: f64,
    /// Planned landing time of its last pulse, s.
    pub end_s: f64,
}

/// A run of spans that will become one segment.
struct Piece {
    direction: Direction,
    range: FrequencyRange,
    spans: std::ops::Range<usize>,
}

/// Ranges that can play `freq_hz` (below every minimum only range 0 comes close: it runs at 1.5 Hz).
fn covering(freq_hz: f64) -> [bool; 3] {
    let low_only = freq_hz < FrequencyRange::Low.min_actual_hz();
    FrequencyRange::FINEST_FIRST
        .map(|r| r.covers(freq_hz) || (low_only && r == FrequencyRange::Low))
}

fn finest(ok: [bool; 3]) -> Option<FrequencyRange> {
    FrequencyRange::FINEST_FIRST
        .into_iter()
        .zip(ok)
        .find_map(|(r, ok)| ok.then_some(r))
}

/// Splits spans into pieces of one direction and one range, as few as a greedy pass makes.
fn pieces(start: i64, spans: &[Span]) -> Vec<Piece> {
    let mut out: Vec<Piece> = Vec::new();
    let mut prev = start;
    let mut ok = [true; 3];
    for (i, s) in spans.iter().enumerate() {
        let direction = Direction::of(s.target - prev).unwrap_or(Direction::Up);
        let freq = (s.target - prev).abs() as f64 / (s.end_s - s.start_s).max(f64::MIN_POSITIVE);
        let cover = covering(freq);
        let joined = [ok[0] && cover[0], ok[1] && cover[1], ok[2] && cover[2]];
        match out.last_mut() {
            Some(p) if p.direction == direction && joined.contains(&true) => {
                p.spans.end = i + 1;
                p.range = finest(joined).unwrap_or(p.range);
                ok = joined;
            }
            _ => {
                ok = cover;
                let range = finest(cover).unwrap_or(FrequencyRange::Low);
                out.push(Piece {
                    direction,
                    range,
                    spans: i..i + 1,
                });
            }
        }
        prev = s.target;
    }
    out
}

/// Builds the segments for `spans`, starting from count `start` at t = 0; `grid_s` is the
/// period whose points the rows' ends should stay near.
#[must_use]
pub fn build(
    joint: &Joint,
    model: FrequencyModel,
    start: i64,
    spans: &[Span],
    grid_s: f64,
) -> Vec<Segment> {
    let pieces = pieces(start, spans);
    let mut ranges = vec![FrequencyRange::Low; spans.len()];
    for p in &pieces {
        ranges[p.spans.clone()].fill(p.range);
    }
    let freqs = Frequencies {
        joint,
        model,
        start,
        spans,
        ranges: &ranges,
        grid_s,
    }
    .choose();
    pieces
        .into_iter()
        .map(|p| {
            let rows = p
                .spans
                .clone()
                .map(|i| Row {
                    freq_hz: freqs[i],
                    target: spans[i].target,
                })
                .collect();
            segment(joint, p.direction, p.range, rows)
        })
        .collect()
}

/// Chooses every row's frequency value: each row aims at its planned end from where the previous
/// row really ended (the residual is carried, never accumulated); the last two rows are chosen
/// together so the channel ends as near its planned end as the model allows.
struct Frequencies<'a> {
    joint: &'a Joint,
    model: FrequencyModel,
    start: i64,
    spans: &'a [Span],
    ranges: &'a [FrequencyRange],
    grid_s: f64,
}

impl Frequencies<'_> {
    fn pulses(&self, i: usize) -> u64 {
        let prev = if i == 0 {
            self.start
        } else {
            self.spans[i - 1].target
        };
        (self.spans[i].target - prev).unsigned_abs()
    }

    fn duration_s(&self, i: usize, freq_hz: u32) -> f64 {
        let actual = self
            .model
            .actual_hz(freq_hz, self.ranges[i])
            .min(f64::from(self.joint.max_freq_hz));
        self.pulses(i) as f64 / actual
    }

    /// The value that ends row `i` nearest its planned end, starting at `t_s`.
    fn aim(&self, i: usize, t_s: f64) -> u32 {
        let pulses = self.pulses(i);
        let wanted_s = self.spans[i].end_s - t_s;
        let wanted_hz = if wanted_s > 0.0 {
            pulses as f64 / wanted_s
        } else {
            f64::INFINITY
        };
        self.model
            .best_set_hz(wanted_hz, pulses, self.ranges[i], self.joint.max_freq_hz)
    }

    fn choose(&self) -> Vec<u32> {
        self.choose_searching::<true>()
    }

    /// [`Self::choose`], values leading where the one before led searched again unless
    /// `SKIP_REPEATS`.
    fn choose_searching<const SKIP_REPEATS: bool>(&self) -> Vec<u32> {
        let n = self.spans.len();
        // The tail's search moves a boundary by up to half its row, which a drive with limits
        // would take as a step: its rows each aim at their planned end.
        let tail = if self.joint.dynamics.is_set() {
            0
        } else {
            n.min(TAIL_ROWS)
        };
        let mut freqs = Vec::with_capacity(n);
        let mut t_s = 0.0;
        for i in 0..n - tail {
            let f = self.aim(i, t_s);
            t_s += self.duration_s(i, f);
            freqs.push(f);
        }
        if tail > 0 {
            let mut best = Tail {
                freqs: Vec::new(),
                end_err_s: f64::INFINITY,
            };
            self.search_tail::<SKIP_REPEATS>(
                n - tail,
                t_s,
                &mut Vec::with_capacity(tail),
                &mut best,
            );
            freqs.extend(best.freqs);
        }
        freqs
    }

    /// Tries values around each tail row's aim (the last row always aims), keeping every inner
    /// boundary within a grid period (and half its row) of its planned time, for the combination that ends nearest
    /// the planned end.
    fn search_tail<const SKIP_REPEATS: bool>(
        &self,
        i: usize,
        t_s: f64,
        chosen: &mut Vec<u32>,
        best: &mut Tail,
    ) {
        let last = self.spans.len() - 1;
        let aim = self.aim(i, t_s);
        if i == last {
            let err = (t_s + self.duration_s(i, aim) - self.spans[i].end_s).abs();
            if err < best.end_err_s {
                best.end_err_s = err;
                best.freqs.clone_from(chosen);
                best.freqs.push(aim);
            }
            return;
        }
        let range = self.ranges[i];
        let reach = (aim / 4).clamp(2, TAIL_REACH);
        let lo = aim.saturating_sub(reach).max(range.min_set_hz());
        let hi = (aim + reach)
            .min(range.max_set_hz())
            .min(self.joint.max_freq_hz);
        let span_s = self.spans[i].end_s - self.spans[i].start_s;
        let slack_s = (span_s / 2.0).min(self.grid_s);
        // Neighbouring values often select the same divisor: a value ending where the one
        // searched before it ended leads to the same rows after it, which cannot end strictly
        // nearer, so it is not searched again.
        let mut searched_end = f64::NAN;
        for f in lo..=hi {
            let end = t_s + self.duration_s(i, f);
            if f != aim && (end - self.spans[i].end_s).abs() > slack_s
                || SKIP_REPEATS && end.to_bits() == searched_end.to_bits()
            {
                continue;
            }
            searched_end = end;
            chosen.push(f);
            self.search_tail::<SKIP_REPEATS>(i + 1, end, chosen, best);
            chosen.pop();
        }
    }
}

/// Rows at the end of a channel whose frequencies are chosen together.
const TAIL_ROWS: usize = 3;
/// How far (in Hz values) a tail row's value may move from its aim.
const TAIL_REACH: u32 = 12;

struct Tail {
    freqs: Vec<u32>,
    end_err_s: f64,
}

/// A segment with its control code: the joint's output method, absolute targets, and duty 1/4
/// when any row reaches the channel's threshold.
#[must_use]
pub fn segment(
    joint: &Joint,
    direction: Direction,
    range: FrequencyRange,
    rows: Vec<Row>,
) -> Segment {
    let top = rows.iter().map(|r| r.freq_hz).max().unwrap_or(0);
    let duty = if top >= quarter_duty_from_hz(joint.channel) {
        Duty::Quarter
    } else {
        Duty::Half
    };
    Segment {
        control: ControlCode {
            output: joint.output,
            direction,
            absolute: true,
            range,
            duty,
        },
        rows,
    }
}

/// The range a single table must use for all of `freqs_hz`: the finest that covers them all,
/// else the one that covers most of them (finer on a tie).
#[must_use]
pub fn range_for_all(freqs_hz: &[f64]) -> FrequencyRange {
    let mut ok = [true; 3];
    let mut hits = [0usize; 3];
    for &f in freqs_hz {
        let c = covering(f);
        for r in 0..3 {
            ok[r] &= c[r];
            hits[r] += usize::from(c[r]);
        }
    }
    finest(ok).unwrap_or_else(|| {
        let best = (0..3).max_by_key(|&r| (hits[r], 3 - r)).unwrap_or(0);
        FrequencyRange::FINEST_FIRST[best]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::JointKind;
    use crate::table::OutputMethod;

    fn joint(channel: u8, max_freq_hz: u32) -> Joint {
        Joint {
            name: "d3".into(),
            channel,
            kind: JointKind::Prismatic,
            step: 0.01,
            offset: 0.0,
            min: -1e6,
            max: 1e6,
            max_freq_hz,
            output: OutputMethod::PulseSign,
            dynamics: crate::robot::Dynamics::default(),
        }
    }

    fn spans(targets: &[i64], period_s: f64) -> Vec<Span> {
        targets
            .iter()
            .enumerate()
            .map(|(i, &target)| Span {
                target,
                start_s: i as f64 * period_s,
                end_s: (i + 1) as f64 * period_s,
            })
            .collect()
    }

    #[test]
    fn the_tail_searched_once_per_end_is_the_tail_searched_in_full() {
        // Random decelerating tails in every range: values that select the same divisor are
        // searched once, and the choice is the same as searching every value.
        let mut next = crate::testing::uniform(0x9e37_79b9_7f4a_7c15u64);
        let mut repeats = 0;
        for case in 0..300 {
            let top_hz = [150.0, 2_000.0, 40_000.0][case % 3] * (0.5 + next());
            let period_s = [0.01, 0.05][case % 2];
            let (mut target, mut t_s) = (0i64, 0.0);
            let spans: Vec<Span> = (0..6)
                .map(|k| {
                    let hz = top_hz * (1.0 - f64::from(k) / 7.0) * (0.9 + 0.2 * next());
                    target += (hz * period_s).round().max(1.0) as i64;
                    let span = Span {
                        target,
                        start_s: t_s,
                        end_s: t_s + period_s,
                    };
                    t_s += period_s;
                    span
                })
                .collect();
            for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
                for range in FrequencyRange::FINEST_FIRST {
                    let ranges = vec![range; spans.len()];
                    let j = joint(0, 100_000);
                    let f = Frequencies {
                        joint: &j,
                        model,
                        start: 0,
                        spans: &spans,
                        ranges: &ranges,
                        grid_s: period_s,
                    };
                    let (once, full) =
                        (f.choose_searching::<true>(), f.choose_searching::<false>());
                    assert_eq!(once, full, "{model:?} {range:?} {spans:?}");
                    // How often two neighbouring values of a tail row select one divisor.
                    let t = spans.len() - TAIL_ROWS;
                    repeats += usize::from(
                        (f.duration_s(t, once[t]) - f.duration_s(t, once[t] + 1)).abs() == 0.0,
                    );
                }
            }
        }
        assert!(repeats > 50, "{repeats} tails with a repeated end");
    }

    #[test]
    fn reversing_joint_splits_into_two_segments() {
        let segs = build(
            &joint(0, 100_000),
            FrequencyModel::Ideal,
            0,
            &spans(&[50, 100, 60, 20], 0.05),
            0.05,
        );
        assert_eq!(segs.len(), 2);
        assert_eq!(segs[0].control.direction, Direction::Up);
        assert_eq!(segs[1].control.direction, Direction::Down);
        assert_eq!(segs[1].rows.last().unwrap().target, 20);
    }

    #[test]
    fn range_two_is_preferred_when_every_frequency_is_at_least_191_hz() {
        let segs = build(
            &joint(0, 100_000),
            FrequencyModel::Ideal,
            0,
            &spans(&[10, 30], 0.05),
            0.05,
        );
        assert_eq!(segs[0].control.range, FrequencyRange::High);
        let slow = build(
            &joint(0, 100_000),
            FrequencyModel::Ideal,
            0,
            &spans(&[5, 10], 0.05),
            0.05,
        );
        assert_eq!(slow[0].control.range, FrequencyRange::Mid);
    }

    #[test]
    fn stretch_no_range_covers_is_split() {
        // 20 Hz needs range 0; 15 kHz is beyond range 0: two segments in the same direction.
        let segs = build(
            &joint(0, 100_000),
            FrequencyModel::Ideal,
            0,
            &spans(&[1, 751], 0.05),
            0.05,
        );
        assert_eq!(segs.len(), 2);
        assert_eq!(segs[0].control.range, FrequencyRange::Low);
        assert_eq!(segs[1].control.range, FrequencyRange::High);
    }

    #[test]
    fn channel_two_at_fifteen_kilohertz_gets_quarter_duty() {
        let segs = build(
            &joint(2, 20_000),
            FrequencyModel::Ideal,
            0,
            &spans(&[750], 0.05),
            0.05,
        );
        assert_eq!(segs[0].rows[0].freq_hz, 15_000);
        assert_eq!(segs[0].control.duty, Duty::Quarter);
    }

    #[test]
    fn divider_residual_is_carried_so_rows_end_on_the_grid() {
        // 1234 pulses a period: every row alone ends early or late under the divider; with the
        // residual carried, the last row still ends within one pulse time of the grid.
        let targets: Vec<i64> = (1..=40).map(|i| i * 1_234).collect();
        let j = joint(0, 100_000);
        let segs = build(
            &j,
            FrequencyModel::FpxDivider,
            0,
            &spans(&targets, 0.05),
            0.05,
        );
        let range = segs[0].control.range;
        let total: f64 = segs[0]
            .rows
            .iter()
            .map(|r| 1_234.0 / FrequencyModel::FpxDivider.actual_hz(r.freq_hz, range))
            .sum();
        assert!(
            (total - 2.0).abs() < 1.0 / 24_680.0 * 2.0,
            "ends at {total}"
        );
    }
}
