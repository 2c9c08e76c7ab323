//! Step 3 of cutting a joint's pulses into pieces ([`super::build`]): for a run that is not one
//! stretch (a joint that wavers or holds inside it, a count that starts off its track) or
//! windows too narrow for step 2, each edge's sample interval is followed from pulse to pulse
//! the way the one-by-one searches (`Track::since`, `Track::until`) find it, and only the pulses
//! where the crossing interval or an edge's interval changes are worked out.

use super::build::{Levels, Span};
use super::{Edge, Piece, Windows};
use crate::plan::bounded::pulses::Track;

impl Track<'_> {
    /// Step 3: follows each edge's sample interval from pulse to pulse as the one-by-one
    /// searches would find it, working out only the pulses where the crossing interval or an
    /// edge's changes.
    pub(super) fn pieces_one_by_one(&self, span: &Span, delta: f64, w: &mut Windows) {
        let u = self.counts();
        let (d, mut k) = (span.d(), span.start.first);
        let df = d as f64;
        let mut count = span.start.count;
        let mut early = EarlyEdge::new(self, span.first_interval, df);
        let mut late = LateEdge(None);
        let (first_early, first_late) = (w.early.len(), w.late.len());
        for i in span.first_interval..=span.last_interval {
            let b = u[i + 1];
            while if d > 0 {
                b > count as f64 + 0.5
            } else {
                b < count as f64 - 0.5
            } {
                let h = count as f64 + 0.5 * df;
                let lo = early.edge(self, i, h - df * delta, df);
                if w.early.len() == first_early || w.early.last().is_some_and(|p| p.edge != lo) {
                    w.early.push(Piece::new(k, lo));
                }
                let hi = late.edge(self, i, h + df * delta, df);
                if w.late.len() == first_late || w.late.last().is_some_and(|p| p.edge != hi) {
                    w.late.push(Piece::new(k, hi));
                }
                count += d;
                k += 1;
                let skip = same_after(u, b, count, d, delta, (lo, early.from), hi, i);
                count += d * skip;
                k += skip as usize;
            }
        }
        debug_assert_eq!(k, span.start.first + span.n);
    }
}

/// How many pulses after one just worked out (the count now `count`, crossing in interval `i`
/// that ends at `b`) cross in the same interval with both edges where its are (`lo`, with the
/// stretch's first sample `from`, and `hi`).
#[allow(clippy::too_many_arguments)]
fn same_after(
    u: &[f64],
    b: f64,
    count: i64,
    d: i64,
    delta: f64,
    (lo, from): (Edge, usize),
    hi: Edge,
    i: usize,
) -> i64 {
    let df = d as f64;
    let levels = |offset| Levels {
        c0: count,
        d,
        df,
        offset,
    };
    // In the interval: the half counts `b` is past.
    let mut same = levels(0.0).first_reaching(0, i64::MAX / 4, b, false);
    let early = levels(-df * delta);
    match lo {
        Edge::At(_) => same = early.first_reaching(0, same, u[from], false),
        Edge::Passes(j) if j < i => same = early.first_reaching(0, same, u[j + 1], false),
        // (A one-by-one piece is one interval: never `Spans`.)
        Edge::Passes(_) | Edge::Spans(..) => {}
    }
    if let Edge::Passes(j) = hi {
        same = levels(df * delta).first_reaching(0, same, u[j + 1], true);
    }
    same
}

/// Follows the sample interval in which a run's earliest landings fall (`Track::since`'s
/// search, carried from pulse to pulse).
struct EarlyEdge {
    /// The crossing interval of the pulse before.
    crossed: usize,
    /// The first interval of the stretch moving this way that holds it.
    from: usize,
    /// The last interval found to start at or before the level.
    at: usize,
}

impl EarlyEdge {
    fn new(track: &Track, crossed: usize, d: f64) -> Self {
        let mut from = crossed;
        while from > 0 && track.moves(from - 1, d) {
            from -= 1;
        }
        Self {
            crossed,
            from,
            at: from,
        }
    }

    fn edge(&mut self, track: &Track, crossed: usize, level: f64, d: f64) -> Edge {
        for i in self.crossed + 1..=crossed {
            if !track.moves(i - 1, d) {
                (self.from, self.at) = (i, i);
            }
        }
        self.crossed = crossed;
        let u = track.counts();
        if (u[self.from] - level) * d > 0.0 {
            return Edge::At(track.t(self.from));
        }
        while self.at < crossed && (u[self.at + 1] - level) * d <= 0.0 {
            self.at += 1;
        }
        Edge::Passes(self.at)
    }
}

/// Follows the sample interval in which a run's latest landings fall (`Track::until`'s
/// search, carried from pulse to pulse): where the last search stopped.
struct LateEdge(Option<usize>);

impl LateEdge {
    fn edge(&mut self, track: &Track, crossed: usize, level: f64, d: f64) -> Edge {
        let u = track.counts();
        let mut i = self.0.filter(|&i| i >= crossed).unwrap_or(crossed);
        loop {
            if (u[i + 1] - level) * d >= 0.0 {
                self.0 = Some(i);
                return Edge::Passes(i);
            }
            if i + 2 >= u.len() || !track.moves(i + 1, d) {
                self.0 = Some(i);
                return Edge::At(track.t(i + 1));
            }
            i += 1;
        }
    }
}
