//! Cutting a joint's pulses into runs and pieces ([`Windows`]) from its track.
//!
//! 1. One sweep over the sample intervals counts each interval's crossings (the rule of
//!    `Track::crossings`, worked per interval, not per pulse) and cuts the runs one way.
//! 2. A run whose intervals all move its way (one stretch: the searches for its windows' edges
//!    stop at the same two samples for every pulse) gets its pieces per sample interval: the
//!    pulse where an edge's level reaches the interval's next sample is worked out from the
//!    level's arithmetic and checked on the two pulses either side; a piece runs on over the
//!    intervals along which its edge bends one way ([`Track::bending`]).
//! 3. Any other run (a joint that wavers, or windows too narrow for step 2's argument) follows
//!    each edge from pulse to pulse, skipping the pulses where nothing changes
//!    ([`super::one_by_one`]).

use super::{Edge, Piece, RunStart, Side, Windows};
use crate::plan::bounded::pulses::Track;
use crate::table::Direction;

/// Windows narrower than this, pulses each side, take step 3: step 2 needs a pulse's latest
/// level strictly past its half count in floating point.
const STRETCH_MIN_DELTA: f64 = 1e-3;
/// Counts beyond this take step 3, for the same reason.
const STRETCH_MAX_COUNT: i64 = 1 << 40;
/// How far, as a share, an edge's slope may bend the other way along a piece that runs on
/// ([`Track::bending`]): no more than the samples' rounding. A joint at a steady speed has
/// intervals equal but for the last bits of its counts (on the seed's move, slopes a few
/// 1e-13 apart), which would otherwise cut a piece every few intervals. Along such a piece
/// a pulse inside can bound a row past its ends by at most this share of the piece's time
/// (about 1e-10 s on a 0.1 s piece): far below any realisable step of a row's period, and
/// the execution model judges every plan.
const BEND_ROUNDING: f64 = 1e-9;
/// The most sample intervals a piece runs on over: a pulse inside a piece is read by searching
/// for its interval, which a longer piece makes longer. On the seed's move 8, 16, 32 and 48
/// plan about as fast; unbounded, pieces as long as a ramp made the rows' searches cost more
/// than the pieces saved.
const PIECE_INTERVALS: usize = 16;

/// A run as the sweep finds it.
pub(super) struct Span {
    pub start: RunStart,
    /// Its pulses.
    pub n: usize,
    /// The sample intervals its first and last pulses cross in.
    pub first_interval: usize,
    pub last_interval: usize,
    /// Every interval from the first to the last moves its way.
    one_stretch: bool,
}

impl Span {
    pub(super) fn d(&self) -> i64 {
        self.start.d()
    }
}

/// The count after an interval ending at `b` crossed from `count` going `d`: the count
/// follows while `b` is past the next half count, so it ends within a half of `b`, and on an
/// exact half it stops short.
fn count_after(b: f64, count: i64, d: i64) -> i64 {
    let past = |c: i64| {
        if d > 0 {
            b > c as f64 + 0.5
        } else {
            b < c as f64 - 0.5
        }
    };
    let mut after = crate::kinematics::nearest_count(b);
    if (after - count) * d < 1 || past(after) {
        // Off by more than a tie (a count beyond any a track reaches): the rule itself.
        after = count;
        while past(after) {
            after += d;
        }
    } else if !past(after - d) {
        after -= d;
    }
    after
}

/// The first of `lo..hi` where `short` is false (it is true up to some point and false from
/// there); `hi` if none.
fn first_not(mut lo: i64, mut hi: i64, short: impl Fn(i64) -> bool) -> i64 {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if short(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// A run's edge levels: pulse `m` (from 0) crosses the half count after `c0 + d m`, and an
/// edge's level is that half count plus `offset` (`-d delta` earliest, `+d delta` latest),
/// worked as the one-by-one pulses work them.
pub(super) struct Levels {
    pub c0: i64,
    pub d: i64,
    pub df: f64,
    pub offset: f64,
}

impl Levels {
    fn level(&self, m: i64) -> f64 {
        let half = (self.c0 + self.d * m) as f64 + 0.5 * self.df;
        half + self.offset
    }

    /// The first pulse from `from` (of `n`) whose level has reached `target` (passed it, if
    /// `strictly`); `n` if none.
    pub(super) fn first_reaching(&self, from: i64, n: i64, target: f64, strictly: bool) -> i64 {
        let short = |m: i64| {
            let gap = (target - self.level(m)) * self.df;
            if strictly { gap >= 0.0 } else { gap > 0.0 }
        };
        // Most often the pulse or the one after (a cast, not a ceiling, and the rounding of
        // the levels): checked there, and searched for only if not.
        let guess = self.df * (target - self.c0 as f64) - 0.5 - self.df * self.offset;
        let m = if guess >= n as f64 {
            n
        } else if guess > from as f64 {
            guess as i64
        } else {
            from
        };
        if m > from && !short(m - 1) {
            first_not(from, m - 1, short)
        } else if m == n || !short(m) {
            m
        } else if m + 1 == n || !short(m + 1) {
            m + 1
        } else {
            first_not(m + 2, n, short)
        }
    }
}

impl<'a> Track<'a> {
    /// The joint's pulses from count `start`, with windows `delta` pulses wide each side.
    pub(in crate::plan::bounded) fn windows(self, start: i64, delta: f64) -> Windows<'a> {
        let mut w = Windows {
            track: self,
            delta,
            runs: Vec::new(),
            crossed: Vec::with_capacity(self.counts().len()),
            early: Vec::with_capacity(self.counts().len() + 2),
            late: Vec::with_capacity(self.counts().len() + 2),
            len: 0,
        };
        for span in self.sweep(start, &mut w) {
            w.runs.push(span.start);
            let kept = (w.early.len(), w.late.len());
            let narrow = delta.is_nan()
                || delta < STRETCH_MIN_DELTA
                || span.start.count.abs() > STRETCH_MAX_COUNT - span.n as i64;
            if narrow || !span.one_stretch || !self.stretch_pieces(&span, delta, &mut w) {
                w.early.truncate(kept.0);
                w.late.truncate(kept.1);
                self.pieces_one_by_one(&span, delta, &mut w);
            }
        }
        w.ends();
        w
    }

    /// Step 1: the runs, and where each pulse is crossed (into `w.crossed`); sets `w.len`.
    fn sweep(&self, start: i64, w: &mut Windows) -> Vec<Span> {
        let u = self.counts();
        let mut spans: Vec<Span> = Vec::new();
        let (mut count, mut k) = (start, 0_usize);
        // An interval since the run's last crossing that does not move its way.
        let mut bent = false;
        for i in 0..u.len().saturating_sub(1) {
            let (b, c) = (u[i + 1], count as f64);
            let d: i64 = if b > c + 0.5 {
                1
            } else if b < c - 0.5 {
                -1
            } else {
                if let Some(span) = spans.last() {
                    bent |= !self.moves(i, span.d() as f64);
                }
                continue;
            };
            let direction = if d > 0 {
                Direction::Up
            } else {
                Direction::Down
            };
            let start = RunStart {
                first: k,
                direction,
                count,
            };
            let span = run_of(&mut spans, start, i, bent);
            // A count that starts off its track crosses where the track holds still.
            span.one_stretch &= self.moves(i, d as f64);
            bent = false;
            w.crossed.push((k, i));
            let after = count_after(b, count, d);
            k += (after - count).unsigned_abs() as usize;
            count = after;
            span.n = k - span.start.first;
        }
        w.len = k;
        spans
    }

    /// Step 2 for a run of one stretch; false if its pieces do not close (they always should:
    /// the caller then takes step 3).
    fn stretch_pieces(&self, span: &Span, delta: f64, w: &mut Windows) -> bool {
        let u = self.counts();
        let d = span.d();
        let df = d as f64;
        // The searches' ends: back to the stretch's first sample, on to its last.
        let mut from = span.first_interval;
        while from > 0 && self.moves(from - 1, df) {
            from -= 1;
        }
        let mut to = span.last_interval;
        while to + 2 < u.len() && self.moves(to + 1, df) {
            to += 1;
        }
        let early = Levels {
            c0: span.start.count,
            d,
            df,
            offset: -df * delta,
        };
        let late = Levels {
            c0: span.start.count,
            d,
            df,
            offset: df * delta,
        };
        self.early_pieces(span, &early, (from, to), &mut w.early)
            && self.late_pieces(span, &late, to, &mut w.late)
    }

    /// Step 2's earliest landings of `span`'s pulses at `early`'s levels, the stretch's samples
    /// `from` to `to`: before its first sample, the stretch's start; then the interval whose
    /// first sample the level has reached and whose next it has not. False if they do not close.
    fn early_pieces(
        &self,
        span: &Span,
        early: &Levels,
        (from, to): (usize, usize),
        pieces: &mut Vec<Piece>,
    ) -> bool {
        let u = self.counts();
        let (k0, n, df) = (span.start.first, span.n as i64, early.df);
        let mut m = early.first_reaching(0, n, u[from], false);
        if m > 0 {
            pieces.push(Piece::at(k0, self.t(from)));
        }
        let mut j = from;
        while m < n {
            // The interval pulse `m`'s level is in (most often the next).
            let level = early.level(m);
            let past = |x: f64| (x - level) * df <= 0.0;
            if j < to && past(u[j + 1]) {
                j += 1;
                if j < to && past(u[j + 1]) {
                    j += u[j + 1..=to].partition_point(|&x| past(x));
                }
            }
            if j > to {
                return false;
            }
            let Some((next, last)) = self.run_on(pieces, k0, (j, to), early, Side::Early, (m, n))
            else {
                return false;
            };
            (m, j) = (next, last);
        }
        true
    }

    /// Step 2's latest landings of `span`'s pulses at `late`'s levels, the stretch's last
    /// sample `to`: the interval whose next sample the level has not passed, from the one the
    /// pulse crosses in (no earlier one: the level is past the half count); past the stretch's
    /// last sample, its end. False if they do not close.
    fn late_pieces(&self, span: &Span, late: &Levels, to: usize, pieces: &mut Vec<Piece>) -> bool {
        let u = self.counts();
        let (k0, n, df) = (span.start.first, span.n as i64, late.df);
        let (mut m, mut j) = (0, span.first_interval);
        while m < n {
            let level = late.level(m);
            let passed = |x: f64| (x - level) * df < 0.0;
            if passed(u[j + 1]) {
                j += 1;
                if j <= to && passed(u[j + 1]) {
                    j += u[j + 1..=to + 1].partition_point(|&x| passed(x));
                }
            }
            if j > to {
                pieces.push(Piece::at(k0 + m as usize, self.t(to + 1)));
                break;
            }
            let Some((next, last)) = self.run_on(pieces, k0, (j, to), late, Side::Late, (m, n))
            else {
                return false;
            };
            (m, j) = (next, last);
        }
        true
    }

    /// The piece from pulse `m` (of `n`, from the run's pulse `k0`), whose edge on `side` is in
    /// interval `j`, run on as far as the edge bends the way the side's bound needs (convex for
    /// the earliest, a largest; concave for the latest, a smallest: either is then at the
    /// piece's ends), or, if not past `j`, as far as it bends against it (the bound then has
    /// one peak, [`Piece::against`]), pushed onto `pieces`; the pulse after it and its last
    /// interval. `None` if it would hold no pulse (it always does: the caller then takes step
    /// 3).
    fn run_on(
        &self,
        pieces: &mut Vec<Piece>,
        k0: usize,
        (j, to): (usize, usize),
        levels: &Levels,
        side: Side,
        (m, n): (i64, i64),
    ) -> Option<(i64, usize)> {
        let mut last = self.bending(j, to, levels.d, side);
        let mut against = false;
        if last == j {
            last = self.bending(j, to, levels.d, side.other());
            against = last > j;
        }
        let strictly = side == Side::Late;
        let next = levels.first_reaching(m, n, self.counts()[last + 1], strictly);
        if next == m {
            return None;
        }
        let mut piece = self.piece(k0, (j, last), side, levels, m, next);
        piece.against = against;
        pieces.push(piece);
        Some((next, last))
    }

    /// The last sample interval from `j` (up to `to`) along which an edge's time, as a
    /// function of the pulse, bends only the way `side` needs: its slope over an interval is
    /// the interval's time per count (its reciprocal change, counted the run's way `d`), never
    /// falling for the earliest (convex) and never rising for the latest (concave), by more
    /// than [`BEND_ROUNDING`] of the steepest (shallowest) before it.
    fn bending(&self, j: usize, to: usize, d: i64, side: Side) -> usize {
        let to = to.min(j + PIECE_INTERVALS - 1);
        let rate = self.rates();
        let slope = |i: usize| rate[i] * d as f64;
        let mut last = j;
        match side {
            Side::Early => {
                let mut most = slope(j);
                while last < to && slope(last + 1) >= most - BEND_ROUNDING * most.abs() {
                    last += 1;
                    most = most.max(slope(last));
                }
            }
            Side::Late => {
                let mut least = slope(j);
                while last < to && slope(last + 1) <= least + BEND_ROUNDING * least.abs() {
                    last += 1;
                    least = least.min(slope(last));
                }
            }
        }
        last
    }

    /// The piece of a run from pulse `k0` whose pulses `m` to before `next` have their edge
    /// (`levels`) in sample intervals `from` to `to`.
    fn piece(
        &self,
        k0: usize,
        (from, to): (usize, usize),
        side: Side,
        levels: &Levels,
        m: i64,
        next: i64,
    ) -> Piece {
        let first = k0 + m as usize;
        let (level_first, level_last) = (levels.level(m), levels.level(next - 1));
        if from == to {
            // A piece of one interval: read in place.
            return Piece {
                first,
                edge: Edge::Passes(from),
                at_first: self.at(from, level_first),
                at_last: self.at(from, level_last),
                against: false,
            };
        }
        let edge = Edge::Spans(from, to);
        Piece {
            first,
            edge,
            at_first: self.edge_at(side, edge, level_first, levels.df, &mut { from }),
            at_last: self.edge_at(side, edge, level_last, levels.df, &mut { to }),
            against: false,
        }
    }

    /// When the track passes `level` (going `d`), for an edge on `side` in `edge`'s sample
    /// intervals: the earliest in the last interval that starts at or before the level, the
    /// latest in the first that ends at or past it (as `Track::since` and `Track::until`
    /// find them).
    pub(super) fn edge_at(
        &self,
        side: Side,
        edge: Edge,
        level: f64,
        d: f64,
        interval: &mut usize,
    ) -> f64 {
        let (from, to) = match edge {
            Edge::At(t_s) => return t_s,
            Edge::Passes(i) => return self.at(i, level),
            Edge::Spans(from, to) => (from, to),
        };
        let u = self.counts();
        // The samples after the first the level is past (has reached, for the earliest) are a
        // run from the first: the interval is the first plus how many. Read on from where the
        // last reading found it, or (a level before that) a piece's first and last pulses are
        // most often in its first and last intervals.
        let past = |x: f64| match side {
            Side::Early => (x - level) * d <= 0.0,
            Side::Late => (x - level) * d < 0.0,
        };
        let hint = *interval;
        let i = if (from..=to).contains(&hint) && (hint == from || past(u[hint])) {
            let mut i = hint;
            while i < to && past(u[i + 1]) {
                i += 1;
                if i - hint > 3 {
                    i += u[i + 1..=to].partition_point(|&x| past(x));
                    break;
                }
            }
            i
        } else if !past(u[from + 1]) {
            from
        } else if past(u[to]) {
            to
        } else {
            from + 1 + u[from + 2..to].partition_point(|&x| past(x))
        };
        *interval = i;
        self.at(i, level)
    }
}

/// The run interval `i` crosses in: the last run, carried on when it goes `start`'s way (no
/// longer one stretch if the intervals since its last crossing were `bent`), else a new run
/// begun at `start`.
fn run_of(spans: &mut Vec<Span>, start: RunStart, i: usize, bent: bool) -> &mut Span {
    match spans.last_mut() {
        Some(span) if span.start.direction == start.direction => {
            span.one_stretch &= !bent;
            span.last_interval = i;
        }
        _ => spans.push(Span {
            start,
            n: 0,
            first_interval: i,
            last_interval: i,
            one_stretch: true,
        }),
    }
    spans.last_mut().expect("a run")
}
