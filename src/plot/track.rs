//! An executed path (a plan's run in the execution model, or a PLC's pulse trace replayed): the
//! tool position after every pulse event (forward kinematics of the counts), placed against the
//! planned path (a line, or lines and arcs), and thinned for drawing.

use nalgebra::Vector3;

use crate::geometry::Path;
use crate::kinematics::JOINTS;
use crate::robot::Robot;
use crate::sim::PulseEvent;

/// One executed position, placed against the planned path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TrackPoint {
    /// Distance along the path of its nearest point, mm.
    pub(super) along_mm: f64,
    /// From that nearest point to the executed position, mm (its norm is the path deviation).
    pub(super) offset_mm: Vector3<f64>,
}

impl TrackPoint {
    /// Distance from the executed position to the path, mm.
    pub(super) fn deviation_mm(&self) -> f64 {
        self.offset_mm.norm()
    }
}

/// The tool position at the start and after every pulse event of a run from `start` (counts per
/// joint): its offset measured from `own`, the path the move was planned on, and its place along
/// `frame`, the path the picture is drawn on (the same path, or a line it runs back and forth
/// on).
pub(super) fn executed(
    robot: &Robot,
    own: &Path,
    frame: &Path,
    start: [i64; JOINTS],
    events: &[PulseEvent],
) -> Vec<TrackPoint> {
    let mut counts = start;
    let mut out = Vec::with_capacity(events.len() + 1);
    let at = |c: &[i64; JOINTS]| place_on(own, frame, &robot.pose_of(c).position_mm);
    out.push(at(&counts));
    for e in events {
        counts[e.table] = e.count;
        out.push(at(&counts));
    }
    out
}

/// `p` offset from `own`, its foot there placed along `frame`.
fn place_on(own: &Path, frame: &Path, p: &Vector3<f64>) -> TrackPoint {
    let on_own = place(own, p);
    let foot = p - on_own.offset_mm;
    TrackPoint {
        along_mm: frame.nearest_mm(&foot),
        offset_mm: on_own.offset_mm,
    }
}

/// `p` against `path`.
fn place(path: &Path, p: &Vector3<f64>) -> TrackPoint {
    let along_mm = path.nearest_mm(p);
    TrackPoint {
        along_mm,
        offset_mm: p - path.at(along_mm).position_mm,
    }
}

/// Which of `buckets` equal stretches of a `length_mm` line `along_mm` falls in.
fn bucket(along_mm: f64, length_mm: f64, buckets: usize) -> usize {
    if length_mm <= 0.0 {
        return 0;
    }
    ((along_mm / length_mm * buckets as f64) as usize).min(buckets - 1)
}

/// `points` thinned to at most two a stretch (the nearest to and the farthest from the line), in
/// their order, the first and last kept: the shape of the path survives, the count is bounded.
pub(super) fn thin(points: &[TrackPoint], length_mm: f64, buckets: usize) -> Vec<TrackPoint> {
    let buckets = buckets.max(1);
    let mut near: Vec<Option<usize>> = vec![None; buckets];
    let mut far: Vec<Option<usize>> = vec![None; buckets];
    for (i, p) in points.iter().enumerate() {
        let b = bucket(p.along_mm, length_mm, buckets);
        let d = p.deviation_mm();
        if near[b].is_none_or(|k| d < points[k].deviation_mm()) {
            near[b] = Some(i);
        }
        if far[b].is_none_or(|k| d > points[k].deviation_mm()) {
            far[b] = Some(i);
        }
    }
    let mut keep: Vec<usize> = near.into_iter().chain(far).flatten().collect();
    if !points.is_empty() {
        keep.extend([0, points.len() - 1]);
    }
    keep.sort_unstable();
    keep.dedup();
    keep.into_iter().map(|i| points[i]).collect()
}

/// The largest deviation in each of `buckets` equal stretches of the line, as
/// `(middle of the stretch, deviation)`; stretches no point falls in are left out.
pub(super) fn envelope(points: &[TrackPoint], length_mm: f64, buckets: usize) -> Vec<(f64, f64)> {
    let buckets = buckets.max(1);
    let mut top: Vec<Option<f64>> = vec![None; buckets];
    for p in points {
        let b = bucket(p.along_mm, length_mm, buckets);
        top[b] = Some(top[b].map_or(p.deviation_mm(), |d| d.max(p.deviation_mm())));
    }
    let width = length_mm / buckets as f64;
    top.into_iter()
        .enumerate()
        .filter_map(|(b, d)| d.map(|d| ((b as f64 + 0.5) * width, d)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Line, Pose};

    fn segment() -> Line {
        Line {
            from: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            to: Pose::from_mm_deg(10.0, 0.0, 0.0, 0.0),
        }
    }

    fn line() -> Path {
        Path::from(segment())
    }

    #[test]
    fn a_point_beside_the_line_is_placed_at_its_foot() {
        let p = place(&line(), &Vector3::new(4.0, 0.5, 0.0));
        assert!((p.along_mm - 4.0).abs() < 1e-12);
        assert!((p.deviation_mm() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_move_back_along_the_line_is_placed_from_the_frames_start() {
        let back = Path::from(Line {
            from: segment().to,
            to: segment().from,
        });
        let p = place_on(&back, &line(), &Vector3::new(3.0, 0.25, 0.0));
        assert!((p.along_mm - 3.0).abs() < 1e-12);
        assert!((p.deviation_mm() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn thinning_keeps_the_extremes_of_every_stretch_and_both_ends() {
        let points: Vec<TrackPoint> = (0..=1000)
            .map(|i| {
                let x = f64::from(i) / 100.0;
                place(&line(), &Vector3::new(x, (x * 7.0).sin() * 0.01, 0.0))
            })
            .collect();
        let thin = thin(&points, 10.0, 10);
        assert!(thin.len() <= 22);
        assert_eq!(thin.first(), points.first());
        assert_eq!(thin.last(), points.last());
        let top = points
            .iter()
            .map(TrackPoint::deviation_mm)
            .fold(0.0, f64::max);
        let kept = thin
            .iter()
            .map(TrackPoint::deviation_mm)
            .fold(0.0, f64::max);
        assert!((top - kept).abs() < 1e-15);
    }

    #[test]
    fn envelope_is_the_largest_deviation_of_each_stretch() {
        let points = [
            place(&line(), &Vector3::new(1.0, 0.2, 0.0)),
            place(&line(), &Vector3::new(2.0, 0.1, 0.0)),
            place(&line(), &Vector3::new(8.0, 0.3, 0.0)),
        ];
        let env = envelope(&points, 10.0, 2);
        assert_eq!(env.len(), 2);
        assert!((env[0].0 - 2.5).abs() < 1e-12 && (env[0].1 - 0.2).abs() < 1e-12);
        assert!((env[1].1 - 0.3).abs() < 1e-12);
    }
}
