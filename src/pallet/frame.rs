//! A user frame: a fixture's own coordinates (a pallet station, a press die), taught from three
//! points or given as numbers, and how a pose in it becomes a world pose of the tool centre.
//!
//! Taught from three points, as a robot controller's user frame is: `origin`, a point along +x
//! (`x_point`), and a point on the +y side of the xy plane (`xy_point`). x runs from the origin
//! to `x_point`; z is square to the plane of the three points, pointing up (the side of
//! `x_point` x `xy_point`); y completes a right-handed frame. Given as numbers: an origin and
//! a turn about world z (`rotation_deg`), the frame level.
//!
//! A 4-axis robot turns its tool only about z. A frame taught from three real points is never
//! quite level; positions on it are transformed fully (a slot on a tilted pallet sits on the
//! tilted plane), while the tool angle takes only the frame's turn about z (the direction of its
//! x axis seen from above). A frame whose z axis leans more than [`MAX_TILT_DEG`] from world z
//! is refused: the tool could not sit square on it.

use nalgebra::{Matrix3, Vector3};
use thiserror::Error;

use crate::geometry::Pose;

/// The most a frame's z axis may lean from world z, degrees.
pub const MAX_TILT_DEG: f64 = 5.0;

/// The least distance between the origin and `x_point`, and of `xy_point` from the x axis, mm:
/// closer points leave the frame's axes to the teaching's errors.
pub const MIN_POINT_SPREAD_MM: f64 = 10.0;

/// Why three points or numbers make no frame.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FrameError {
    /// A point or an angle that is not a finite number.
    #[error("{what} is {value}; it must be a finite number")]
    NotFinite {
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// Points too close to tell the axes.
    #[error(
        "{what} is {distance_mm:.3} mm; the three points must be at least {min_mm} mm apart \
         to set the axes"
    )]
    TooClose {
        /// Which distance.
        what: &'static str,
        /// The distance.
        distance_mm: f64,
        /// [`MIN_POINT_SPREAD_MM`].
        min_mm: f64,
    },
    /// A frame leaning too far for a tool that turns only about z.
    #[error(
        "the frame's z axis leans {tilt_deg:.2} degrees from world z; a tool that turns only \
         about z allows at most {max_deg} degrees"
    )]
    Tilted {
        /// The lean, degrees.
        tilt_deg: f64,
        /// [`MAX_TILT_DEG`].
        max_deg: f64,
    },
}

/// A checked frame: where its origin is and how its axes lie in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    origin_mm: Vector3<f64>,
    /// Columns: the frame's x, y and z axes in world coordinates.
    axes: Matrix3<f64>,
}

impl Default for Frame {
    fn default() -> Self {
        Self::world()
    }
}

impl Frame {
    /// World coordinates themselves.
    #[must_use]
    pub fn world() -> Self {
        Self {
            origin_mm: Vector3::zeros(),
            axes: Matrix3::identity(),
        }
    }

    /// A level frame at `origin_mm`, turned by `rotation_deg` about world z.
    ///
    /// # Errors
    /// A value that is not finite.
    pub fn level(origin_mm: Vector3<f64>, rotation_deg: f64) -> Result<Self, FrameError> {
        finite("the origin", &origin_mm)?;
        if !rotation_deg.is_finite() {
            return Err(FrameError::NotFinite {
                what: "rotation_deg",
                value: rotation_deg,
            });
        }
        let (s, c) = rotation_deg.to_radians().sin_cos();
        let axes = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        Ok(Self { origin_mm, axes })
    }

    /// The frame taught by three points ([`self`](self)).
    ///
    /// # Errors
    /// A point not finite, points too close together or in a line, or a frame leaning more
    /// than [`MAX_TILT_DEG`].
    pub fn from_points(
        origin: Vector3<f64>,
        x_point: Vector3<f64>,
        xy_point: Vector3<f64>,
    ) -> Result<Self, FrameError> {
        finite("the origin", &origin)?;
        finite("x_point", &x_point)?;
        finite("xy_point", &xy_point)?;
        let along = x_point - origin;
        spread("x_point's distance from the origin", along.norm())?;
        let x = along.normalize();
        let side = xy_point - origin;
        let across = side - x * side.dot(&x);
        spread("xy_point's distance from the x axis", across.norm())?;
        let y = across.normalize();
        let z = x.cross(&y);
        let tilt_deg = z.z.clamp(-1.0, 1.0).acos().to_degrees();
        if tilt_deg > MAX_TILT_DEG {
            return Err(FrameError::Tilted {
                tilt_deg,
                max_deg: MAX_TILT_DEG,
            });
        }
        Ok(Self {
            origin_mm: origin,
            axes: Matrix3::from_columns(&[x, y, z]),
        })
    }

    /// Its origin, world mm.
    #[must_use]
    pub fn origin_mm(&self) -> Vector3<f64> {
        self.origin_mm
    }

    /// Its turn about world z: the direction of its x axis seen from above, radians.
    #[must_use]
    pub fn turn_rad(&self) -> f64 {
        let x = self.axes.column(0);
        x.y.atan2(x.x)
    }

    /// A point in the frame, in world coordinates.
    #[must_use]
    pub fn point(&self, local_mm: &Vector3<f64>) -> Vector3<f64> {
        self.origin_mm + self.axes * local_mm
    }

    /// A direction in the frame (no origin), in world coordinates.
    #[must_use]
    pub fn direction(&self, local: &Vector3<f64>) -> Vector3<f64> {
        self.axes * local
    }

    /// A pose in the frame (x, y, z in it, the tool angle from its x axis) as a world pose: the
    /// point transformed fully, the angle turned by the frame's turn about z.
    #[must_use]
    pub fn pose(&self, local: &Pose) -> Pose {
        Pose {
            position_mm: self.point(&local.position_mm),
            a_rad: local.a_rad + self.turn_rad(),
        }
    }

    /// A world pose in the frame's coordinates ([`Self::pose`] undone).
    #[must_use]
    pub fn local(&self, world: &Pose) -> Pose {
        Pose {
            position_mm: self.axes.transpose() * (world.position_mm - self.origin_mm),
            a_rad: world.a_rad - self.turn_rad(),
        }
    }
}

fn finite(what: &'static str, p: &Vector3<f64>) -> Result<(), FrameError> {
    match p.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(FrameError::NotFinite { what, value }),
        None => Ok(()),
    }
}

fn spread(what: &'static str, distance_mm: f64) -> Result<(), FrameError> {
    if distance_mm >= MIN_POINT_SPREAD_MM {
        Ok(())
    } else {
        Err(FrameError::TooClose {
            what,
            distance_mm,
            min_mm: MIN_POINT_SPREAD_MM,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    #[test]
    fn a_frame_from_three_points_puts_its_axes_where_the_points_say() {
        // Origin at (800, 100, 20), x along world +y, the xy point on world -x's side.
        let f = Frame::from_points(
            v(800.0, 100.0, 20.0),
            v(800.0, 400.0, 20.0),
            v(500.0, 150.0, 20.0),
        )
        .unwrap();
        assert!((f.turn_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let p = f.point(&v(100.0, 50.0, 10.0));
        assert!((p - v(750.0, 200.0, 30.0)).norm() < 1e-9, "{p}");
        let pose = f.pose(&Pose::from_mm_deg(100.0, 50.0, 10.0, 30.0));
        assert!((pose.a_rad.to_degrees() - 120.0).abs() < 1e-9);
        let back = f.local(&pose);
        assert!((back.position_mm - v(100.0, 50.0, 10.0)).norm() < 1e-9);
        assert!((back.a_rad.to_degrees() - 30.0).abs() < 1e-9);
    }

    #[test]
    fn a_level_frame_equals_the_same_frame_taught_by_points() {
        let given = Frame::level(v(10.0, 20.0, 5.0), 30.0).unwrap();
        let (s, c) = 30f64.to_radians().sin_cos();
        let taught = Frame::from_points(
            v(10.0, 20.0, 5.0),
            v(10.0 + 100.0 * c, 20.0 + 100.0 * s, 5.0),
            v(10.0 - 50.0 * s + 7.0 * c, 20.0 + 50.0 * c + 7.0 * s, 5.0),
        )
        .unwrap();
        let local = v(123.0, -45.0, 67.0);
        assert!((given.point(&local) - taught.point(&local)).norm() < 1e-9);
        assert!((given.turn_rad() - taught.turn_rad()).abs() < 1e-12);
    }

    #[test]
    fn points_too_close_in_a_line_or_leaning_are_refused_with_the_limit() {
        let o = v(0.0, 0.0, 0.0);
        let e = Frame::from_points(o, v(5.0, 0.0, 0.0), v(0.0, 100.0, 0.0)).unwrap_err();
        assert!(
            e.to_string().contains("5.000 mm") && e.to_string().contains("10 mm"),
            "{e}"
        );
        let e = Frame::from_points(o, v(100.0, 0.0, 0.0), v(300.0, 2.0, 0.0)).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("xy_point's distance from the x axis is 2.000 mm"),
            "{e}"
        );
        // 100 mm along x, rising 10 mm: 5.7 degrees.
        let e = Frame::from_points(o, v(100.0, 0.0, 10.0), v(0.0, 100.0, 0.0)).unwrap_err();
        assert!(
            e.to_string().contains("5.71 degrees") && e.to_string().contains("at most 5"),
            "{e}"
        );
        let e = Frame::from_points(o, v(f64::NAN, 0.0, 0.0), v(0.0, 1.0, 0.0)).unwrap_err();
        assert!(e.to_string().starts_with("x_point is NaN"), "{e}");
        // Taught upside down (the xy point on the -y side of a frame seen from above).
        let e = Frame::from_points(o, v(100.0, 0.0, 0.0), v(0.0, -100.0, 0.0)).unwrap_err();
        assert!(matches!(e, FrameError::Tilted { .. }), "{e}");
    }

    #[test]
    fn a_slightly_tilted_frame_moves_points_fully_and_turns_the_tool_about_z_only() {
        // 100 mm along x rising 2 mm: 1.15 degrees.
        let f =
            Frame::from_points(v(0.0, 0.0, 0.0), v(100.0, 0.0, 2.0), v(0.0, 100.0, 0.0)).unwrap();
        let p = f.point(&v(500.0, 0.0, 0.0));
        assert!((p.z - 500.0 * 2.0 / 100f64.hypot(2.0)).abs() < 1e-9, "{p}");
        assert!(f.turn_rad().abs() < 1e-12);
    }
}
