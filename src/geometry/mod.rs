//! PURE. Poses, the straight line between two poses, paths of lines and arcs through waypoints
//! (corners blended or stopped at), the polyline of a curved tool path, the motion profile
//! along a path, and the pace at which a path's profile slows for its tight arcs.

mod pace;
mod path;
mod polyline;
mod profile;
pub mod topp;

pub use pace::{Pace, SpeedCap};
pub use path::{
    ARC_MIN_BULGE, ARC_MIN_GAP_MM, Arc, ArcBy, ArcFault, Corner, Element, Path, PathError,
    PathSpec, Piece, Primitive, RADIUS_SLACK_MM,
};
pub use polyline::Polyline;
pub use profile::{Profile, ProfileError, ProfileRequest};

use nalgebra::Vector3;

/// A number as a message shows it: `decimals` places when it is of a size a person writes
/// (1e-4 to 1e9), else in exponent form (`1e308` is not written out in 309 digits).
#[must_use]
pub fn shown(value: f64, decimals: usize) -> String {
    if value.is_finite() && value != 0.0 && !(1e-4..1e9).contains(&value.abs()) {
        format!("{value:e}")
    } else {
        format!("{value:.decimals$}")
    }
}

/// A tool pose in the base frame: position in mm and a tool angle about z in radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position, mm.
    pub position_mm: Vector3<f64>,
    /// Tool angle about z, radians.
    pub a_rad: f64,
}

impl Pose {
    /// A pose from x, y, z in mm and the tool angle in degrees (the user's units).
    #[must_use]
    pub fn from_mm_deg(x: f64, y: f64, z: f64, a_deg: f64) -> Self {
        Self {
            position_mm: Vector3::new(x, y, z),
            a_rad: a_deg.to_radians(),
        }
    }

    /// `[x, y, z, a_deg]`, the user's units.
    #[must_use]
    pub fn to_mm_deg(&self) -> [f64; 4] {
        let p = self.position_mm;
        [p.x, p.y, p.z, self.a_rad.to_degrees()]
    }
}

/// A planned path of the tool point, as the accuracy figures measure an executed move against it.
pub trait ToolPath {
    /// Distance from a point to the path, mm.
    fn distance_mm(&self, p: &Vector3<f64>) -> f64;

    /// Where the path ends, mm.
    fn end_mm(&self) -> Vector3<f64>;

    /// The distance from `p` to the path when it is more than `floor_mm` (`None` when it is
    /// not), mm: what a running maximum needs. `hint` is the path's own note of where it found
    /// the last point nearest (0 to begin with): a path of many pieces measures that piece
    /// first, and a point within `floor_mm` of it is done.
    fn distance_beyond_mm(&self, p: &Vector3<f64>, floor_mm: f64, hint: &mut usize) -> Option<f64> {
        let _ = hint;
        let d = self.distance_mm(p);
        (d > floor_mm).then_some(d)
    }

    /// A new measurement begins (at the path's start): forget where the last one was.
    fn restart(&self) {}

    /// The path as one straight segment, when it is one (measurements then take the faster
    /// [`LineDistance`]).
    fn as_line(&self) -> Option<&Line> {
        None
    }
}

/// Distances from many points to one segment, its direction and squared length computed once:
/// the same arithmetic as [`Line::distance_mm`], so the same values (squared).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineDistance {
    from: Vector3<f64>,
    d: Vector3<f64>,
    len2: f64,
    /// A bound of how far a distance computed to the segment (its foot point rounded, and
    /// `p - from`) may be from the point's true distance, mm: sixteen roundings of the largest
    /// coordinates involved.
    round_mm: f64,
}

impl LineDistance {
    /// For the segment P1P2 of `line`.
    #[must_use]
    pub fn new(line: &Line) -> Self {
        let from = line.from.position_mm;
        let d = line.to.position_mm - from;
        Self {
            from,
            d,
            len2: d.norm_squared(),
            round_mm: 16.0 * f64::EPSILON * (from.norm() + d.norm()),
        }
    }

    /// What a point's `|w|² len² - (w.d)²` (its squared distance to the line times the squared
    /// length, `w = p - from`) must stay within for [`Self::squared_mm2`] to be surely at most
    /// `limit_mm` squared: the limit less the distance's roundings ([`Self::round_mm`]), squared,
    /// times the squared length, less a share for the products' roundings. No point is clear of
    /// a limit within the roundings.
    #[must_use]
    pub fn clear(&self, limit_mm: f64) -> f64 {
        let limit = limit_mm - self.round_mm;
        if limit > 0.0 {
            limit * limit * self.len2 * (1.0 - 1e-12)
        } else {
            f64::NEG_INFINITY
        }
    }

    /// Whether `p` is surely clear ([`Self::clear`]): judged without a division or a root, when
    /// its projection falls inside the segment, with a margin of eight roundings of the terms
    /// that cancel in `|w|² len² - (w.d)²`; `false` when it cannot tell.
    #[inline]
    fn surely_clear(&self, p: &Vector3<f64>, clear: f64) -> bool {
        let w = p - self.from;
        let dot = w.dot(&self.d);
        if self.len2 > 0.0 && dot >= 0.0 && dot <= self.len2 {
            let whole = w.norm_squared() * self.len2;
            let margin = 8.0 * f64::EPSILON * whole;
            return whole - dot * dot + margin <= clear;
        }
        false
    }

    /// The squared distance from `p` to the segment when it may be more than `floor_mm2`
    /// (`None` when it is surely not), mm²: the same value as [`Self::squared_mm2`]. `clear` is
    /// [`Self::clear`] of the root of `floor_mm2` (made once per floor): a point surely clear of
    /// it is not measured.
    #[must_use]
    #[inline]
    pub fn squared_beyond_mm2(&self, p: &Vector3<f64>, floor_mm2: f64, clear: f64) -> Option<f64> {
        if self.surely_clear(p, clear) {
            return None;
        }
        let d2 = self.squared_mm2(p);
        (d2 > floor_mm2).then_some(d2)
    }

    /// Whether `Line::distance_mm(p)` is surely at most `limit_mm` ([`Self::clear`]), judged
    /// without a division or a root; `false` when it cannot tell.
    #[must_use]
    #[inline]
    pub fn surely_within(&self, p: &Vector3<f64>, limit_mm: f64) -> bool {
        self.surely_clear(p, self.clear(limit_mm))
    }

    /// The squared distance from `p` to the segment, mm²: `Line::distance_mm(p)` is its
    /// square root, bit for bit.
    #[must_use]
    #[inline]
    pub fn squared_mm2(&self, p: &Vector3<f64>) -> f64 {
        let u = if self.len2 > 0.0 {
            ((p - self.from).dot(&self.d) / self.len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (self.from + self.d * u)).norm_squared()
    }
}

/// The straight line from one pose to another; the tool angle goes linearly with distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Start pose (P1).
    pub from: Pose,
    /// End pose (P2).
    pub to: Pose,
}

impl Line {
    /// Length of the line in mm (eq. 1).
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        (self.to.position_mm - self.from.position_mm).norm()
    }

    /// The pose at distance `s_mm` from P1 (eq. 7), the tool angle in proportion.
    #[must_use]
    pub fn at(&self, s_mm: f64) -> Pose {
        let len = self.length_mm();
        let u = if len > 0.0 { s_mm / len } else { 1.0 };
        Pose {
            position_mm: self.from.position_mm + (self.to.position_mm - self.from.position_mm) * u,
            a_rad: self.from.a_rad + (self.to.a_rad - self.from.a_rad) * u,
        }
    }

    /// Distance from a point to the segment P1P2, mm.
    #[must_use]
    pub fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        let d = self.to.position_mm - self.from.position_mm;
        let len2 = d.norm_squared();
        let u = if len2 > 0.0 {
            ((p - self.from.position_mm).dot(&d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (self.from.position_mm + d * u)).norm()
    }

    /// The smallest and largest distance of the segment's projection on the xy plane from the z
    /// axis, mm (where kinematics with a vertical axis meet their singularities and reach limits).
    #[must_use]
    pub fn xy_radius_range_mm(&self) -> (f64, f64) {
        let a = self.from.position_mm.xy();
        let b = self.to.position_mm.xy();
        let d = b - a;
        let len2 = d.norm_squared();
        let u = if len2 > 0.0 {
            (-a.dot(&d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let nearest = (a + d * u).norm();
        (nearest, a.norm().max(b.norm()))
    }
}

impl ToolPath for Line {
    fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        Line::distance_mm(self, p)
    }

    fn end_mm(&self) -> Vector3<f64> {
        self.to.position_mm
    }

    fn as_line(&self) -> Option<&Line> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_surely_within_a_limit_of_a_line_is_within_it_by_its_distance() {
        // The seed's line, points scattered about it (a fixed generator), and limits at the
        // point's own distance give or take a few roundings: where rounding could fool it.
        let line = Line {
            from: Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0),
            to: Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0),
        };
        let near = LineDistance::new(&line);
        let mut next = crate::testing::uniform(0x2545_f491_4f6c_dd1d);
        let mut said = 0;
        for _ in 0..200_000 {
            let along = line.at(next() * line.length_mm()).position_mm;
            let off = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 0.2;
            let p = along + off;
            let d = line.distance_mm(&p);
            for limit in [d, d.next_up(), d.next_down(), d * (1.0 + 1e-9), d * 1.001] {
                if near.surely_within(&p, limit) {
                    assert!(d <= limit, "{p:?}: {d} > {limit}");
                    said += 1;
                }
            }
        }
        // It does say so, for most points and limits (never wrongly: above).
        assert!(said > 200_000, "{said}");
    }

    #[test]
    fn line_interpolates_position_and_angle() {
        let line = Line {
            from: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            to: Pose::from_mm_deg(30.0, 40.0, 0.0, 90.0),
        };
        assert!((line.length_mm() - 50.0).abs() < 1e-12);
        let mid = line.at(25.0);
        assert!((mid.position_mm - Vector3::new(15.0, 20.0, 0.0)).norm() < 1e-12);
        assert!((mid.a_rad - 45f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn distance_to_segment_uses_the_end_points_beyond_them() {
        let line = Line {
            from: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            to: Pose::from_mm_deg(10.0, 0.0, 0.0, 0.0),
        };
        assert!((line.distance_mm(&Vector3::new(5.0, 3.0, 0.0)) - 3.0).abs() < 1e-12);
        assert!((line.distance_mm(&Vector3::new(13.0, 4.0, 0.0)) - 5.0).abs() < 1e-12);
    }

    #[test]
    #[allow(clippy::float_cmp)] // bit for bit is the point
    fn line_distance_is_the_square_of_distance_mm_bit_for_bit() {
        let line = Line {
            from: Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0),
            to: Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0),
        };
        let fast = LineDistance::new(&line);
        for i in 0..200 {
            let k = f64::from(i);
            let p = Vector3::new(
                -900.0 - 1.3 * k,
                530.0 + 0.7 * k,
                40.0 + 0.9 * (k * 0.37).sin(),
            );
            assert_eq!(fast.squared_mm2(&p).sqrt(), line.distance_mm(&p));
        }
    }

    #[test]
    fn xy_radius_range_finds_the_closest_approach_inside_the_segment() {
        let line = Line {
            from: Pose::from_mm_deg(-100.0, 60.0, 0.0, 0.0),
            to: Pose::from_mm_deg(100.0, 60.0, 5.0, 0.0),
        };
        let (near, far) = line.xy_radius_range_mm();
        assert!((near - 60.0).abs() < 1e-12);
        assert!((far - 116.619_037_896_906).abs() < 1e-9);
    }
}
