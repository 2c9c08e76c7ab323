//! PURE. A blend's corner arc: the circle tangent to both neighbours of a waypoint, as large as
//! the blend's reach along each of them allows.
//!
//! Between two lines it has a closed form: radius `reach / tan(turn / 2)`, reaching as far
//! along both. Next to an arc it is found from its radius `ρ`, as a CAD fillet is: its centre
//! lies `ρ` from a line, on the corner's inner side, and `R - ρ` or `R + ρ` from an arc's centre
//! (`-` where the arc curves towards the inside of the corner), so it is where the two offsets
//! cross; it touches each neighbour at the foot of its centre. The largest `ρ` whose touching
//! points lie within the reach allowed on both sides is found by bisection. A circle tangent to
//! both exists only where they share a plane: a line in the arc's plane, two arcs in one plane.

use nalgebra::{Vector2, Vector3};

use super::{Arc, Primitive};

/// How far a line or an arc's plane may lean out of the other neighbour's plane and still be
/// taken as in it, radians.
pub(super) const COPLANAR_RAD: f64 = 1e-6;

/// Bisection steps on the radius: its bracket shrinks to 2^-80 of itself.
const BISECTIONS: usize = 80;

/// How far the corner arc as built may be from the circle found (its centre, its end), mm.
const FIT_MM: f64 = 1e-6;

/// The largest corner circle, mm. Where the neighbours have a common tangent across the
/// corner (two arcs curving the same way), circles of any size touch both; one of 100 m is
/// straight to well under a micrometre over a blend.
const MAX_RADIUS_MM: f64 = 1e5;

/// The most a corner arc may turn, radians: short of a half turn, where its direction at the
/// end no longer tells which way round it goes.
const MAX_TURN_RAD: f64 = std::f64::consts::PI - 1e-3;

/// A corner arc and how far it reaches along each neighbour from the waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Fillet {
    /// Along the element before, back from the waypoint, mm.
    pub reach_in_mm: f64,
    /// Along the element after, on from the waypoint, mm.
    pub reach_out_mm: f64,
    /// The arc from one touching point to the other.
    pub corner: Arc,
}

/// Why no corner arc joins two neighbours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum NoFillet {
    /// They lie in different planes; the angle between them, radians.
    OffPlane { off_rad: f64 },
    /// No circle tangent to both touches them within the reaches allowed.
    NoCircle,
}

/// The corner arc between `a` and `b` (`b` starting where `a` ends, turning `turn_rad` there),
/// reaching at most `reach_in_mm` back along `a` and `reach_out_mm` on along `b`.
pub(super) fn fillet(
    a: &Primitive,
    b: &Primitive,
    turn_rad: f64,
    reach_in_mm: f64,
    reach_out_mm: f64,
) -> Result<Fillet, NoFillet> {
    let len_a = a.length_mm();
    if let (Primitive::Line(_), Primitive::Line(_)) = (a, b) {
        return Ok(between_lines(a, b, turn_rad, reach_in_mm.min(reach_out_mm)));
    }
    let plane = Plane::of(a, b)?;
    let t_in = plane.dir(&a.direction(len_a));
    let t_out = plane.dir(&b.direction(0.0));
    let mut corner = Corner {
        a: Curve::of(a, &plane, (t_out - t_in * t_out.dot(&t_in)).normalize()),
        b: Curve::of(b, &plane, (t_out * t_in.dot(&t_out) - t_in).normalize()),
        branch: 0,
        reach_in_mm,
        reach_out_mm,
    };
    let guess = reach_in_mm.max(reach_out_mm) / (turn_rad / 2.0).tan();
    // A circle a millionth of the guess is in the corner as between two lines: its centre
    // on the bisector. Of the two offsets' crossings, that one's stays the corner's as it grows.
    let tiny = guess * 1e-6;
    let centre = (t_out - t_in).normalize() * (tiny / (turn_rad / 2.0).cos());
    corner.branch = corner
        .branch_near(tiny, &centre)
        .ok_or(NoFillet::NoCircle)?;
    let radius = corner.largest(guess)?;
    halved_until_it_fits(a, b, &plane, &corner, radius)
}

/// The corner arc between two lines: it reaches `reach` mm along both.
fn between_lines(a: &Primitive, b: &Primitive, turn_rad: f64, reach: f64) -> Fillet {
    let len_a = a.length_mm();
    Fillet {
        reach_in_mm: reach,
        reach_out_mm: reach,
        corner: Arc::tangent(
            a.at(len_a - reach),
            b.at(reach),
            a.direction(len_a),
            b.direction(0.0),
            reach / (turn_rad / 2.0).tan(),
        ),
    }
}

/// The arc of `corner` of the largest `radius`, built and checked. Where circles of every size
/// up to the largest touch both (a line nearly tangent to an arc curving back across it), the
/// largest is found far off, where the offsets' crossing has lost the digits the arc as built
/// needs: it is halved until the arc fits.
fn halved_until_it_fits(
    a: &Primitive,
    b: &Primitive,
    plane: &Plane,
    corner: &Corner,
    mut radius: f64,
) -> Result<Fillet, NoFillet> {
    let len_a = a.length_mm();
    for _ in 0..=HALVINGS {
        let (centre, reach_in, reach_out) = corner.at(radius).ok_or(NoFillet::NoCircle)?;
        let arc = Arc::tangent(
            a.at(len_a - reach_in),
            b.at(reach_out),
            a.direction(len_a - reach_in),
            b.direction(reach_out),
            radius,
        );
        // The centre's own rounding grows with the radius.
        let fits = (arc.centre_mm - plane.point(&centre)).norm() <= FIT_MM * (1.0 + radius * 1e-3)
            && arc.end_gap_mm() <= FIT_MM
            && arc.sweep_rad <= MAX_TURN_RAD + 1e-9;
        if fits {
            return Ok(Fillet {
                reach_in_mm: reach_in,
                reach_out_mm: reach_out,
                corner: arc,
            });
        }
        radius /= 2.0;
    }
    Err(NoFillet::NoCircle)
}

/// How many times the radius found is halved for an arc that fits ([`fillet`]): from the
/// largest corner circle to about 1 m.
const HALVINGS: usize = 7;

/// The plane both neighbours lie in, as coordinates about the waypoint.
struct Plane {
    origin: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    normal: Vector3<f64>,
}

impl Plane {
    /// The plane of the arc among `a` and `b`, if the other lies in it.
    fn of(a: &Primitive, b: &Primitive) -> Result<Self, NoFillet> {
        let normal = match (a, b) {
            (Primitive::Arc(arc), _) | (_, Primitive::Arc(arc)) => arc.normal(),
            (Primitive::Line(_), Primitive::Line(_)) => {
                unreachable!("two lines have a closed form")
            }
        };
        let off_rad = match (a, b) {
            (Primitive::Arc(p), Primitive::Arc(q)) => p.normal().cross(&q.normal()).norm().asin(),
            (Primitive::Line(_), _) => a.direction(0.0).dot(&normal).abs().asin(),
            (_, Primitive::Line(_)) => b.direction(0.0).dot(&normal).abs().asin(),
        };
        if off_rad.is_nan() || off_rad > COPLANAR_RAD {
            return Err(NoFillet::OffPlane { off_rad });
        }
        let t_in = a.direction(a.length_mm());
        let e1 = (t_in - normal * t_in.dot(&normal)).normalize();
        Ok(Self {
            origin: a.to().position_mm,
            e1,
            e2: normal.cross(&e1),
            normal,
        })
    }

    fn coords(&self, p: &Vector3<f64>) -> Vector2<f64> {
        let d = p - self.origin;
        Vector2::new(d.dot(&self.e1), d.dot(&self.e2))
    }

    fn dir(&self, d: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(d.dot(&self.e1), d.dot(&self.e2)).normalize()
    }

    fn point(&self, p: &Vector2<f64>) -> Vector3<f64> {
        self.origin + self.e1 * p.x + self.e2 * p.y
    }
}

/// A neighbour near the waypoint (the origin), in the plane's coordinates, with its normal
/// towards the inside of the corner there.
#[derive(Debug, Clone, Copy)]
enum Curve {
    /// A line through the origin along `dir` (the direction of travel).
    Line {
        dir: Vector2<f64>,
        inner: Vector2<f64>,
    },
    /// A circle; `ccw` when travel along it turns counter-clockwise in the plane.
    Circle {
        centre: Vector2<f64>,
        radius: f64,
        ccw: bool,
        inner: Vector2<f64>,
    },
}

impl Curve {
    fn of(p: &Primitive, plane: &Plane, inner: Vector2<f64>) -> Self {
        match p {
            Primitive::Line(_) => Self::Line {
                dir: plane.dir(&p.direction(0.0)),
                inner,
            },
            Primitive::Arc(arc) => Self::Circle {
                centre: plane.coords(&arc.centre_mm),
                radius: arc.radius_mm,
                ccw: arc.normal().dot(&plane.normal) > 0.0,
                inner,
            },
        }
    }

    /// Where a circle of `radius` tangent to it on the corner's inner side has its centre.
    fn offset(&self, radius: f64) -> Option<Offset> {
        match *self {
            Self::Line { dir, inner } => Some(Offset::Line {
                point: inner * radius,
                dir,
            }),
            Self::Circle {
                centre,
                radius: r,
                inner,
                ..
            } => {
                // The arc curving towards the inside holds the corner circle within its own.
                let inside = centre.dot(&inner) > 0.0;
                let at = if inside { r - radius } else { r + radius };
                (at > 0.0).then_some(Offset::Circle { centre, radius: at })
            }
        }
    }

    /// Where a circle centred at `c` touches it, and its direction of travel there.
    fn touch(&self, c: &Vector2<f64>) -> (Vector2<f64>, Vector2<f64>) {
        match *self {
            Self::Line { dir, .. } => (dir * c.dot(&dir), dir),
            Self::Circle {
                centre,
                radius,
                ccw,
                ..
            } => {
                let out = (c - centre).normalize();
                let left = Vector2::new(-out.y, out.x);
                (centre + out * radius, if ccw { left } else { -left })
            }
        }
    }

    /// How far along it from the waypoint a circle centred at `c` touches it: back from it when
    /// `before`, on from it otherwise (`None` where the touching point is on the other side).
    fn reach(&self, c: &Vector2<f64>, before: bool) -> Option<f64> {
        let reach = match *self {
            Self::Line { dir, .. } => {
                let along = c.dot(&dir);
                if before { -along } else { along }
            }
            Self::Circle {
                centre,
                radius,
                ccw,
                ..
            } => {
                let touch = (c - centre).normalize();
                let waypoint = -centre.normalize();
                let (from, to) = if before {
                    (touch, waypoint)
                } else {
                    (waypoint, touch)
                };
                let turn = from.perp(&to).atan2(from.dot(&to));
                radius * if ccw { turn } else { -turn }
            }
        };
        (reach > 0.0).then_some(reach)
    }
}

/// Where the centres of the circles of one radius tangent to a neighbour lie.
#[derive(Debug, Clone, Copy)]
enum Offset {
    Line {
        point: Vector2<f64>,
        dir: Vector2<f64>,
    },
    Circle {
        centre: Vector2<f64>,
        radius: f64,
    },
}

impl Offset {
    /// Where two offsets cross (none, one or two points).
    fn cross(&self, other: &Self) -> Vec<Vector2<f64>> {
        match (*self, *other) {
            (Self::Line { point, dir }, Self::Circle { centre, radius })
            | (Self::Circle { centre, radius }, Self::Line { point, dir }) => {
                // |point + t dir - centre| = radius, dir a unit vector.
                let w = point - centre;
                let half_b = w.dot(&dir);
                let disc = half_b * half_b - (w.norm_squared() - radius * radius);
                if disc < 0.0 {
                    return Vec::new();
                }
                let root = disc.sqrt();
                vec![
                    point + dir * (-half_b - root),
                    point + dir * (-half_b + root),
                ]
            }
            (
                Self::Circle {
                    centre: c1,
                    radius: r1,
                },
                Self::Circle {
                    centre: c2,
                    radius: r2,
                },
            ) => {
                let d = (c2 - c1).norm();
                if d <= 0.0 || d > r1 + r2 || d < (r1 - r2).abs() {
                    return Vec::new();
                }
                let along = (d * d + r1 * r1 - r2 * r2) / (2.0 * d);
                let across = (r1 * r1 - along * along).max(0.0).sqrt();
                let u = (c2 - c1) / d;
                let mid = c1 + u * along;
                let side = Vector2::new(-u.y, u.x);
                vec![mid + side * across, mid - side * across]
            }
            (Self::Line { .. }, Self::Line { .. }) => Vec::new(),
        }
    }
}

/// A corner next to an arc, in the plane's coordinates.
struct Corner {
    a: Curve,
    b: Curve,
    /// Which of the offsets' two crossings (in [`Offset::cross`]'s order) is the corner's.
    branch: usize,
    reach_in_mm: f64,
    reach_out_mm: f64,
}

impl Corner {
    /// The centre of the corner circle of `radius`, and its reaches back along `a` and on
    /// along `b`, if both are within what is allowed.
    fn at(&self, radius: f64) -> Option<(Vector2<f64>, f64, f64)> {
        let centre = *self.crossings(radius).get(self.branch)?;
        let reach_in = self.a.reach(&centre, true)?;
        let reach_out = self.b.reach(&centre, false)?;
        let within = reach_in <= self.reach_in_mm && reach_out <= self.reach_out_mm;
        (within && Self::rounds(&centre, self.a.touch(&centre), self.b.touch(&centre)))
            .then_some((centre, reach_in, reach_out))
    }

    /// Whether the circle about `c` through touching points `p` and `q` (each with the
    /// neighbour's direction of travel there) runs from one to the other as a corner arc: it
    /// leaves `p` along `a`'s direction, arrives at `q` along `b`'s, and turns less than
    /// [`MAX_TURN_RAD`] on the way.
    fn rounds(
        c: &Vector2<f64>,
        (p, tp): (Vector2<f64>, Vector2<f64>),
        (q, tq): (Vector2<f64>, Vector2<f64>),
    ) -> bool {
        let turn = tp.perp(&tq).atan2(tp.dot(&tq));
        // Left about the centre (counter-clockwise) or right.
        let left = tp.perp(&(c - p)) > 0.0;
        let r = q - c;
        let along = if left {
            Vector2::new(-r.y, r.x)
        } else {
            Vector2::new(r.y, -r.x)
        };
        (turn > 0.0) == left && turn.abs() < MAX_TURN_RAD && along.normalize().dot(&tq) > 1.0 - 1e-9
    }

    /// Where the centres of circles of `radius` tangent to both neighbours lie.
    fn crossings(&self, radius: f64) -> Vec<Vector2<f64>> {
        match (self.a.offset(radius), self.b.offset(radius)) {
            (Some(oa), Some(ob)) => oa.cross(&ob),
            _ => Vec::new(),
        }
    }

    /// Which crossing for circles of `radius` lies nearest to `centre`.
    fn branch_near(&self, radius: f64, centre: &Vector2<f64>) -> Option<usize> {
        self.crossings(radius)
            .iter()
            .map(|c| (c - centre).norm_squared())
            .enumerate()
            .min_by(|p, q| p.1.total_cmp(&q.1))
            .map(|(i, _)| i)
    }

    /// The largest radius a corner circle may have, searched about `guess` (the radius two lines
    /// would take).
    fn largest(&self, guess: f64) -> Result<f64, NoFillet> {
        let mut hi = (2.0 * guess).min(MAX_RADIUS_MM);
        while self.at(hi).is_some() {
            if hi >= MAX_RADIUS_MM {
                return Ok(hi);
            }
            hi = (2.0 * hi).min(MAX_RADIUS_MM);
        }
        let mut lo = guess.min(hi / 2.0);
        let mut tries = 0;
        while self.at(lo).is_none() {
            lo /= 4.0;
            tries += 1;
            if tries > 40 {
                return Err(NoFillet::NoCircle);
            }
        }
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if self.at(mid).is_some() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(lo)
    }
}
