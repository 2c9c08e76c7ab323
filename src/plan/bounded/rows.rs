//! Rows from pulse windows: from where the channel really is, the longest run of pulses that
//! one realisable frequency lands inside all their windows (pulse i of a row lands at
//! `start + i / f`), then the next row from where that one really ends. Each stretch of one
//! direction becomes segments in the finest frequency range that plays it without breaking a
//! window, split where no range can.

use std::cell::RefCell;

use super::pulses::Run;
use super::windows::{Cursor, Pulses, Side};
use crate::plan::segments::segment;
use crate::robot::Joint;
use crate::table::{FrequencyModel, FrequencyRange, MAX_SEGMENTS, Row, Segment};

/// What a channel can play: its joint, the model, and the segments left.
pub(super) struct Channel<'a> {
    /// The joint.
    pub joint: &'a Joint,
    /// The frequency model.
    pub model: FrequencyModel,
    /// Pulses a run may leave off their windows (played as near as its range allows) to stay
    /// one segment where no range plays it all; the execution model judges the result.
    pub off_window: usize,
    /// Buffers for a row's scan ([`Channel::longest`]), kept between rows.
    pub bounds: &'a RefCell<Bounds>,
}

/// Pulses a row's windows are first scanned over ([`Channel::longest`]).
const SCAN_FIRST: usize = 4096;

/// The pieces a row's scan has read on each side ([`Bound`]), kept between rows and plans.
#[derive(Default)]
pub(super) struct Bounds {
    early: Vec<Scanned>,
    late: Vec<Scanned>,
}

impl Bounds {
    /// The most pieces held.
    pub(super) fn capacity(&self) -> usize {
        self.early.capacity().max(self.late.capacity())
    }
}

/// A piece a scan has read: its first pulse, the bound over the pulses before it, the first
/// pulse's own bound, and, along a piece whose edge bends against the bound, the pulse where
/// its own bound peaks and that bound.
#[derive(Clone, Copy)]
struct Scanned {
    first: usize,
    before: f64,
    own: f64,
    peak: Option<(usize, f64)>,
}

/// One side of a row's period bounds from its start, read piece by piece: pulse `i` (from 0)
/// lands at `t_s + (i + 1) * period`, so the period is at least every earlier pulse's earliest
/// landing over its number (the [`Side::Early`] bound, the largest of them) and at most every
/// latest over its number (the smallest). Along a piece a pulse's own bound is monotone
/// ([`super::windows`]), so the bound through a pulse of it is read from the piece's first
/// pulse and that one; along a piece whose edge bends against the bound it rises to one peak
/// and falls, so past the peak it is the peak's.
struct Bound<'b> {
    side: Side,
    cursor: Cursor,
    pieces: &'b mut Vec<Scanned>,
    /// The bound before any pulse (the range's period limit).
    outer: f64,
    /// The current piece's last pulse (`None` before the first), and the bound through it.
    last: Option<usize>,
    through_last: f64,
}

/// Bounds `a` and `b` on `side` together: the tighter.
fn combine(side: Side, a: f64, b: f64) -> f64 {
    match side {
        Side::Early => a.max(b),
        Side::Late => a.min(b),
    }
}

impl Scanned {
    /// The bound through pulse `k` of this piece, `read` working out `k`'s own bound where
    /// the piece's first pulse and peak do not give it.
    fn through(&self, side: Side, k: usize, read: impl FnOnce() -> f64) -> f64 {
        let own = match self.peak {
            Some((p, at_peak)) if k >= p => at_peak,
            _ if k == self.first => self.own,
            _ => read(),
        };
        combine(side, combine(side, self.before, self.own), own)
    }
}

/// Whether bound `a` is tighter than `b` on `side`.
fn tighter(side: Side, a: f64, b: f64) -> bool {
    match side {
        Side::Early => a > b,
        Side::Late => a < b,
    }
}

impl Bound<'_> {
    fn combine(&self, a: f64, b: f64) -> f64 {
        combine(self.side, a, b)
    }

    fn own(t_s: f64, k: usize, edge_s: f64) -> f64 {
        (edge_s - t_s) / (k + 1) as f64
    }

    /// The bound through pulse `k` of the current piece.
    fn through<P: Pulses>(&mut self, pulses: P, t_s: f64, k: usize) -> f64 {
        if self.last == Some(k) {
            return self.through_last;
        }
        let piece = *self.pieces.last().expect("a piece entered");
        let side = self.side;
        piece.through(side, k, || {
            Self::own(t_s, k, pulses.edge(side, k, &mut self.cursor))
        })
    }

    /// Where the own bound peaks along pulses `k` (bound `at_k`) to `last` (`at_last`) of a
    /// piece whose edge bends against it, and the bound there: it rises to the peak and falls
    /// after, so the peak is searched for; the rounding of the pulses' edges may leave a
    /// neighbour of the one found a last bit tighter, so a few either side are read too.
    fn peak<P: Pulses>(
        &mut self,
        pulses: P,
        t_s: f64,
        (k, at_k): (usize, f64),
        (last, at_last): (usize, f64),
    ) -> (usize, f64) {
        let side = self.side;
        let mut own = |i: usize| Self::own(t_s, i, pulses.edge(side, i, &mut self.cursor));
        // Falling from the first, or rising to the last, it peaks there.
        let found = if last <= k + 1 || !tighter(side, own(k + 1), at_k) {
            k
        } else if tighter(side, at_last, own(last - 1)) {
            last
        } else {
            // It rises into `lo` and does not rise past `hi`.
            let (mut lo, mut hi) = (k + 1, last - 1);
            while lo < hi {
                let mid = usize::midpoint(lo, hi);
                if tighter(side, own(mid + 1), own(mid)) {
                    lo = mid + 1;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        let mut best = (k, at_k);
        for i in found.saturating_sub(2).max(k)..=(found + 2).min(last) {
            let at = if i == k {
                at_k
            } else if i == last {
                at_last
            } else {
                own(i)
            };
            if tighter(side, at, best.1) {
                best = (i, at);
            }
        }
        best
    }

    /// Enters the piece pulse `k` is in, the pulses before it scanned.
    fn enter<P: Pulses>(&mut self, pulses: P, t_s: f64, k: usize) {
        let before = match self.last {
            Some(_) => self.through_last,
            None => self.outer,
        };
        let (last, at_k, at_last, against) = pulses.piece(self.side, k, &mut self.cursor);
        let own = Self::own(t_s, k, at_k);
        let own_last = Self::own(t_s, last, at_last);
        let peak = against.then(|| self.peak(pulses, t_s, (k, own), (last, own_last)));
        self.pieces.push(Scanned {
            first: k,
            before,
            own,
            peak,
        });
        let through = peak.map_or(own_last, |(_, at_peak)| self.combine(at_peak, own_last));
        self.through_last = self.combine(self.combine(before, own), through);
        self.last = Some(last);
    }

    /// The bound through pulse `k` of any piece scanned.
    fn through_scanned<P: Pulses>(&self, pulses: P, t_s: f64, k: usize) -> f64 {
        let piece = self.pieces[self.pieces.partition_point(|p| p.first <= k) - 1];
        piece.through(self.side, k, || {
            Self::own(t_s, k, pulses.edge(self.side, k, &mut { Cursor::NEW }))
        })
    }
}

/// A row's period bounds from its start, as far as they have been scanned.
struct Scan<'b, P> {
    pulses: P,
    t_s: f64,
    early: Bound<'b>,
    late: Bound<'b>,
    /// Pulses that keep the bounds open.
    open_to: usize,
    /// False once the bounds cross or the pulses run out.
    open: bool,
}

impl<'b, P: Pulses> Scan<'b, P> {
    fn new(pulses: P, t_s: f64, (lo, hi): (f64, f64), bounds: &'b mut Bounds) -> Self {
        bounds.early.clear();
        bounds.late.clear();
        let bound = |side, pieces, outer| Bound {
            side,
            cursor: Cursor::NEW,
            pieces,
            outer,
            last: None,
            through_last: outer,
        };
        Self {
            pulses,
            t_s,
            early: bound(Side::Early, &mut bounds.early, lo),
            late: bound(Side::Late, &mut bounds.late, hi),
            open_to: 0,
            open: true,
        }
    }

    /// Whether the bounds through pulse `k` (in both current pieces) cross.
    fn crosses(&mut self, k: usize) -> bool {
        let (pulses, t_s) = (self.pulses, self.t_s);
        self.early.through(pulses, t_s, k) > self.late.through(pulses, t_s, k)
    }

    /// Scans to `reach` pulses, or as far as they stay open; returns how many are open.
    fn extend(&mut self, reach: usize) -> usize {
        let (pulses, t_s) = (self.pulses, self.t_s);
        while self.open && self.open_to < reach {
            let k = self.open_to;
            if k == pulses.len() {
                self.open = false;
                break;
            }
            for bound in [&mut self.early, &mut self.late] {
                if bound.last.is_none_or(|last| last < k) {
                    bound.enter(pulses, t_s, k);
                }
            }
            let last = |b: &Bound| b.last.expect("a piece entered");
            let x = last(&self.early).min(last(&self.late)).min(reach - 1);
            // Each side's bound through its piece's last pulse is known, and bounds only close
            // as pulses are added: where those are open, so is every pulse before.
            let clear = self.early.through_last <= self.late.through_last;
            if !clear && self.crosses(x) {
                // The first pulse they cross at: the bounds only close as pulses are added.
                let (mut open, mut closed) = (k, x);
                while open < closed {
                    let mid = usize::midpoint(open, closed);
                    if self.crosses(mid) {
                        closed = mid;
                    } else {
                        open = mid + 1;
                    }
                }
                self.open_to = closed;
                self.open = false;
                break;
            }
            self.open_to = x + 1;
        }
        self.open_to
    }

    /// The bounds over the first `m` pulses (scanned and open).
    fn over(&self, m: usize) -> (f64, f64) {
        debug_assert!(m >= 1 && m <= self.open_to);
        (
            self.early.through_scanned(self.pulses, self.t_s, m - 1),
            self.late.through_scanned(self.pulses, self.t_s, m - 1),
        )
    }
}

/// Rows for a stretch of pulses in one range.
struct Attempt {
    rows: Vec<Row>,
    end_s: f64,
    /// Pulses before the first one that could not land in its window.
    clean_pulses: usize,
    broken: usize,
    /// How far outside its window the worst broken pulse lands, s (0 with none broken).
    worst_miss_s: f64,
}

impl Channel<'_> {
    fn fastest_set(&self, range: FrequencyRange) -> u32 {
        range
            .max_set_hz()
            .min(self.joint.max_freq_hz)
            .max(range.min_set_hz())
    }

    /// A set value whose real frequency gives a pulse period in `[lo_s, hi_s]`, and that
    /// frequency.
    fn realise(
        &self,
        range: FrequencyRange,
        lo_s: f64,
        hi_s: f64,
        want_s: f64,
    ) -> Option<(u32, f64)> {
        let set = self
            .model
            .set_for_period(range, lo_s, hi_s, want_s, self.joint.max_freq_hz)?;
        Some((
            set,
            self.model
                .actual_hz(set, range)
                .min(f64::from(self.joint.max_freq_hz)),
        ))
    }

    /// The longest row from `t_s` over `pulses`, or `None` when not even one pulse fits.
    ///
    /// The window only widens as the row gets shorter, so whether a value fits is monotonic in
    /// the row's length: the longest that fits is searched for. The windows are scanned up to
    /// where they run out, or, on a stretch where they stay open for long (a cruise, where the
    /// row ends at the frequency step nearest its speed, not where its windows close), only as
    /// far as a doubling search needs: scanning every row to the cruise's end made the rows'
    /// time grow with the square of its length.
    fn longest<P: Pulses>(
        &self,
        range: FrequencyRange,
        pulses: P,
        t_s: f64,
        bounds: &mut Bounds,
    ) -> Option<(usize, u32, f64)> {
        self.longest_scanning(range, pulses, t_s, bounds, SCAN_FIRST)
            .0
    }

    /// [`Self::longest`], the windows first scanned over `first_reach` pulses; also how many
    /// pulses were scanned.
    fn longest_scanning<P: Pulses>(
        &self,
        range: FrequencyRange,
        pulses: P,
        t_s: f64,
        bounds: &mut Bounds,
        first_reach: usize,
    ) -> (Option<(usize, u32, f64)>, usize) {
        let fastest = self
            .model
            .actual_hz(self.fastest_set(range), range)
            .min(f64::from(self.joint.max_freq_hz));
        let outer = (1.0 / fastest, 1.0 / range.min_actual_hz());
        let mut scan = Scan::new(pulses, t_s, outer, bounds);
        let fit = |scan: &Scan<P>, m: usize| {
            let (lo, hi) = scan.over(m);
            let want = (pulses.ideal_s(m - 1) - t_s) / m as f64;
            self.realise(range, lo, hi, want)
                .map(|(set, f)| (m, set, f))
        };
        let (mut good, mut best, mut reach) = (0usize, None, first_reach.max(1));
        let mut bad = loop {
            let n = scan.extend(reach);
            if n <= good {
                // The windows closed right after the longest that fits.
                return (best, scan.open_to);
            }
            match fit(&scan, n) {
                Some(found) if !scan.open => return (Some(found), scan.open_to),
                Some(found) => {
                    (good, best) = (n, Some(found));
                    reach *= 2;
                }
                None => break n,
            }
        };
        while bad - good > 1 {
            let mid = usize::midpoint(good, bad);
            match fit(&scan, mid) {
                Some(found) => {
                    good = mid;
                    best = Some(found);
                }
                None => bad = mid,
            }
        }
        (best, scan.open_to)
    }

    /// Rows for `pulses` in `range` from `t_s`. A pulse no frequency can place is played at the
    /// nearest value the range allows and counted as broken; once more than `give_up_after` are
    /// broken the attempt ends there (its caller does not take it).
    fn attempt<P: Pulses>(
        &self,
        range: FrequencyRange,
        pulses: P,
        mut t_s: f64,
        give_up_after: usize,
    ) -> Attempt {
        let mut a = Attempt {
            rows: Vec::new(),
            end_s: t_s,
            clean_pulses: pulses.len(),
            broken: 0,
            worst_miss_s: 0.0,
        };
        let mut k = 0;
        let mut bounds = self.bounds.borrow_mut();
        while k < pulses.len() {
            let (m, set, f) =
                if let Some(row) = self.longest(range, pulses.after(k), t_s, &mut bounds) {
                    row
                } else {
                    if a.broken == 0 {
                        a.clean_pulses = k;
                    }
                    a.broken += 1;
                    if a.broken > give_up_after {
                        break;
                    }
                    let pulse = pulses.pulse(k);
                    let nearest = self.nearest(range, (pulse.ideal_s - t_s).max(1e-6));
                    let lands_s = t_s + 1.0 / nearest.2;
                    let miss_s = (pulse.lo_s - lands_s).max(lands_s - pulse.hi_s);
                    a.worst_miss_s = a.worst_miss_s.max(miss_s);
                    nearest
                };
            t_s += m as f64 / f;
            k += m;
            a.rows.push(Row {
                freq_hz: set,
                target: pulses.count(k - 1),
            });
        }
        a.end_s = t_s;
        a
    }

    /// A one-pulse row as near a wanted pulse period as the range allows.
    fn nearest(&self, range: FrequencyRange, want_s: f64) -> (usize, u32, f64) {
        let set = self
            .model
            .best_set_hz(1.0 / want_s, 1, range, self.joint.max_freq_hz);
        (
            1,
            set,
            self.model
                .actual_hz(set, range)
                .min(f64::from(self.joint.max_freq_hz)),
        )
    }

    /// The segment for the next stretch of `pulses`: the finest range that plays them all
    /// within their windows; else, with segments to spare, the range that plays the longest
    /// clean stretch (the rest goes to the next segment); else the range that breaks fewest
    /// (of those that tie, the one whose worst pulse lands nearest its window).
    fn next_segment<P: Pulses>(
        &self,
        pulses: P,
        t_s: f64,
        last_chance: bool,
    ) -> (FrequencyRange, Attempt) {
        let mut prefixes = Vec::with_capacity(3);
        for range in FrequencyRange::FINEST_FIRST {
            let a = self.attempt(range, pulses, t_s, 0);
            if a.broken == 0 {
                return (range, a);
            }
            prefixes.push((range, a));
        }
        // One segment with a few pulses off their windows rather than two: the PLC starts a
        // channel's next segment at its next scan (ACCURACY.md), which holds the rest of the
        // joint's run back by up to a scan's worth of pulses at whatever speed it reaches.
        // (With none allowed off, the loop above already found that no range plays them all.)
        if self.off_window > 0 {
            for range in FrequencyRange::FINEST_FIRST {
                let a = self.attempt(range, pulses, t_s, self.off_window);
                if a.broken <= self.off_window {
                    return (range, a);
                }
            }
        }
        let (range, best) = prefixes
            .into_iter()
            .max_by_key(|(_, a)| a.clean_pulses)
            .expect("three ranges");
        if !last_chance && best.clean_pulses > 0 {
            return (range, best);
        }
        // The range that breaks fewest; of those that tie, the one whose worst pulse lands
        // nearest its window (a joint slower than a range's lowest frequency runs ahead in
        // every range, least in the slowest), then the finest. A later range is given up once
        // it breaks more than the best so far.
        let [finest, rest @ ..] = FrequencyRange::FINEST_FIRST;
        let mut best = (finest, self.attempt(finest, pulses, t_s, usize::MAX));
        for range in rest {
            if best.1.broken == 0 {
                break;
            }
            let a = self.attempt(range, pulses, t_s, best.1.broken);
            if a.broken < best.1.broken
                || (a.broken == best.1.broken && a.worst_miss_s < best.1.worst_miss_s)
            {
                best = (range, a);
            }
        }
        best
    }

    /// Segments for one run of pulses starting at `t_s` from `count`; returns them and the
    /// time the last pulse lands. `segments_left` bounds the splitting.
    pub(super) fn run<P: Pulses>(
        &self,
        run: &Run<P>,
        mut t_s: f64,
        mut count: i64,
        segments_left: usize,
    ) -> (Vec<Segment>, f64) {
        let mut out = Vec::new();
        let mut pulses = run.pulses;
        while pulses.len() > 0 {
            let last_chance = out.len() + 1 >= segments_left.min(MAX_SEGMENTS);
            let (range, a) = self.next_segment(pulses, t_s, last_chance);
            let played = a
                .rows
                .last()
                .map_or(0, |r| (r.target - count).unsigned_abs() as usize);
            t_s = a.end_s;
            count = a.rows.last().map_or(count, |r| r.target);
            out.push(segment(self.joint, run.direction, range, a.rows));
            pulses = pulses.after(played.max(1).min(pulses.len()));
        }
        (out, t_s)
    }
}

#[cfg(test)]
mod tests {
    use super::super::pulses::{Counts, Pulse, runs};
    use super::*;
    use crate::robot::seed_robot;

    /// A joint speeding up to `hz` pulses a second in 0.2 s, then cruising for `cruise_s`
    /// with a slight waver (so that no one frequency plays the cruise), sampled every ms.
    fn cruise(hz: f64, cruise_s: f64) -> Vec<Pulse> {
        let n = ((0.2 + cruise_s) * 1e3) as usize;
        let u = (0..=n)
            .map(|i| {
                let t = i as f64 * 1e-3;
                if t < 0.2 {
                    hz * t * t / 0.4
                } else {
                    hz * (t - 0.1) + 3.0 * (t * 2.0).sin()
                }
            })
            .collect();
        let mut pulses = Vec::new();
        let starts = Counts::new(u).track(1e-3).pulses_into(0, 2.0, &mut pulses);
        assert_eq!(starts.len(), 1, "one run");
        pulses
    }

    /// [`Channel::next_segment`] with every attempt played to the end of the pulses wherever
    /// pulses broke (as it was before attempts were given up early), the fewest broken chosen,
    /// ties to the one that misses least.
    fn next_segment_in_full(
        channel: &Channel<'_>,
        pulses: &[Pulse],
        t_s: f64,
        last_chance: bool,
    ) -> (FrequencyRange, Vec<Row>, usize) {
        let full = |r| channel.attempt(r, pulses, t_s, usize::MAX);
        let played = |r, a: Attempt| (r, a.rows, a.broken);
        let mut prefixes = Vec::new();
        for range in FrequencyRange::FINEST_FIRST {
            let a = channel.attempt(range, pulses, t_s, 0);
            if a.broken == 0 {
                return played(range, a);
            }
            prefixes.push((range, a));
        }
        if channel.off_window > 0 {
            for range in FrequencyRange::FINEST_FIRST {
                let a = full(range);
                if a.broken <= channel.off_window {
                    return played(range, a);
                }
            }
        }
        let (range, best) = prefixes
            .into_iter()
            .max_by_key(|(_, a)| a.clean_pulses)
            .unwrap();
        if !last_chance && best.clean_pulses > 0 {
            return played(range, best);
        }
        let (range, a) = FrequencyRange::FINEST_FIRST
            .map(|r| (r, full(r)))
            .into_iter()
            .min_by(|(_, a), (_, b)| {
                a.broken
                    .cmp(&b.broken)
                    .then(a.worst_miss_s.total_cmp(&b.worst_miss_s))
            })
            .unwrap();
        played(range, a)
    }

    /// A cruise whose pulses waver by more than any one frequency plays, from many starts:
    /// the segment chosen with attempts given up once they cannot be taken is the segment
    /// chosen with every attempt played in full.
    #[test]
    fn attempts_given_up_early_choose_the_segment_attempts_played_in_full_choose() {
        let joint = seed_robot().joints[1].clone();
        let mut pulses = cruise(4_000.0, 0.5);
        // Every seventh pulse's window pulled early: no frequency lands in all of them.
        for p in pulses.iter_mut().skip(40).step_by(7) {
            p.lo_s -= 2e-3;
            p.hi_s = p.lo_s + 2e-5;
        }
        let mut broke = 0;
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            for off_window in [0, 2, 30] {
                let spare = RefCell::new(Bounds::default());
                let channel = Channel {
                    joint: &joint,
                    model,
                    off_window,
                    bounds: &spare,
                };
                for k in (0..pulses.len()).step_by(211) {
                    let t_s = pulses[k].ideal_s - 1e-4;
                    for last_chance in [false, true] {
                        let (range, a) = channel.next_segment(&pulses[k..], t_s, last_chance);
                        let full = next_segment_in_full(&channel, &pulses[k..], t_s, last_chance);
                        assert_eq!((range, a.rows, a.broken), full, "{model:?} {k}");
                        broke += usize::from(full.2 > 0);
                    }
                }
            }
        }
        assert!(broke > 20, "{broke} choices with pulses off their windows");
    }

    /// A joint creeping slower than any range plays (a pulse every 0.8 s, its window 0.2 s
    /// either side; range 0 goes no slower than 1.5 Hz): every range breaks every pulse, each
    /// landing early, and the range chosen is the one that runs ahead least, the slowest. (The
    /// finest was chosen before: range 2 played the pulses at 191 Hz, all within 0.1 s.)
    #[test]
    fn a_run_no_range_plays_goes_to_the_range_that_runs_ahead_least() {
        let joint = seed_robot().joints[1].clone();
        let pulses: Vec<Pulse> = (1..=20_i32)
            .map(|i| {
                let ideal_s = 3.0 + 0.8 * f64::from(i);
                Pulse {
                    count: i64::from(i),
                    ideal_s,
                    lo_s: ideal_s - 0.2,
                    hi_s: ideal_s + 0.2,
                }
            })
            .collect();
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let spare = RefCell::new(Bounds::default());
            let channel = Channel {
                joint: &joint,
                model,
                off_window: 0,
                bounds: &spare,
            };
            for last_chance in [false, true] {
                let (range, a) = channel.next_segment(pulses.as_slice(), 0.0, last_chance);
                assert_eq!(range, FrequencyRange::Low, "{model:?}");
                assert_eq!((a.rows.len(), a.broken), (20, 20), "{model:?}");
                // A pulse every 1/1.5 s at the slowest (1.49 Hz under the divider): the last lands at
                // about 13.4 s, 2.6 s early.
                assert!((a.end_s - 20.0 / 1.5).abs() < 0.1, "{model:?} {}", a.end_s);
                let full = next_segment_in_full(&channel, pulses.as_slice(), 0.0, last_chance);
                assert_eq!((range, a.rows, a.broken), full, "{model:?}");
            }
        }
    }

    #[test]
    fn a_row_scanned_as_far_as_the_search_needs_is_the_row_scanned_to_its_windows_end() {
        let joint = seed_robot().joints[1].clone();
        let pulses = cruise(9_000.0, 3.0);
        let mut bounds = Bounds::default();
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let spare = RefCell::new(Bounds::default());
            let channel = Channel {
                joint: &joint,
                model,
                off_window: 0,
                bounds: &spare,
            };
            for range in FrequencyRange::FINEST_FIRST {
                // Rows from every 97th pulse: scanned first over 1, 7, 64 and 4096 pulses,
                // and all the way (what the search did before).
                let (mut rows, mut longer_than_first) = (0, 0);
                for k in (0..pulses.len()).step_by(97) {
                    let t_s = pulses[k].ideal_s - 1e-4;
                    let (whole, _) =
                        channel.longest_scanning(range, &pulses[k..], t_s, &mut bounds, usize::MAX);
                    for first in [1, 7, 64, SCAN_FIRST] {
                        let (row, scanned) =
                            channel.longest_scanning(range, &pulses[k..], t_s, &mut bounds, first);
                        assert_eq!(
                            row, whole,
                            "{model:?} {range:?} from pulse {k}, first {first}"
                        );
                        // Scanned no further than a doubling past the row.
                        let m = row.map_or(0, |r| r.0);
                        assert!(scanned <= (2 * m + 1).max(first), "{m} {scanned}");
                    }
                    rows += 1;
                    longer_than_first += usize::from(whole.is_some_and(|r| r.0 > 64));
                }
                assert!(rows > 100, "{rows}");
                if range != FrequencyRange::Low {
                    assert!(
                        longer_than_first > 10,
                        "{model:?} {range:?} {longer_than_first}"
                    );
                }
            }
        }
    }

    proptest::proptest! {
        /// A run's segments read piece by piece from its windows are the segments read pulse
        /// by pulse from its pulses made one by one.
        #[test]
        fn rows_read_by_pieces_are_the_rows_read_pulse_by_pulse(
            u in super::super::windows::tests::track(),
            delta in 0.0..6.0_f64,
            off_window in 0..3_usize,
        ) {
            let joint = seed_robot().joints[1].clone();
            let counts = Counts::new(u);
            let track = counts.track(1e-3);
            let mut made = Vec::new();
            let starts = track.pulses_into(0, delta, &mut made);
            let windows = track.windows(0, delta);
            let read = windows.runs();
            for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
                let spare = RefCell::new(Bounds::default());
                let channel = Channel { joint: &joint, model, off_window, bounds: &spare };
                let (mut t_s, mut count) = (0.0, 0);
                for (r, o) in read.iter().zip(runs(&made, &starts)) {
                    let by_pieces = channel.run(r, t_s, count, 4);
                    let by_pulses = channel.run(&o, t_s, count, 4);
                    proptest::prop_assert_eq!(&by_pieces, &by_pulses, "{:?}", model);
                    t_s = by_pulses.1;
                    count = o.pulses.last().map_or(count, |p| p.count);
                }
            }
        }
    }
}
