//! A curved tool path as a polyline: points close enough together that their chords stand for the
//! curve (a joint-space move's tool path, its points by forward kinematics).
//!
//! The distance to it is searched from the chord where the previous search ended: an executed
//! move's poses come one pulse at a time, so the nearest chord moves little from one call to the
//! next. The search walks along the chords while the distance falls. Stopping at a local minimum
//! can only over-estimate the distance, never under-estimate it: on the safe side for a bound.

use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::Vector3;

use super::ToolPath;

/// A tool path through `points`, in order.
#[derive(Debug)]
pub struct Polyline {
    points: Vec<Vector3<f64>>,
    /// The chord where the last search ended. Atomic so that a course holding a polyline can be
    /// shared between threads; a search's answer depends on where it starts, so one polyline is
    /// measured on one thread at a time (the planner plans parts side by side only on paths).
    cursor: AtomicUsize,
}

impl Clone for Polyline {
    fn clone(&self) -> Self {
        Self {
            points: self.points.clone(),
            cursor: AtomicUsize::new(self.cursor.load(Ordering::Relaxed)),
        }
    }
}

impl Polyline {
    /// A polyline through `points` (at least one).
    ///
    /// # Panics
    /// When `points` is empty.
    #[must_use]
    pub fn new(points: Vec<Vector3<f64>>) -> Self {
        assert!(!points.is_empty(), "a polyline needs a point");
        Self {
            points,
            cursor: AtomicUsize::new(0),
        }
    }

    /// Its points.
    #[must_use]
    pub fn points(&self) -> &[Vector3<f64>] {
        &self.points
    }

    /// Its length, mm.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    /// Distance from `p` to chord `i` (from point i to point i + 1).
    fn chord_distance_mm(&self, i: usize, p: &Vector3<f64>) -> f64 {
        let a = self.points[i];
        let Some(b) = self.points.get(i + 1) else {
            return (p - a).norm();
        };
        let d = b - a;
        let len2 = d.norm_squared();
        let u = if len2 > 0.0 {
            ((p - a).dot(&d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (a + d * u)).norm()
    }
}

impl ToolPath for Polyline {
    fn distance_mm(&self, p: &Vector3<f64>) -> f64 {
        let chords = self.points.len().saturating_sub(1).max(1);
        let mut i = self.cursor.load(Ordering::Relaxed).min(chords - 1);
        let mut d = self.chord_distance_mm(i, p);
        while i + 1 < chords {
            let next = self.chord_distance_mm(i + 1, p);
            if next >= d {
                break;
            }
            (i, d) = (i + 1, next);
        }
        while i > 0 {
            let next = self.chord_distance_mm(i - 1, p);
            if next >= d {
                break;
            }
            (i, d) = (i - 1, next);
        }
        self.cursor.store(i, Ordering::Relaxed);
        d
    }

    fn end_mm(&self) -> Vector3<f64> {
        *self.points.last().expect("at least one point")
    }

    fn restart(&self) {
        self.cursor.store(0, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quarter_circle(n: usize) -> Polyline {
        Polyline::new(
            (0..=n)
                .map(|i| {
                    let t = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
                    Vector3::new(100.0 * t.cos(), 100.0 * t.sin(), 0.0)
                })
                .collect(),
        )
    }

    #[test]
    fn distance_to_an_arc_follows_points_along_it() {
        let arc = quarter_circle(1_000);
        assert!((arc.length_mm() - 50.0 * std::f64::consts::PI).abs() < 1e-3);
        for k in 0..=20 {
            let t = std::f64::consts::FRAC_PI_2 * f64::from(k) / 20.0;
            let p = Vector3::new(101.0 * t.cos(), 101.0 * t.sin(), 0.0);
            let d = arc.distance_mm(&p);
            assert!((d - 1.0).abs() < 1e-3, "{k}: {d}");
        }
        assert!((arc.end_mm() - Vector3::new(0.0, 100.0, 0.0)).norm() < 1e-9);
    }

    #[test]
    fn restart_searches_from_the_start_again() {
        // A three-quarter circle: from its end, the walk back toward its start would climb first.
        let n = 3_000;
        let arc = Polyline::new(
            (0..=n)
                .map(|i| {
                    let t = 1.5 * std::f64::consts::PI * f64::from(i) / f64::from(n);
                    Vector3::new(100.0 * t.cos(), 100.0 * t.sin(), 0.0)
                })
                .collect(),
        );
        // A measurement follows the path to its end...
        for p in arc.points().iter().step_by(10) {
            assert!(arc.distance_mm(p) < 1e-9);
        }
        assert!(arc.distance_mm(&arc.end_mm()) < 1e-9);
        // ...from where a search for the start would stop at a local minimum: an over-estimate.
        let start = Vector3::new(100.0, 0.0, 0.0);
        assert!(arc.distance_mm(&start) > 100.0);
        arc.restart();
        assert!(arc.distance_mm(&start) < 1e-9);
    }

    #[test]
    fn a_path_that_stands_still_is_a_point() {
        let still = Polyline::new(vec![Vector3::new(1.0, 2.0, 3.0); 5]);
        assert!((still.distance_mm(&Vector3::new(1.0, 2.0, 7.0)) - 4.0).abs() < 1e-12);
        assert!(
            (Polyline::new(vec![Vector3::zeros()]).distance_mm(&Vector3::x()) - 1.0).abs() < 1e-12
        );
    }
}
