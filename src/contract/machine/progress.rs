//! PURE. How far along its plan a running start is, by the counts the PLC reports rather than by
//! the clock: the plan's counts over the start's own time (a [`ProgressCurve`]) and the planned
//! instant whose counts come nearest those read.
//!
//! Nearest is measured with every channel's counts divided by its scale: its travel over the
//! start (every step counted, so a joint that goes out and back counts both ways), and no less
//! than [`MIN_SCALE`] pulses. A channel then weighs by the share of its own way it is off,
//! whatever its pulses per mm or per degree: a joint with many pulses does not drown the others,
//! and one pulse of a joint that barely moves (whose pulses may land a little before or after
//! the plan's samples) weighs at most `1 / MIN_SCALE` of a way. A channel that does not move adds
//! the same distance everywhere and decides nothing.
//!
//! Between its points the plan is taken as straight, in time and in counts, and the curve keeps
//! only the points it needs for that to hold within [`THIN`] of every channel's scale (and a
//! pulse): a plan sampled every millisecond over seconds keeps a few dozen points (a ramp bends
//! its counts, a cruise hardly does), so following it costs little per status read.

use std::fmt;
use std::time::Duration;

use crate::contract::CHANNELS;

/// A channel's counts are divided by at least this many pulses.
pub const MIN_SCALE: i64 = 1_000;
/// The curve is straight between its points within this share of each channel's scale.
pub const THIN: f64 = 1.0 / 10_000.0;

/// A start's planned counts over its own time (0 when the PLC begins it, to its planned end).
#[derive(Clone, PartialEq, Eq)]
pub struct ProgressCurve {
    /// When the plan is at each point, strictly increasing from 0.
    at: Vec<Duration>,
    /// Counts per channel at each point.
    counts: Vec<[i32; CHANNELS]>,
    /// Per channel, the counts that make one unit of distance.
    scale: [i64; CHANNELS],
}

impl fmt::Debug for ProgressCurve {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ProgressCurve")
            .field("points", &self.at.len())
            .field("end", &self.end())
            .field("scale", &self.scale)
            .finish_non_exhaustive()
    }
}

impl ProgressCurve {
    /// The curve through `points` (each a time in the start and every channel's count then, in
    /// time order), thinned; a later point at the same time replaces the earlier. `None` for
    /// fewer than two distinct times or times out of order.
    #[must_use]
    pub fn new(points: &[(Duration, [i32; CHANNELS])]) -> Option<Self> {
        let mut at: Vec<Duration> = Vec::with_capacity(points.len());
        let mut counts: Vec<[i32; CHANNELS]> = Vec::with_capacity(points.len());
        for &(t, c) in points {
            match at.last() {
                Some(&last) if t < last => return None,
                Some(&last) if t == last => {
                    if let Some(last) = counts.last_mut() {
                        *last = c;
                    }
                }
                _ => {
                    at.push(t);
                    counts.push(c);
                }
            }
        }
        if at.len() < 2 {
            return None;
        }
        let mut travel = [0_i64; CHANNELS];
        for w in counts.windows(2) {
            for (c, t) in travel.iter_mut().enumerate() {
                *t += (i64::from(w[1][c]) - i64::from(w[0][c])).abs();
            }
        }
        let scale = travel.map(|t| t.max(MIN_SCALE));
        let keep = thin(&at, &counts, &scale);
        Some(Self {
            at: keep.iter().map(|&i| at[i]).collect(),
            counts: keep.iter().map(|&i| counts[i]).collect(),
            scale,
        })
    }

    /// Points kept.
    #[must_use]
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether it has no points (never: a curve has at least two).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// Its planned end.
    #[must_use]
    pub fn end(&self) -> Duration {
        self.at.last().copied().unwrap_or_default()
    }

    /// Per channel, the counts that make one unit of distance (its travel, at least
    /// [`MIN_SCALE`]).
    #[must_use]
    pub fn scale(&self) -> [i64; CHANNELS] {
        self.scale
    }

    /// The planned counts at `at` (straight between points; the end's past it).
    #[must_use]
    pub fn counts_at(&self, at: Duration) -> [f64; CHANNELS] {
        let k = self.segment(at);
        let (t0, t1) = (self.at[k], self.at[k + 1]);
        let u =
            at.clamp(t0, t1).saturating_sub(t0).as_secs_f64() / t1.saturating_sub(t0).as_secs_f64();
        std::array::from_fn(|c| {
            let (a, b) = (
                f64::from(self.counts[k][c]),
                f64::from(self.counts[k + 1][c]),
            );
            a + u * (b - a)
        })
    }

    /// The instant between `from` and `until` (both within the curve) at which the planned
    /// counts come nearest `counts`, the earliest of equally near ones; `from` when `until` is
    /// not past it. Searching only forward from where the start was last found, its progress
    /// never goes back, even where a joint reverses and its counts pass again where they were.
    #[must_use]
    pub fn locate(&self, counts: &[i32; CHANNELS], from: Duration, until: Duration) -> Duration {
        let from = from.min(self.end());
        let until = until.clamp(from, self.end());
        let mut best = (f64::INFINITY, from);
        for k in self.segment(from)..self.at.len() - 1 {
            let (t0, t1) = (self.at[k], self.at[k + 1]);
            if t0 > until {
                break;
            }
            let span = t1.saturating_sub(t0).as_secs_f64();
            let lo = from.max(t0).saturating_sub(t0).as_secs_f64() / span;
            let hi = until.min(t1).saturating_sub(t0).as_secs_f64() / span;
            let (p0, p1) = (&self.counts[k], &self.counts[k + 1]);
            let norm = |c: usize, a: i32, b: i32| {
                (i64::from(a) - i64::from(b)) as f64 / self.scale[c] as f64
            };
            let r: [f64; CHANNELS] = std::array::from_fn(|c| norm(c, counts[c], p0[c]));
            let d: [f64; CHANNELS] = std::array::from_fn(|c| norm(c, p1[c], p0[c]));
            let rd: f64 = (0..CHANNELS).map(|c| r[c] * d[c]).sum();
            let dd: f64 = (0..CHANNELS).map(|c| d[c] * d[c]).sum();
            let u = if dd > 0.0 {
                (rd / dd).clamp(lo, hi)
            } else {
                lo
            };
            let distance: f64 = (0..CHANNELS).map(|c| (r[c] - u * d[c]).powi(2)).sum();
            if distance < best.0 {
                let at = t0 + Duration::from_secs_f64(u * span);
                best = (distance, at.clamp(from, until));
            }
        }
        best.1
    }

    /// The share of the curve's time `at` is, 0 to 1.
    #[must_use]
    pub fn share(&self, at: Duration) -> f64 {
        (at.as_secs_f64() / self.end().as_secs_f64()).clamp(0.0, 1.0)
    }

    /// The segment (from point k to k + 1) `at` lies on: the last that begins at or before it.
    fn segment(&self, at: Duration) -> usize {
        self.at
            .partition_point(|&t| t <= at)
            .saturating_sub(1)
            .min(self.at.len() - 2)
    }
}

/// The points of `counts` (at times `at`) to keep: from each kept point, the farthest later one
/// the straight line to which passes within the tolerance of every point between, channel by
/// channel (each channel's slope from the kept point must lie within the bounds every point in
/// between sets it: one pass).
fn thin(at: &[Duration], counts: &[[i32; CHANNELS]], scale: &[i64; CHANNELS]) -> Vec<usize> {
    let tolerance: [f64; CHANNELS] = std::array::from_fn(|c| (scale[c] as f64 * THIN).max(1.0));
    let full = [(f64::NEG_INFINITY, f64::INFINITY); CHANNELS];
    let mut keep = vec![0];
    let mut anchor = 0;
    let mut slopes = full;
    for i in 1..at.len() {
        let slope = |a: usize, c: usize, off: f64| {
            (f64::from(counts[i][c]) + off - f64::from(counts[a][c]))
                / at[i].saturating_sub(at[a]).as_secs_f64()
        };
        let fits = (0..CHANNELS).all(|c| {
            let s = slope(anchor, c, 0.0);
            slopes[c].0 <= s && s <= slopes[c].1
        });
        if !fits {
            anchor = i - 1;
            keep.push(anchor);
            slopes = full;
        }
        for (c, (lo, hi)) in slopes.iter_mut().enumerate() {
            *lo = lo.max(slope(anchor, c, -tolerance[c]));
            *hi = hi.min(slope(anchor, c, tolerance[c]));
        }
    }
    if keep.last() != Some(&(at.len() - 1)) {
        keep.push(at.len() - 1);
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(ms: u64) -> Duration {
        Duration::from_millis(ms)
    }

    /// A straight curve over 1 s from `from` to `to`.
    fn straight(from: [i32; CHANNELS], to: [i32; CHANNELS]) -> ProgressCurve {
        ProgressCurve::new(&[(ms(0), from), (ms(1_000), to)]).unwrap()
    }

    #[test]
    fn a_curve_needs_two_times_in_order_and_a_later_point_at_the_same_time_replaces_the_earlier() {
        assert!(ProgressCurve::new(&[]).is_none());
        assert!(ProgressCurve::new(&[(ms(0), [0; CHANNELS])]).is_none());
        assert!(ProgressCurve::new(&[(ms(5), [0; CHANNELS]), (ms(1), [1; CHANNELS])]).is_none());
        let c = ProgressCurve::new(&[
            (ms(0), [0; CHANNELS]),
            (ms(100), [10; CHANNELS]),
            (ms(100), [1_000; CHANNELS]),
        ])
        .unwrap();
        assert_eq!((c.len(), c.end()), (2, ms(100)));
        assert!(
            c.counts_at(ms(100))
                .iter()
                .all(|&n| (n - 1_000.0).abs() < 1e-9)
        );
    }

    #[test]
    fn a_channels_scale_is_its_travel_both_ways_and_at_least_the_minimum() {
        let c = ProgressCurve::new(&[
            (ms(0), [0, 0, 7, 0]),
            (ms(500), [1_000, -3_000, 7, 40]),
            (ms(1_000), [0, -6_000, 7, 20]),
        ])
        .unwrap();
        assert_eq!(c.scale(), [2_000, 6_000, MIN_SCALE, MIN_SCALE]);
    }

    #[test]
    fn the_nearest_instant_is_found_between_points() {
        let c = straight([0, 0, 0, 0], [1_000, -2_000, 0, 0]);
        let at = c.locate(&[250, -500, 0, 0], ms(0), ms(1_000));
        assert!(at.abs_diff(ms(250)) < Duration::from_micros(10), "{at:?}");
        assert!((c.share(at) - 0.25).abs() < 1e-4);
        // Off the plan: the nearest instant all the same.
        let at = c.locate(&[260, -480, 3, 0], ms(0), ms(1_000));
        assert!(at.abs_diff(ms(250)) < ms(5), "{at:?}");
    }

    #[test]
    fn the_search_goes_only_forward_from_where_it_was_and_no_further_than_it_is_told() {
        let c = straight([0; CHANNELS], [1_000, 1_000, 0, 0]);
        let at_300 = [300, 300, 0, 0];
        assert_eq!(c.locate(&at_300, ms(500), ms(1_000)), ms(500));
        assert_eq!(c.locate(&[900, 900, 0, 0], ms(0), ms(600)), ms(600));
        assert_eq!(c.locate(&at_300, ms(700), ms(200)), ms(700));
        assert_eq!(c.locate(&at_300, ms(5_000), ms(9_000)), ms(1_000));
    }

    #[test]
    fn equally_near_instants_resolve_to_the_earliest() {
        // Standing still at the start for 200 ms, then on.
        let c = ProgressCurve::new(&[
            (ms(0), [0; CHANNELS]),
            (ms(200), [0; CHANNELS]),
            (ms(1_000), [800, 800, 0, 0]),
        ])
        .unwrap();
        assert_eq!(c.locate(&[0; CHANNELS], ms(0), ms(1_000)), ms(0));
        assert_eq!(c.locate(&[0; CHANNELS], ms(50), ms(1_000)), ms(50));
    }

    #[test]
    fn a_joint_with_many_pulses_does_not_drown_the_others() {
        // Channel 0 travels 100 times the pulses of channels 1 and 2. It reads 40 % of its way,
        // they 50 % of theirs: each weighs by its share of its own way, so the instant is the
        // one nearest all three (7/15), not the big joint's 0.4.
        let c = straight([0; CHANNELS], [100_000, 1_000, 1_000, 0]);
        let at = c.locate(&[40_000, 500, 500, 0], ms(0), ms(1_000));
        assert!((c.share(at) - 7.0 / 15.0).abs() < 1e-3, "{at:?}");
    }

    #[test]
    fn a_finely_sampled_plan_keeps_few_points_and_stays_within_its_tolerance() {
        // 2 s sampled every millisecond: 0.4 s ramps and a cruise, channel 0 over 200000 pulses,
        // channel 1 over 3000 backwards, channel 3 out 40 pulses and back.
        let s = |t: f64| {
            let (ramp, total) = (0.4, 2.0);
            let v = 1.0 / (total - ramp);
            if t < ramp {
                0.5 * v / ramp * t * t
            } else if t < total - ramp {
                0.5 * v * ramp + v * (t - ramp)
            } else {
                1.0 - 0.5 * v / ramp * (total - t).powi(2)
            }
        };
        let points: Vec<(Duration, [i32; CHANNELS])> = (0..=2_000_u32)
            .map(|i| {
                let u = s(f64::from(i) / 1_000.0);
                let counts = [
                    (200_000.0 * u).round() as i32,
                    (-3_000.0 * u).round() as i32,
                    5,
                    (40.0 * (1.0 - (2.0 * u - 1.0).abs())).round() as i32,
                ];
                (ms(i.into()), counts)
            })
            .collect();
        let c = ProgressCurve::new(&points).unwrap();
        assert!(c.len() < 60, "{} points", c.len());
        let scale = c.scale();
        for (at, counts) in &points {
            let planned = c.counts_at(*at);
            for ch in 0..CHANNELS {
                let tolerance = (scale[ch] as f64 * THIN).max(1.0);
                let off = (planned[ch] - f64::from(counts[ch])).abs();
                assert!(off <= tolerance + 1e-9, "channel {ch} at {at:?}: {off}");
            }
        }
        // Every sample is found near where it was planned: on the cruise within a millisecond,
        // where the robot crawls off and into its ends within the grain of its counts (there a
        // pulse of channel 1 takes several ms).
        for (at, counts) in &points {
            let off = c.locate(counts, ms(0), c.end()).abs_diff(*at);
            let cruise = (ms(400)..=ms(1_600)).contains(at);
            let limit = if cruise { ms(1) } else { ms(12) };
            assert!(off <= limit, "{at:?}: {off:?}");
        }
    }
}
