//! PURE. A path of the tool through waypoints: lines and circular arcs, each waypoint either a
//! stop or a blended corner, built into the primitives the planner follows.
//!
//! A blend of radius `r` at a waypoint replaces the corner by an arc tangent to both neighbours,
//! starting and ending no further than `r` from the waypoint along them (less where a
//! neighbour is shorter than `2 r`: a blend takes at most half of each neighbour, so two blends
//! never overlap). Next to an arc the corner arc is the circle tangent to both neighbours in
//! the plane they share ([`fillet`]); it reaches at most `r` along each, and at most half of
//! either. A tangent join (an arc leaving in the direction the line came in) needs no blend.

mod arc;
mod bounds;
mod fillet;

pub use arc::{ARC_MIN_BULGE, ARC_MIN_GAP_MM, Arc, ArcFault, RADIUS_SLACK_MM};

use nalgebra::Vector3;
use thiserror::Error;

use super::{Line, LineDistance, Pose, ToolPath};
use bounds::Bounds;
use fillet::{Fillet, NoFillet, fillet};

/// The turn (radians) below which a corner is no corner: the path goes straight on.
const STRAIGHT_RAD: f64 = 1e-6;
/// The turn (radians) beyond which a corner goes back the way it came: no arc can round it.
const REVERSAL_RAD: f64 = std::f64::consts::PI - 1e-3;
/// How far from a path's ends and stops a stop added to it ([`Path::with_stop_at`]) must be, mm.
const STOP_APART_MM: f64 = 1e-3;

/// How the path goes on from one element to the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Corner {
    /// The tool comes to rest at the waypoint.
    Stop,
    /// The corner is rounded by an arc leaving each neighbour at most this far from it, mm.
    Blend(f64),
}

/// How an arc element is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArcBy {
    /// Through this point (three points make the circle).
    Via(Vector3<f64>),
    /// About this centre, in the plane square to `axis` through it.
    Centre {
        /// The centre, mm.
        centre_mm: Vector3<f64>,
        /// The plane's normal (z for an arc in a horizontal plane).
        axis: Vector3<f64>,
        /// Clockwise seen from the axis' tip (else counter-clockwise).
        clockwise: bool,
    },
}

/// One element of a path: to a pose, on a line or an arc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Element {
    /// A straight line to a pose.
    Line {
        /// Where it ends.
        to: Pose,
    },
    /// A circular arc to a pose.
    Arc {
        /// Where it ends.
        to: Pose,
        /// Which circle.
        by: ArcBy,
    },
}

impl Element {
    /// Where it ends.
    #[must_use]
    pub fn to(&self) -> Pose {
        match self {
            Self::Line { to } | Self::Arc { to, .. } => *to,
        }
    }
}

/// A path as written: a start, elements, and how each waypoint between two elements is passed.
#[derive(Debug, Clone, PartialEq)]
pub struct PathSpec {
    /// Where the tool starts.
    pub start: Pose,
    /// The elements, in order, with the corner at each one's end (the last one's is a stop,
    /// whatever it says).
    pub elements: Vec<(Element, Corner)>,
}

/// Why a path cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PathError {
    /// No elements.
    #[error("a path needs at least one element")]
    Empty,
    /// An element that does not move the tool point (and is not a full circle).
    #[error("element {element} ends where it starts ({x:.3}, {y:.3}, {z:.3} mm): it has no length")]
    NoLength {
        /// Element number, from 1.
        element: usize,
        /// Where, mm.
        x: f64,
        /// y, mm.
        y: f64,
        /// z, mm.
        z: f64,
    },
    /// An arc element's points make no circle.
    #[error("element {element} (arc): {reason}")]
    Arc {
        /// Element number, from 1.
        element: usize,
        /// Why.
        reason: String,
    },
    /// A blend radius that is not a number above 0.
    #[error("waypoint {waypoint}: blend {radius_mm} mm must be a number above 0")]
    BlendRadius {
        /// Waypoint number (the end of element n), from 1.
        waypoint: usize,
        /// The radius given, mm.
        radius_mm: f64,
    },
    /// A blend next to an arc whose other neighbour leaves the arc's plane: no circle is
    /// tangent to both.
    #[error(
        "waypoint {waypoint}: a blend next to an arc needs both neighbours in one plane, and \
         element {element} leaves the arc's plane by {off_deg:.3} deg (at most {max_deg:.1e} \
         deg); make the corner a stop"
    )]
    BlendOffPlane {
        /// Waypoint number, from 1.
        waypoint: usize,
        /// The element that leaves the plane (the line, or the second arc), from 1.
        element: usize,
        /// By how much, degrees.
        off_deg: f64,
        /// The most taken as in the plane, degrees.
        max_deg: f64,
    },
    /// No circle tangent to both neighbours touches them within the blend's reach.
    #[error(
        "waypoint {waypoint}: no arc tangent to both neighbours touches them within \
         {radius_mm} mm of the waypoint (and within half of each); make the corner a stop or \
         give another blend"
    )]
    BlendNoArc {
        /// Waypoint number, from 1.
        waypoint: usize,
        /// The blend asked, mm.
        radius_mm: f64,
    },
    /// A corner that turns the path back on itself cannot be blended.
    #[error("waypoint {waypoint}: the path turns back by {turn_deg:.1} deg there; it must stop")]
    Reversal {
        /// Waypoint number, from 1.
        waypoint: usize,
        /// The turn, degrees.
        turn_deg: f64,
    },
}

/// One primitive of a built path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Primitive {
    /// A straight line.
    Line(Line),
    /// A circular arc.
    Arc(Arc),
}

impl Primitive {
    /// Its length, mm.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        match self {
            Self::Line(l) => l.length_mm(),
            Self::Arc(a) => a.length_mm(),
        }
    }

    /// The pose at `s_mm` from its start.
    #[must_use]
    pub fn at(&self, s_mm: f64) -> Pose {
        match self {
            Self::Line(l) => l.at(s_mm),
            Self::Arc(a) => a.at(s_mm),
        }
    }

    /// The unit direction of travel at `s_mm` from its start (a line without length: zero).
    #[must_use]
    pub fn direction(&self, s_mm: f64) -> Vector3<f64> {
        match self {
            Self::Line(l) => (l.to.position_mm - l.from.position_mm)
                .try_normalize(0.0)
                .unwrap_or_else(Vector3::zeros),
            Self::Arc(a) => a.direction(s_mm),
        }
    }

    /// Its curvature, 1/mm (0 on a line).
    #[must_use]
    pub fn curvature_per_mm(&self) -> f64 {
        match self {
            Self::Line(_) => 0.0,
            Self::Arc(a) => 1.0 / a.radius_mm,
        }
    }

    /// Distance from a point to it, mm.
    #[must_use]
    pub fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Self::Line(l) => l.distance_mm(p),
            Self::Arc(a) => a.distance_mm(p),
        }
    }

    /// Distance from its start of its point nearest to `p`, mm.
    #[must_use]
    pub fn nearest_mm(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Self::Line(l) => {
                let d = l.to.position_mm - l.from.position_mm;
                let len2 = d.norm_squared();
                if len2 > 0.0 {
                    ((p - l.from.position_mm).dot(&d) / len2).clamp(0.0, 1.0) * len2.sqrt()
                } else {
                    0.0
                }
            }
            Self::Arc(a) => a.nearest_mm(p),
        }
    }

    /// The part of it from `start_mm` after its start to `end_mm` before its end (what blends
    /// at its ends leave of it).
    #[must_use]
    fn cut(&self, start_mm: f64, end_mm: f64) -> Self {
        match self {
            Self::Line(line) => Self::Line(Line {
                from: if start_mm > 0.0 {
                    line.at(start_mm)
                } else {
                    line.from
                },
                to: if end_mm > 0.0 {
                    line.at(line.length_mm() - end_mm)
                } else {
                    line.to
                },
            }),
            Self::Arc(arc) => Self::Arc(arc.cut(start_mm, end_mm)),
        }
    }

    /// Where it starts.
    #[must_use]
    pub fn from(&self) -> Pose {
        match self {
            Self::Line(l) => l.from,
            Self::Arc(a) => a.from,
        }
    }

    /// Where it ends.
    #[must_use]
    pub fn to(&self) -> Pose {
        match self {
            Self::Line(l) => l.to,
            Self::Arc(a) => a.to,
        }
    }
}

/// A primitive in place on its path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// The primitive.
    pub primitive: Primitive,
    /// Its start's distance along the path, mm.
    pub start_mm: f64,
    /// The element it comes from (from 1), or `None` for a blend's corner arc.
    pub element: Option<usize>,
    /// A blend's corner arc: the waypoint it rounds (the end of element n, from 1); `None` for
    /// an element's own piece.
    pub waypoint: Option<usize>,
}

/// A built path: pieces end to end, and where along it the tool comes to rest.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pieces: Vec<Piece>,
    /// Distances along the path of every stop, ascending; the last is the path's end.
    stops_mm: Vec<f64>,
    /// Bounding spheres over the pieces, for the distance from a point to the path.
    bounds: Bounds,
    /// Every line piece's figures, made once (`None` for an arc).
    lines: Vec<Option<LinePiece>>,
}

/// What a line piece's distance and quick position ([`Path::near`]) need, made once.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LinePiece {
    distance: LineDistance,
    from: Vector3<f64>,
    d: Vector3<f64>,
    /// One over its length, 1/mm.
    per_mm: f64,
    /// Where it ends along the path, mm (as [`Path::length_mm`] makes it for the last piece).
    end_mm: f64,
    /// How far a position made with `per_mm` may be from the one [`Line::at`] makes, mm: a few
    /// roundings of the largest coordinates involved.
    off_mm: f64,
}

impl LinePiece {
    fn new(line: &Line, start_mm: f64) -> Self {
        let from = line.from.position_mm;
        let d = line.to.position_mm - from;
        let len = line.length_mm();
        Self {
            distance: LineDistance::new(line),
            from,
            d,
            per_mm: if len > 0.0 { 1.0 / len } else { 0.0 },
            end_mm: start_mm + len,
            off_mm: 16.0 * f64::EPSILON * (from.norm() + len),
        }
    }
}

impl Path {
    fn new(pieces: Vec<Piece>, stops_mm: Vec<f64>) -> Self {
        Self {
            bounds: Bounds::new(&pieces),
            lines: pieces
                .iter()
                .map(|p| match &p.primitive {
                    Primitive::Line(l) => Some(LinePiece::new(l, p.start_mm)),
                    Primitive::Arc(_) => None,
                })
                .collect(),
            pieces,
            stops_mm,
        }
    }

    /// Builds `spec` into its primitives, corners blended where asked.
    ///
    /// # Errors
    /// When an element has no length or no circle, or a blend cannot be made (see
    /// [`PathError`]).
    pub fn build(spec: &PathSpec) -> Result<Self, PathError> {
        if spec.elements.is_empty() {
            return Err(PathError::Empty);
        }
        let mut raw = Vec::with_capacity(spec.elements.len());
        let mut from = spec.start;
        for (i, (element, _)) in spec.elements.iter().enumerate() {
            raw.push(primitive(i + 1, from, element)?);
            from = element.to();
        }
        let last = raw.len() - 1;
        let mut passes = Vec::with_capacity(last);
        for (i, (_, corner)) in spec.elements.iter().enumerate().take(last) {
            passes.push(pass(i + 1, *corner, &raw[i], &raw[i + 1])?);
        }
        Ok(Self::joined(&raw, &passes))
    }

    /// The path of primitives `raw` passing each waypoint between them as `passes` say: each
    /// cut back by the blends beside it, a corner arc between, a stop where it comes to rest.
    fn joined(raw: &[Primitive], passes: &[Pass]) -> Self {
        let mut pieces = Vec::new();
        let mut stops_mm = Vec::new();
        let mut s = 0.0;
        for (i, prim) in raw.iter().enumerate() {
            let cut_start = match i.checked_sub(1).and_then(|w| passes.get(w)) {
                Some(Pass::Blend(f)) => f.reach_out_mm,
                _ => 0.0,
            };
            let cut_end = match passes.get(i) {
                Some(Pass::Blend(f)) => f.reach_in_mm,
                _ => 0.0,
            };
            let own = prim.cut(cut_start, cut_end);
            // A line two blends took whole leaves nothing between their arcs.
            if own.length_mm() > 1e-9 {
                pieces.push(Piece {
                    primitive: own,
                    start_mm: s,
                    element: Some(i + 1),
                    waypoint: None,
                });
                s += own.length_mm();
            }
            match passes.get(i) {
                Some(&Pass::Blend(Fillet { corner, .. })) => {
                    pieces.push(Piece {
                        primitive: Primitive::Arc(corner),
                        start_mm: s,
                        element: None,
                        waypoint: Some(i + 1),
                    });
                    s += corner.length_mm();
                }
                Some(Pass::Stop) => stops_mm.push(s),
                Some(Pass::Straight) | None => {}
            }
        }
        stops_mm.push(s);
        Self::new(pieces, stops_mm)
    }

    /// Its pieces, in order.
    #[must_use]
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Its length, mm.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        self.pieces
            .last()
            .map_or(0.0, |p| p.start_mm + p.primitive.length_mm())
    }

    /// Distances along it where the tool comes to rest, ascending; the last is its end.
    #[must_use]
    pub fn stops_mm(&self) -> &[f64] {
        &self.stops_mm
    }

    /// The same path with the tool also coming to rest `s_mm` along it (the piece there cut in
    /// two, both from the same element): `None` unless `s_mm` lies inside it, more than a
    /// micrometre from its ends and its stops.
    #[must_use]
    pub fn with_stop_at(&self, s_mm: f64) -> Option<Self> {
        let apart = |stop: f64| (stop - s_mm).abs() > STOP_APART_MM;
        let inside = s_mm > STOP_APART_MM && s_mm < self.length_mm() - STOP_APART_MM;
        if !(inside && self.stops_mm.iter().all(|&stop| apart(stop))) {
            return None;
        }
        let mut pieces = Vec::with_capacity(self.pieces.len() + 1);
        for piece in &self.pieces {
            let into = s_mm - piece.start_mm;
            let length_mm = piece.primitive.length_mm();
            if into > STOP_APART_MM && into < length_mm - STOP_APART_MM {
                pieces.push(Piece {
                    primitive: piece.primitive.cut(0.0, length_mm - into),
                    ..*piece
                });
                pieces.push(Piece {
                    primitive: piece.primitive.cut(into, 0.0),
                    start_mm: s_mm,
                    ..*piece
                });
            } else {
                pieces.push(*piece);
            }
        }
        let mut stops_mm = self.stops_mm.clone();
        stops_mm.push(s_mm);
        stops_mm.sort_by(f64::total_cmp);
        Some(Self::new(pieces, stops_mm))
    }

    /// The path cut at every stop: sections the tool runs through without coming to rest, each
    /// measured from its own start.
    #[must_use]
    pub fn sections(&self) -> Vec<Path> {
        let mut sections = Vec::with_capacity(self.stops_mm.len());
        let mut pieces = Vec::new();
        let mut base_mm = 0.0;
        let mut stops = self.stops_mm.iter().peekable();
        for piece in &self.pieces {
            pieces.push(Piece {
                start_mm: piece.start_mm - base_mm,
                ..*piece
            });
            let end_mm = piece.start_mm + piece.primitive.length_mm();
            if stops.next_if(|&&stop| stop <= end_mm + 1e-9).is_some() {
                sections.push(Path::new(
                    std::mem::take(&mut pieces),
                    vec![end_mm - base_mm],
                ));
                base_mm = end_mm;
            }
        }
        sections
    }

    /// Distance along it of its point nearest to `p`, mm (the first such point where several are
    /// as near).
    #[must_use]
    pub fn nearest_mm(&self, p: &Vector3<f64>) -> f64 {
        self.pieces
            .iter()
            .map(|piece| {
                let into = piece.primitive.nearest_mm(p);
                let d = (piece.primitive.at(into).position_mm - p).norm();
                (d, piece.start_mm + into)
            })
            .fold(
                (f64::INFINITY, 0.0),
                |best, c| if c.0 < best.0 { c } else { best },
            )
            .1
    }

    /// The largest curvature of any piece, 1/mm (0 for lines only).
    #[must_use]
    pub fn max_curvature_per_mm(&self) -> f64 {
        self.pieces
            .iter()
            .map(|p| p.primitive.curvature_per_mm())
            .fold(0.0, f64::max)
    }

    /// The piece holding distance `s_mm` and the distance into it.
    fn locate(&self, s_mm: f64) -> (&Piece, f64) {
        let i = self
            .pieces
            .partition_point(|p| p.start_mm <= s_mm)
            .saturating_sub(1);
        let piece = &self.pieces[i];
        (piece, s_mm - piece.start_mm)
    }

    /// The pose at distance `s_mm` along it (clamped to its ends).
    #[must_use]
    pub fn at(&self, s_mm: f64) -> Pose {
        if s_mm >= self.length_mm() {
            return self.pieces[self.pieces.len() - 1].primitive.to();
        }
        let (piece, into) = self.locate(s_mm.max(0.0));
        piece.primitive.at(into)
    }

    /// A position within the returned distance (mm) of [`Self::at`]'s at `s_mm`, made without a
    /// root or a division, on a line piece strictly inside the path (`None` elsewhere: an arc,
    /// an end). `hint` is the piece the last call found, looked at first.
    #[must_use]
    // Always inlined into the measurement's loop over pulses (out of line since the loop has a
    // copy for arms with a tool offset, the seed's lines planned 5 to 9 % slower).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn near(&self, s_mm: f64, hint: &mut usize) -> Option<(Vector3<f64>, f64)> {
        let holds = |i: usize| {
            self.pieces.get(i).is_some_and(|p| p.start_mm <= s_mm)
                && self
                    .pieces
                    .get(i + 1)
                    .is_none_or(|next| s_mm < next.start_mm)
        };
        if !holds(*hint) {
            *hint = self
                .pieces
                .partition_point(|p| p.start_mm <= s_mm)
                .saturating_sub(1);
        }
        let line = self.lines.get(*hint)?.as_ref()?;
        let piece = &self.pieces[*hint];
        if !(s_mm > 0.0 && s_mm >= piece.start_mm && s_mm < line.end_mm) {
            return None;
        }
        let into = s_mm - piece.start_mm;
        Some((line.from + line.d * (into * line.per_mm), line.off_mm))
    }

    /// The unit direction of travel at distance `s_mm`.
    #[must_use]
    pub fn direction(&self, s_mm: f64) -> Vector3<f64> {
        let (piece, into) = self.locate(s_mm.clamp(0.0, self.length_mm()));
        piece.primitive.direction(into)
    }

    /// The curvature at distance `s_mm`, 1/mm.
    #[must_use]
    pub fn curvature_per_mm(&self, s_mm: f64) -> f64 {
        self.locate(s_mm.clamp(0.0, self.length_mm()))
            .0
            .primitive
            .curvature_per_mm()
    }
}

impl From<Line> for Path {
    /// A line as a path of one piece (element 1), stopped at its end.
    fn from(line: Line) -> Self {
        Self::new(
            vec![Piece {
                primitive: Primitive::Line(line),
                start_mm: 0.0,
                element: Some(1),
                waypoint: None,
            }],
            vec![line.length_mm()],
        )
    }
}

impl ToolPath for Path {
    /// The smallest distance to any piece; only the pieces that could be the nearest are
    /// measured.
    fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        self.bounds.nearest(&self.pieces, p).0
    }

    fn distance_beyond_mm(&self, p: &Vector3<f64>, floor_mm: f64, hint: &mut usize) -> Option<f64> {
        if let Some(piece) = self.pieces.get(*hint) {
            let within = match &self.lines[*hint] {
                Some(line) if line.distance.surely_within(p, floor_mm) => true,
                _ => piece.primitive.distance_mm(p) <= floor_mm,
            };
            if within {
                // The path is at least as near as that piece.
                return None;
            }
        }
        let (d, nearest) = self.bounds.nearest(&self.pieces, p);
        *hint = nearest;
        (d > floor_mm).then_some(d)
    }

    fn end_mm(&self) -> Vector3<f64> {
        self.pieces[self.pieces.len() - 1]
            .primitive
            .to()
            .position_mm
    }
}

/// How the path passes a waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Pass {
    /// It comes to rest there.
    Stop,
    /// Its neighbours meet in line (a blend asked there has nothing to round).
    Straight,
    /// A corner arc and how far it reaches along its neighbours.
    Blend(Fillet),
}

/// How the path passes `waypoint`, between primitives `a` and `b`, asked for `corner`.
fn pass(waypoint: usize, corner: Corner, a: &Primitive, b: &Primitive) -> Result<Pass, PathError> {
    let Corner::Blend(r) = corner else {
        return Ok(Pass::Stop);
    };
    if !(r.is_finite() && r > 0.0) {
        return Err(PathError::BlendRadius {
            waypoint,
            radius_mm: r,
        });
    }
    let t_in = a.direction(a.length_mm());
    let t_out = b.direction(0.0);
    let turn_rad = t_in.dot(&t_out).clamp(-1.0, 1.0).acos();
    if turn_rad <= STRAIGHT_RAD {
        return Ok(Pass::Straight);
    }
    if turn_rad >= REVERSAL_RAD {
        return Err(PathError::Reversal {
            waypoint,
            turn_deg: turn_rad.to_degrees(),
        });
    }
    let reach = |p: &Primitive| r.min(p.length_mm() / 2.0);
    match fillet(a, b, turn_rad, reach(a), reach(b)) {
        Ok(f) => Ok(Pass::Blend(f)),
        Err(NoFillet::OffPlane { off_rad }) => Err(PathError::BlendOffPlane {
            waypoint,
            // The line leaves the arc's plane; of two arcs, the second leaves the first's.
            element: if matches!(a, Primitive::Line(_)) {
                waypoint
            } else {
                waypoint + 1
            },
            off_deg: off_rad.to_degrees(),
            max_deg: fillet::COPLANAR_RAD.to_degrees(),
        }),
        Err(NoFillet::NoCircle) => Err(PathError::BlendNoArc {
            waypoint,
            radius_mm: r,
        }),
    }
}

/// Element `n`'s primitive from `from`.
fn primitive(n: usize, from: Pose, element: &Element) -> Result<Primitive, PathError> {
    let to = element.to();
    let full_circle = matches!(
        element,
        Element::Arc {
            by: ArcBy::Centre { .. },
            ..
        }
    );
    if !full_circle && (to.position_mm - from.position_mm).norm() <= 1e-9 {
        let p = to.position_mm;
        return Err(PathError::NoLength {
            element: n,
            x: p.x,
            y: p.y,
            z: p.z,
        });
    }
    match *element {
        Element::Line { to } => Ok(Primitive::Line(Line { from, to })),
        Element::Arc { to, by } => {
            let arc = match by {
                ArcBy::Via(via) => Arc::through(from, via, to),
                ArcBy::Centre {
                    centre_mm,
                    axis,
                    clockwise,
                } => Arc::centred(from, to, centre_mm, axis, clockwise),
            };
            arc.map(Primitive::Arc).map_err(|fault| PathError::Arc {
                element: n,
                reason: describe(&fault),
            })
        }
    }
}

/// An arc fault in words.
fn describe(fault: &ArcFault) -> String {
    match fault {
        ArcFault::TooClose { points, gap_mm } => format!(
            "{points} are {gap_mm:.3} mm apart; an arc's points must be at least \
             {ARC_MIN_GAP_MM} mm apart"
        ),
        ArcFault::Flat { off_mm, chord_mm } => format!(
            "the start, the via point and the end lie on one line, or nearly: the via point is \
             {off_mm:.3} mm off the line through the ends, {chord_mm:.3} mm apart; at least \
             {:.3} mm ({ARC_MIN_BULGE} of the chord)",
            ARC_MIN_BULGE * chord_mm
        ),
        ArcFault::Radii { from_mm, to_mm } => format!(
            "the start is {from_mm:.3} mm from the centre and the end {to_mm:.3} mm; they must \
             be within {RADIUS_SLACK_MM} mm of one radius"
        ),
        ArcFault::OffPlane { off_mm } => format!(
            "an end is {off_mm:.3} mm off the arc's plane (through the centre, square to the \
             axis); at most {RADIUS_SLACK_MM} mm"
        ),
        ArcFault::NoRadius { radius_mm } => {
            format!("the start is {radius_mm:.3} mm from the centre; at least {ARC_MIN_GAP_MM} mm")
        }
        ArcFault::EndsNear { gap_mm } => format!(
            "the end is {gap_mm:.3} mm from the start: on it (a full circle) or at least \
             {ARC_MIN_GAP_MM} mm away"
        ),
    }
}

#[cfg(test)]
mod tests;
