//! A joint's pulses and their windows ([`super::pulses`]), read where needed rather than made
//! one by one: between two samples the track is a line, so along the pulses whose window edge
//! falls in one sample interval the edge follows one formula, and a pulse's bound in a row,
//! `(edge - start) / n`, is monotone along them. The pulses are cut into such pieces, run on
//! over further intervals ([`Edge::Spans`], up to sixteen) while the edge bends one way (to
//! within the samples' rounding): the way its bound allows, and a row's period bounds are read
//! at the piece's ends only ([`super::rows`]); or against it, where a joint speeds up (its
//! earliest landings) or slows down (its latest), and the bound rises to one peak inside the
//! piece and falls, which the rows search for ([`Piece::against`]).
//!
//! The pieces are found per sample interval ([`build`]); a pulse read from them is the pulse
//! `Track::pulses_into` makes, bit for bit (the tests check it).

mod build;
mod one_by_one;

use super::pulses::{Pulse, Track};
use crate::table::Direction;

/// A window's edge: its earliest or its latest landing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Side {
    /// The earliest landing.
    Early,
    /// The latest landing.
    Late,
}

impl Side {
    /// The other edge.
    fn other(self) -> Self {
        match self {
            Self::Early => Self::Late,
            Self::Late => Self::Early,
        }
    }
}

/// Pulses with windows, read by index from 0 in time order, in pieces along which one edge
/// follows one formula. `Copy`: a view, cut with [`Pulses::after`].
pub(super) trait Pulses: Copy {
    /// How many.
    fn len(self) -> usize;
    /// Pulse `k`.
    fn pulse(self, k: usize) -> Pulse;
    /// Pulse `k`'s count after it ([`Pulse::count`]), without its windows.
    fn count(self, k: usize) -> i64 {
        self.pulse(k).count
    }
    /// When pulse `k` lands on time ([`Pulse::ideal_s`]), without its windows.
    fn ideal_s(self, k: usize) -> f64 {
        self.pulse(k).ideal_s
    }
    /// The pulses from `k` on.
    fn after(self, k: usize) -> Self;
    /// The last pulse of the piece pulse `k` is in on `side` (from `k`, that side's edge is
    /// monotone in the pulse), the edge at `k` and at that last pulse, and whether the edge
    /// bends against the side's bound along it ([`Piece::against`]). `cursor` is a place to
    /// start looking, kept between calls ([`Cursor::NEW`] at first).
    fn piece(self, side: Side, k: usize, cursor: &mut Cursor) -> (usize, f64, f64, bool);
    /// Pulse `k`'s edge on `side` (`cursor` as for [`Self::piece`]).
    fn edge(self, side: Side, k: usize, cursor: &mut Cursor) -> f64;
}

/// Where a reading of pieces left off: the piece, and the sample interval in it. Kept between
/// calls it makes reading on cheap.
#[derive(Debug, Clone, Copy)]
pub(super) struct Cursor {
    piece: usize,
    interval: usize,
}

impl Cursor {
    /// A cursor that knows nothing yet.
    pub(super) const NEW: Self = Self {
        piece: usize::MAX,
        interval: usize::MAX,
    };
}

/// Pulses made one by one: every pulse is a piece of its own.
impl Pulses for &[Pulse] {
    fn len(self) -> usize {
        <[Pulse]>::len(self)
    }

    fn pulse(self, k: usize) -> Pulse {
        self[k]
    }

    fn after(self, k: usize) -> Self {
        &self[k..]
    }

    fn piece(self, side: Side, k: usize, cursor: &mut Cursor) -> (usize, f64, f64, bool) {
        let at_k = self.edge(side, k, cursor);
        (k, at_k, at_k, false)
    }

    fn edge(self, side: Side, k: usize, _: &mut Cursor) -> f64 {
        match side {
            Side::Early => self[k].lo_s,
            Side::Late => self[k].hi_s,
        }
    }
}

/// Where one edge of a piece's windows lies.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Edge {
    /// When the track passes the edge's level, in this sample interval.
    Passes(usize),
    /// When the track passes the edge's level, in one of the sample intervals from the first
    /// to the second, along which the edge bends one way only ([`build`]): the pulse's own
    /// interval is searched for, as the one-by-one searches find it.
    Spans(usize, usize),
    /// At this time: where the joint's motion that way starts (earliest) or ends (latest).
    At(f64),
}

/// The pulses from `first` to the next piece's, whose edge is `edge`, and the edge at its first
/// and last pulses ([`Windows::ends`]).
#[derive(Debug, Clone, Copy)]
struct Piece {
    first: usize,
    edge: Edge,
    at_first: f64,
    at_last: f64,
    /// The edge bends against its side's bound along the piece (concave for the earliest,
    /// convex for the latest, where a joint speeds up or slows down): a pulse's bound in a
    /// row then rises to one peak and falls ([`super::rows`] finds it), not only at the ends.
    against: bool,
}

impl Piece {
    /// Pulses from `first` whose edge is at `t_s`.
    fn at(first: usize, t_s: f64) -> Self {
        Self {
            first,
            edge: Edge::At(t_s),
            at_first: t_s,
            at_last: t_s,
            against: false,
        }
    }

    fn new(first: usize, edge: Edge) -> Self {
        Self {
            first,
            edge,
            at_first: f64::NAN,
            at_last: f64::NAN,
            against: false,
        }
    }
}

/// The pulses one way from `first`, and the count before them.
#[derive(Debug, Clone, Copy)]
struct RunStart {
    first: usize,
    direction: Direction,
    count: i64,
}

impl RunStart {
    /// Its direction, +1 or -1.
    fn d(&self) -> i64 {
        match self.direction {
            Direction::Up => 1,
            Direction::Down => -1,
        }
    }

    /// The count before its pulse `k` (counted in the joint's pulses).
    fn before(&self, k: usize) -> i64 {
        self.count + self.d() * (k - self.first) as i64
    }

    /// The half count its pulse `k` crosses, and its direction.
    fn half(&self, k: usize) -> (f64, f64) {
        let df = self.d() as f64;
        (self.before(k) as f64 + 0.5 * df, df)
    }
}

/// One joint's pulses and windows `delta` pulses wide each side ([`Track::windows`]).
pub(super) struct Windows<'a> {
    track: Track<'a>,
    delta: f64,
    runs: Vec<RunStart>,
    /// Each pulse from the first is crossed (ideally lands) in the second sample interval.
    crossed: Vec<(usize, usize)>,
    early: Vec<Piece>,
    late: Vec<Piece>,
    len: usize,
}

/// The index of the last entry whose first pulse is at or before `k`, starting from `cursor`.
fn locate<T>(entries: &[T], first: impl Fn(&T) -> usize, k: usize, cursor: &mut usize) -> usize {
    let c = *cursor;
    // Read in order: most often the next entry's first pulse.
    let n = c.wrapping_add(1);
    if entries.get(n).is_some_and(|next| first(next) == k) {
        *cursor = n;
        return n;
    }
    let fits = |c: usize| {
        c < entries.len()
            && first(&entries[c]) <= k
            && entries.get(c + 1).is_none_or(|e| first(e) > k)
    };
    if !fits(c) {
        *cursor = if c < entries.len() && fits(c + 1) {
            c + 1
        } else {
            entries.partition_point(|e| first(e) <= k) - 1
        };
    }
    *cursor
}

impl Windows<'_> {
    /// The run pulse `k` is in.
    fn run_of(&self, k: usize) -> RunStart {
        self.runs[locate(&self.runs, |r| r.first, k, &mut { usize::MAX })]
    }

    fn pieces(&self, side: Side) -> &[Piece] {
        match side {
            Side::Early => &self.early,
            Side::Late => &self.late,
        }
    }

    /// Pulse `k`'s edge on `side`, in `piece`, of `run`; `interval` is where the last reading
    /// found its interval.
    fn edge_in(
        &self,
        side: Side,
        piece: &Piece,
        k: usize,
        run: &RunStart,
        interval: &mut usize,
    ) -> f64 {
        if let Edge::At(t_s) = piece.edge {
            return t_s;
        }
        let (h, df) = run.half(k);
        let level = match side {
            Side::Early => h - df * self.delta,
            Side::Late => h + df * self.delta,
        };
        self.track.edge_at(side, piece.edge, level, df, interval)
    }

    /// Pulse `k`'s edge on `side` (of `run`), its piece found from `cursor`.
    fn edge(&self, side: Side, k: usize, cursor: &mut Cursor, run: &RunStart) -> f64 {
        let pieces = self.pieces(side);
        let piece = &pieces[locate(pieces, |p| p.first, k, &mut cursor.piece)];
        if k == piece.first {
            piece.at_first
        } else {
            self.edge_in(side, piece, k, run, &mut cursor.interval)
        }
    }

    /// The last pulse of `k`'s piece on `side` (of `run`), the edge at `k` and there.
    fn piece(
        &self,
        side: Side,
        k: usize,
        cursor: &mut Cursor,
        run: &RunStart,
    ) -> (usize, f64, f64, bool) {
        let pieces = self.pieces(side);
        let p = locate(pieces, |p| p.first, k, &mut cursor.piece);
        let piece = &pieces[p];
        let last = pieces.get(p + 1).map_or(self.len, |next| next.first) - 1;
        let at_k = if k == piece.first {
            piece.at_first
        } else {
            self.edge_in(side, piece, k, run, &mut cursor.interval)
        };
        (last, at_k, piece.at_last, piece.against)
    }

    /// Works out the edge at their first and last pulses for the pieces that do not have them.
    fn ends(&mut self) {
        for side in [Side::Early, Side::Late] {
            let mut pieces = std::mem::take(match side {
                Side::Early => &mut self.early,
                Side::Late => &mut self.late,
            });
            for p in 0..pieces.len() {
                let piece = pieces[p];
                if !piece.at_first.is_nan() {
                    continue;
                }
                let last = pieces.get(p + 1).map_or(self.len, |next| next.first) - 1;
                let run = self.run_of(piece.first);
                let mut interval = usize::MAX;
                pieces[p].at_first = self.edge_in(side, &piece, piece.first, &run, &mut interval);
                pieces[p].at_last = self.edge_in(side, &piece, last, &run, &mut interval);
            }
            match side {
                Side::Early => self.early = pieces,
                Side::Late => self.late = pieces,
            }
        }
    }

    /// Pulse `k`.
    fn pulse(&self, k: usize, run: &RunStart) -> Pulse {
        Pulse {
            count: Self::count(k, run),
            ideal_s: self.ideal_s(k, run),
            lo_s: self.edge(Side::Early, k, &mut { Cursor::NEW }, run),
            hi_s: self.edge(Side::Late, k, &mut { Cursor::NEW }, run),
        }
    }

    /// Pulse `k`'s count after it.
    fn count(k: usize, run: &RunStart) -> i64 {
        run.before(k) + run.half(k).1 as i64
    }

    /// When pulse `k` lands on time.
    fn ideal_s(&self, k: usize, run: &RunStart) -> f64 {
        let crossed = self.crossed[locate(&self.crossed, |c| c.0, k, &mut { usize::MAX })].1;
        self.track.at(crossed, run.half(k).0)
    }

    /// The runs of one direction, in order.
    pub(super) fn runs(&self) -> Vec<super::pulses::Run<Stretch<'_>>> {
        self.runs
            .iter()
            .enumerate()
            .map(|(r, run)| super::pulses::Run {
                direction: run.direction,
                pulses: Stretch {
                    windows: self,
                    run: *run,
                    from: run.first,
                    to: self.runs.get(r + 1).map_or(self.len, |next| next.first),
                },
            })
            .collect()
    }

    /// How many pulses.
    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.len
    }
}

/// Some of a joint's pulses, `from` to before `to` of its [`Windows`].
#[derive(Clone, Copy)]
pub(super) struct Stretch<'w> {
    windows: &'w Windows<'w>,
    /// The run they are in.
    run: RunStart,
    from: usize,
    to: usize,
}

impl Pulses for Stretch<'_> {
    fn len(self) -> usize {
        self.to - self.from
    }

    fn pulse(self, k: usize) -> Pulse {
        debug_assert!(self.from + k < self.to);
        self.windows.pulse(self.from + k, &self.run)
    }

    fn count(self, k: usize) -> i64 {
        debug_assert!(self.from + k < self.to);
        Windows::count(self.from + k, &self.run)
    }

    fn ideal_s(self, k: usize) -> f64 {
        debug_assert!(self.from + k < self.to);
        self.windows.ideal_s(self.from + k, &self.run)
    }

    fn after(self, k: usize) -> Self {
        assert!(k <= self.len(), "{k} pulses after {}", self.len());
        Self {
            from: self.from + k,
            ..self
        }
    }

    fn piece(self, side: Side, k: usize, cursor: &mut Cursor) -> (usize, f64, f64, bool) {
        let g = self.from + k;
        let (last, at_k, at_last, against) = self.windows.piece(side, g, cursor, &self.run);
        // Pieces end where runs do.
        debug_assert!(last < self.to);
        (last - self.from, at_k, at_last, against)
    }

    fn edge(self, side: Side, k: usize, cursor: &mut Cursor) -> f64 {
        self.windows.edge(side, self.from + k, cursor, &self.run)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::pulses::{Counts, runs};
    use super::*;
    use proptest::prelude::*;

    /// A track: legs of steady speed (counts a sample, either way, some holding still), of
    /// speed changing steadily (speeding up or slowing down, the edges bending one way), with
    /// a wiggle of `wiggle` counts now and then, and values that now and then land on half
    /// counts exactly.
    pub(in crate::plan::bounded) fn track() -> impl Strategy<Value = Vec<f64>> {
        (
            -3.0..3.0_f64,
            prop::collection::vec((-20.0..20.0_f64, 1..60_usize, 0..6_u8), 1..12),
            0.0..0.9_f64,
        )
            .prop_map(|(u0, legs, wiggle)| {
                let mut u = vec![u0];
                for (speed, samples, kind) in legs {
                    let speed = match kind {
                        0 => 0.0,
                        1 => speed.round() + 0.5 * speed.signum(),
                        _ => speed,
                    };
                    for s in 0..samples {
                        let last = *u.last().unwrap();
                        let jiggle = if kind == 3 && s % 5 == 2 {
                            -wiggle * speed.signum()
                        } else {
                            0.0
                        };
                        let ramp = (s + 1) as f64 / samples as f64;
                        let step = match kind {
                            4 => speed * ramp,
                            5 => speed * (1.0 - ramp + 0.01),
                            _ => speed,
                        };
                        u.push(last + step + jiggle);
                    }
                }
                u
            })
    }

    proptest! {
        /// Every pulse read from the pieces is the pulse made one by one, bit for bit, and
        /// the runs are the same.
        #[test]
        fn pulses_read_from_pieces_are_the_pulses_made_one_by_one(
            u in track(),
            start in -8..8_i64,
            delta in prop_oneof![Just(0.0), 0.0..10.0_f64],
        ) {
            let counts = Counts::new(u);
            let track = counts.track(1e-3);
            let mut made = Vec::new();
            let starts = track.pulses_into(start, delta, &mut made);
            let windows = track.windows(start, delta);
            prop_assert_eq!(windows.len(), made.len());
            let one_by_one = runs(&made, &starts);
            let read = windows.runs();
            prop_assert_eq!(read.len(), one_by_one.len());
            for (r, o) in read.iter().zip(&one_by_one) {
                prop_assert_eq!(r.direction, o.direction);
                prop_assert_eq!(r.pulses.len(), o.pulses.len());
                let mut cursors = [Cursor::NEW; 2];
                for (k, p) in o.pulses.iter().enumerate() {
                    prop_assert_eq!(r.pulses.pulse(k), *p);
                    prop_assert_eq!(r.pulses.count(k), p.count);
                    prop_assert_eq!(r.pulses.ideal_s(k).to_bits(), p.ideal_s.to_bits());
                    // Read along the pieces as the scan reads them.
                    for (side, c) in [Side::Early, Side::Late].into_iter().zip(&mut cursors) {
                        let (last, at_k, at_last, _) = r.pulses.piece(side, k, c);
                        prop_assert!(last >= k && last < o.pulses.len());
                        // Bit for bit.
                        let bits = |at: f64| at.to_bits();
                        prop_assert_eq!(bits(at_k), bits(o.pulses.edge(side, k, &mut { Cursor::NEW })));
                        prop_assert_eq!(bits(at_last), bits(o.pulses.edge(side, last, &mut { Cursor::NEW })));
                    }
                }
            }
        }
    }
}
