//! A circular arc of the tool point, in any plane, with the tool angle going linearly with
//! distance along it.
//!
//! The arc is kept as its centre, radius and an orthonormal pair in its plane: `u` points from
//! the centre to the start, `v` is the direction of travel at the start. The point at angle
//! `θ` (0 to `sweep`) is `centre + r (u cos θ + v sin θ)`.

use std::f64::consts::TAU;

use nalgebra::Vector3;

use crate::geometry::Pose;

/// A circular arc from `from` to `to` about `centre`, turning `sweep_rad` (up to a full circle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    /// Start pose.
    pub from: Pose,
    /// End pose.
    pub to: Pose,
    /// Centre, mm.
    pub centre_mm: Vector3<f64>,
    /// Radius, mm.
    pub radius_mm: f64,
    /// Angle turned, radians (above 0, at most a full turn).
    pub sweep_rad: f64,
    /// Unit vector from the centre to the start.
    u: Vector3<f64>,
    /// Unit direction of travel at the start.
    v: Vector3<f64>,
}

/// Why three points or a centre give no arc, or one too ill-conditioned to run: the one rule
/// `plan --path` and the daemon both apply ([`Arc::through`], [`Arc::centred`]).
#[derive(Debug, Clone, PartialEq)]
pub enum ArcFault {
    /// Two of the arc's defining points lie closer than [`ARC_MIN_GAP_MM`].
    TooClose {
        /// The two points, as the message names them (`"the via point and the start"`).
        points: &'static str,
        /// Their distance, mm.
        gap_mm: f64,
    },
    /// The via point lies within [`ARC_MIN_BULGE`] of the chord's length from the line through
    /// the start and the end: no circle, or one whose centre a small error swings far.
    Flat {
        /// The via point's distance from that line, mm.
        off_mm: f64,
        /// The chord from the start to the end, mm.
        chord_mm: f64,
    },
    /// The start and end lie at different distances from the centre.
    Radii {
        /// Start's distance from the centre, mm.
        from_mm: f64,
        /// End's distance from the centre, mm.
        to_mm: f64,
    },
    /// A point is off the plane through the centre square to the axis.
    OffPlane {
        /// Its distance from that plane, mm.
        off_mm: f64,
    },
    /// The start is within [`ARC_MIN_GAP_MM`] of the centre.
    NoRadius {
        /// The start's distance from the centre, mm.
        radius_mm: f64,
    },
    /// The end of an arc about a centre is within [`ARC_MIN_GAP_MM`] of its start without
    /// being on it (on it: a full circle), so the arc would be a sliver or nearly a whole turn.
    EndsNear {
        /// Their distance, mm.
        gap_mm: f64,
    },
}

/// How far apart two distances from the centre may be and still be one radius, mm.
pub const RADIUS_SLACK_MM: f64 = 0.01;

/// The least distance between two of the points that define an arc (its start, via point and
/// end; its start and its centre), mm. Closer, an error of a fraction of a millimetre in one of
/// them (a typing slip, the robot's pose rounded to whole pulses) swings the circle.
pub const ARC_MIN_GAP_MM: f64 = 0.5;

/// The least distance of an arc's via point from the line through its start and end, as a share
/// of the chord from the start to the end (the circle's radius is then at most about 500 chords).
/// Nearer the line, the three points are all but collinear and the circle through them is
/// decided by their rounding.
pub const ARC_MIN_BULGE: f64 = 1e-3;

impl Arc {
    /// The arc from `from` through `via` to `to`.
    ///
    /// # Errors
    /// [`ArcFault::TooClose`] when two of the three points are within [`ARC_MIN_GAP_MM`];
    /// [`ArcFault::Flat`] when the via point is within [`ARC_MIN_BULGE`] chords of the line
    /// through the ends.
    pub fn through(from: Pose, via: Vector3<f64>, to: Pose) -> Result<Self, ArcFault> {
        let p = from.position_mm;
        let a = via - p;
        let b = to.position_mm - p;
        for (points, gap_mm) in [
            ("the via point and the start", a.norm()),
            ("the end and the start", b.norm()),
            ("the via point and the end", (via - to.position_mm).norm()),
        ] {
            if gap_mm.is_nan() || gap_mm < ARC_MIN_GAP_MM {
                return Err(ArcFault::TooClose { points, gap_mm });
            }
        }
        let n = a.cross(&b);
        let n2 = n.norm_squared();
        // Twice the triangle's area over the chord: the via point's distance from its line.
        let chord_mm = b.norm();
        let off_mm = n2.sqrt() / chord_mm;
        if off_mm.is_nan() || off_mm < ARC_MIN_BULGE * chord_mm {
            return Err(ArcFault::Flat { off_mm, chord_mm });
        }
        let centre = p + (b * a.norm_squared() - a * b.norm_squared()).cross(&n) / (2.0 * n2);
        // from -> via -> to turns counter-clockwise about n.
        Self::about(from, to, centre, n.normalize(), false)
    }

    /// The arc from `from` to `to` about `centre`, in the plane through the centre square to
    /// `axis`, counter-clockwise seen from the axis' tip (`clockwise` for the other way). A full
    /// circle when `to` is `from`.
    ///
    /// # Errors
    /// When the ends are not one radius from the centre, or not in the plane; when the start is
    /// within [`ARC_MIN_GAP_MM`] of the centre, or the end within it of the start but not on it.
    pub fn centred(
        from: Pose,
        to: Pose,
        centre: Vector3<f64>,
        axis: Vector3<f64>,
        clockwise: bool,
    ) -> Result<Self, ArcFault> {
        let n = axis.normalize();
        for end in [from.position_mm, to.position_mm] {
            let off_mm = (end - centre).dot(&n).abs();
            if off_mm > RADIUS_SLACK_MM {
                return Err(ArcFault::OffPlane { off_mm });
            }
        }
        let (from_mm, to_mm) = (
            (from.position_mm - centre).norm(),
            (to.position_mm - centre).norm(),
        );
        if (from_mm - to_mm).abs() > RADIUS_SLACK_MM {
            return Err(ArcFault::Radii { from_mm, to_mm });
        }
        if from_mm.is_nan() || from_mm < ARC_MIN_GAP_MM {
            return Err(ArcFault::NoRadius { radius_mm: from_mm });
        }
        let gap_mm = (to.position_mm - from.position_mm).norm();
        if gap_mm > 1e-9 && gap_mm < ARC_MIN_GAP_MM {
            return Err(ArcFault::EndsNear { gap_mm });
        }
        Self::about(from, to, centre, n, clockwise)
    }

    /// The arc about `centre` in the plane square to the unit `normal`, counter-clockwise about
    /// it (or clockwise); the whole circle when the ends meet.
    fn about(
        from: Pose,
        to: Pose,
        centre: Vector3<f64>,
        normal: Vector3<f64>,
        clockwise: bool,
    ) -> Result<Self, ArcFault> {
        let normal = if clockwise { -normal } else { normal };
        let r0 = from.position_mm - centre;
        let radius_mm = r0.norm();
        if radius_mm <= 1e-9 {
            return Err(ArcFault::NoRadius { radius_mm });
        }
        let u = r0 / radius_mm;
        let v = normal.cross(&u).normalize();
        let e = to.position_mm - centre;
        let mut sweep_rad = e.dot(&v).atan2(e.dot(&u));
        if sweep_rad <= 1e-12 {
            sweep_rad += TAU;
        }
        Ok(Self {
            from,
            to,
            centre_mm: centre,
            radius_mm,
            sweep_rad,
            u,
            v,
        })
    }

    /// The arc tangent to `t_in` at `from`, turning towards `t_out` by the angle between them,
    /// with radius `radius_mm` (a blend's corner arc; both directions unit vectors).
    pub(super) fn tangent(
        from: Pose,
        to: Pose,
        t_in: Vector3<f64>,
        t_out: Vector3<f64>,
        radius_mm: f64,
    ) -> Self {
        let inward = (t_out - t_in * t_out.dot(&t_in)).normalize();
        let centre = from.position_mm + inward * radius_mm;
        Self {
            from,
            to,
            centre_mm: centre,
            radius_mm,
            // Not the arccosine of the dot product: nearly parallel directions (a corner arc
            // of a large radius) would lose half their digits.
            sweep_rad: t_in.cross(&t_out).norm().atan2(t_in.dot(&t_out)),
            u: -inward,
            v: t_in,
        }
    }

    /// Its length, mm.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        self.radius_mm * self.sweep_rad
    }

    /// The part of it from `start_mm` after its start to `end_mm` before its end (a blend's
    /// corner takes the rest): the same circle, its ends where [`Self::at`] puts them.
    pub(super) fn cut(&self, start_mm: f64, end_mm: f64) -> Self {
        if start_mm <= 0.0 && end_mm <= 0.0 {
            return *self;
        }
        let len = self.length_mm();
        let theta = self.sweep_rad * (start_mm.max(0.0) / len);
        let (sin, cos) = theta.sin_cos();
        Self {
            from: self.at(start_mm.max(0.0)),
            to: if end_mm > 0.0 {
                self.at(len - end_mm)
            } else {
                self.to
            },
            sweep_rad: self.sweep_rad * ((len - start_mm.max(0.0) - end_mm.max(0.0)) / len),
            u: self.u * cos + self.v * sin,
            v: self.v * cos - self.u * sin,
            ..*self
        }
    }

    /// How far the end its circle and sweep make lies from its `to`, mm (0 but for rounding in
    /// an arc made whole).
    pub(super) fn end_gap_mm(&self) -> f64 {
        let (sin, cos) = self.sweep_rad.sin_cos();
        (self.centre_mm + (self.u * cos + self.v * sin) * self.radius_mm - self.to.position_mm)
            .norm()
    }

    /// The unit normal of its plane, about which it turns counter-clockwise.
    #[must_use]
    pub fn normal(&self) -> Vector3<f64> {
        self.u.cross(&self.v)
    }

    /// The pose at distance `s_mm` from the start; exactly `to` at the end.
    #[must_use]
    pub fn at(&self, s_mm: f64) -> Pose {
        let len = self.length_mm();
        if s_mm >= len {
            return self.to;
        }
        let f = (s_mm / len).max(0.0);
        let theta = self.sweep_rad * f;
        Pose {
            position_mm: self.centre_mm
                + (self.u * theta.cos() + self.v * theta.sin()) * self.radius_mm,
            a_rad: self.from.a_rad + (self.to.a_rad - self.from.a_rad) * f,
        }
    }

    /// The unit direction of travel at distance `s_mm`.
    #[must_use]
    pub fn direction(&self, s_mm: f64) -> Vector3<f64> {
        let theta = self.sweep_rad * (s_mm / self.length_mm()).clamp(0.0, 1.0);
        self.v * theta.cos() - self.u * theta.sin()
    }

    /// Distance from the start of its point nearest to `p`, mm (its centre: the start).
    #[must_use]
    pub fn nearest_mm(&self, p: &Vector3<f64>) -> f64 {
        let w = p - self.centre_mm;
        let n = self.normal();
        let in_plane = w - n * w.dot(&n);
        if in_plane.norm() <= 1e-12 {
            return 0.0;
        }
        let mut angle = in_plane.dot(&self.v).atan2(in_plane.dot(&self.u));
        if angle < 0.0 {
            angle += TAU;
        }
        if angle <= self.sweep_rad {
            return angle * self.radius_mm;
        }
        // Outside the sweep: the nearer end.
        let to_start = (p - self.from.position_mm).norm();
        let to_end = (p - self.to.position_mm).norm();
        if to_start <= to_end {
            0.0
        } else {
            self.length_mm()
        }
    }

    /// Distance from a point to the arc, mm.
    #[must_use]
    pub fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        let w = p - self.centre_mm;
        let n = self.normal();
        let height = w.dot(&n);
        let in_plane = w - n * height;
        let mut angle = in_plane.dot(&self.v).atan2(in_plane.dot(&self.u));
        if angle < 0.0 {
            angle += TAU;
        }
        if angle <= self.sweep_rad {
            (in_plane.norm() - self.radius_mm).hypot(height)
        } else {
            (p - self.from.position_mm)
                .norm()
                .min((p - self.to.position_mm).norm())
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};

    use super::*;

    fn pose(x: f64, y: f64, z: f64) -> Pose {
        Pose::from_mm_deg(x, y, z, 0.0)
    }

    #[test]
    fn three_points_give_the_circle_through_them_in_their_order() {
        // A half circle of radius 100 about (0, 0, 50), counter-clockwise seen from above.
        let arc = Arc::through(
            pose(100.0, 0.0, 50.0),
            Vector3::new(0.0, 100.0, 50.0),
            pose(-100.0, 0.0, 50.0),
        )
        .unwrap();
        assert!((arc.centre_mm - Vector3::new(0.0, 0.0, 50.0)).norm() < 1e-9);
        assert!((arc.radius_mm - 100.0).abs() < 1e-9);
        assert!((arc.sweep_rad - PI).abs() < 1e-9);
        assert!((arc.length_mm() - 100.0 * PI).abs() < 1e-9);
        let quarter = arc.at(arc.length_mm() / 2.0).position_mm;
        assert!((quarter - Vector3::new(0.0, 100.0, 50.0)).norm() < 1e-9);
        assert!((arc.direction(0.0) - Vector3::y()).norm() < 1e-9);
        // The same ends through a via below: the other half.
        let other = Arc::through(
            pose(100.0, 0.0, 50.0),
            Vector3::new(0.0, -100.0, 50.0),
            pose(-100.0, 0.0, 50.0),
        )
        .unwrap();
        let mid = other.at(other.length_mm() / 2.0).position_mm;
        assert!((mid - Vector3::new(0.0, -100.0, 50.0)).norm() < 1e-9);
    }

    #[test]
    fn a_via_past_the_end_makes_the_long_way_round() {
        // From (100, 0) through (0, -100) to (0, 100): three quarters of the circle.
        let arc = Arc::through(
            pose(100.0, 0.0, 0.0),
            Vector3::new(0.0, -100.0, 0.0),
            pose(0.0, 100.0, 0.0),
        )
        .unwrap();
        assert!((arc.sweep_rad - 3.0 * FRAC_PI_2).abs() < 1e-9);
    }

    #[test]
    fn collinear_points_give_no_arc() {
        assert!(matches!(
            Arc::through(
                pose(0.0, 0.0, 0.0),
                Vector3::new(1.0, 1.0, 1.0),
                pose(2.0, 2.0, 2.0)
            ),
            Err(ArcFault::Flat { off_mm, .. }) if off_mm < 1e-9
        ));
    }

    #[test]
    fn a_centre_with_the_same_ends_is_a_full_circle_either_way() {
        let start = pose(10.0, 0.0, 0.0);
        let ccw = Arc::centred(start, start, Vector3::zeros(), Vector3::z(), false).unwrap();
        assert!((ccw.sweep_rad - 2.0 * PI).abs() < 1e-12);
        assert!(
            (ccw.at(ccw.length_mm() / 4.0).position_mm - Vector3::new(0.0, 10.0, 0.0)).norm()
                < 1e-9
        );
        let cw = Arc::centred(start, start, Vector3::zeros(), Vector3::z(), true).unwrap();
        assert!(
            (cw.at(cw.length_mm() / 4.0).position_mm - Vector3::new(0.0, -10.0, 0.0)).norm() < 1e-9
        );
    }

    #[test]
    fn a_centre_refuses_ends_at_other_radii_or_off_its_plane() {
        let c = Vector3::zeros();
        assert!(matches!(
            Arc::centred(
                pose(10.0, 0.0, 0.0),
                pose(0.0, 11.0, 0.0),
                c,
                Vector3::z(),
                false
            ),
            Err(ArcFault::Radii { .. })
        ));
        assert!(matches!(
            Arc::centred(
                pose(10.0, 0.0, 0.0),
                pose(0.0, 10.0, 3.0),
                c,
                Vector3::z(),
                false
            ),
            Err(ArcFault::OffPlane { .. })
        ));
    }

    #[test]
    fn distance_is_radial_inside_the_sweep_and_to_the_ends_outside_it() {
        let arc = Arc::centred(
            pose(10.0, 0.0, 0.0),
            pose(0.0, 10.0, 0.0),
            Vector3::zeros(),
            Vector3::z(),
            false,
        )
        .unwrap();
        let inside = Vector3::new(8.0f64.sqrt() * 2.0, 8.0f64.sqrt() * 2.0, 3.0);
        let radial = (inside.xy().norm() - 10.0).hypot(3.0);
        assert!((arc.distance_mm(&inside) - radial).abs() < 1e-12);
        assert!((arc.distance_mm(&Vector3::new(10.0, -5.0, 0.0)) - 5.0).abs() < 1e-12);
    }
}
