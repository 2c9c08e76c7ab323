//! What a move follows: a straight line in Cartesian space (the tool point on the line P1P2, the
//! joints by inverse kinematics at every sample) or a straight line in joint space (every joint
//! from its start value to its target on the same trapezoid, so all reach it together, and the
//! tool wherever forward kinematics puts it).
//!
//! A joint-space path's length, which the profile runs over, is the larger of the tool point's
//! path length (mm) and the tool angle's turn (degrees counted as mm): a joint move takes as long
//! as a line of that length at the move's speed, and a move that only turns the wrist still has
//! a length. The tool point's path is kept as a polyline of chords at most [`TRACE_CHORD_MM`]
//! long, for the accuracy figures to measure against.

use nalgebra::Vector3;

use crate::geometry::{Line, Pace, Path, Polyline, Profile, ToolPath};
use crate::kinematics::{JOINTS, Joints};
use crate::robot::Robot;

use super::error::PlanError;
use super::joint_path::JointPath;
use super::samples::{self, Samples};

/// The longest chord of a joint-space path's tool polyline, mm.
const TRACE_CHORD_MM: f64 = 0.25;
/// Chords of the first, coarse measurement of a joint-space path's length.
const COARSE_CHORDS: usize = 64;
/// The most chords a tool polyline gets.
const MAX_CHORDS: usize = 16_384;

/// A move's path as the planner follows it.
pub(super) enum Course {
    /// The tool point on a straight line.
    Line(Line),
    /// The tool point on a section of a path (lines, arcs, blended corners) it runs through
    /// without a stop, the profile running along it at its pace (slower on tight arcs).
    Path {
        /// The section.
        path: Path,
        /// Where the profile's distance falls on it.
        pace: Pace,
    },
    /// Every joint on a straight line in joint space.
    Joints {
        /// The joints' path.
        path: JointPath,
        /// Its length for the profile: the tool point's path (mm) or the tool angle's turn
        /// (degrees as mm), whichever is larger.
        length_mm: f64,
        /// The tool point's path.
        trace: Polyline,
    },
}

impl Course {
    /// The joint-space course from `from` to `to` for `robot`.
    pub(super) fn joints(robot: &Robot, from: Joints, to: Joints) -> Self {
        let path = JointPath::new(&robot.kinematics, from, to);
        let coarse = path.trace(COARSE_CHORDS).length_mm();
        let chords = ((coarse / TRACE_CHORD_MM).ceil() as usize).clamp(COARSE_CHORDS, MAX_CHORDS);
        let trace = path.trace(chords);
        let turn_deg = (path.pose_at(1.0).a_rad - path.pose_at(0.0).a_rad)
            .to_degrees()
            .abs();
        Self::Joints {
            length_mm: trace.length_mm().max(turn_deg),
            path,
            trace,
        }
    }

    /// The length the profile runs over, mm.
    pub(super) fn length_mm(&self) -> f64 {
        match self {
            Self::Line(line) => line.length_mm(),
            Self::Path { pace, .. } => pace.profile_length_mm(),
            Self::Joints { length_mm, .. } => *length_mm,
        }
    }

    /// The planned tool position at distance `s_mm` along the profile.
    pub(super) fn position_mm(&self, s_mm: f64) -> Vector3<f64> {
        match self {
            Self::Line(line) => line.at(s_mm).position_mm,
            Self::Path { path, pace } => path.at(pace.path_mm(s_mm)).position_mm,
            Self::Joints {
                path, length_mm, ..
            } => path.pose_at(s_mm / length_mm).position_mm,
        }
    }

    /// The planned tool position as a function of the distance along the profile, with what it
    /// can compute once computed once (the same values as [`Course::position_mm`]).
    pub(super) fn positions(&self) -> impl Fn(f64) -> Vector3<f64> + '_ {
        let line = match self {
            Self::Line(line) => {
                let d = line.to.position_mm - line.from.position_mm;
                Some((line.from.position_mm, d, d.norm()))
            }
            Self::Path { .. } | Self::Joints { .. } => None,
        };
        move |s_mm| match line {
            Some((from, d, len)) => from + d * if len > 0.0 { s_mm / len } else { 1.0 },
            None => self.position_mm(s_mm),
        }
    }

    /// What the executed path is measured against.
    pub(super) fn tool_path(&self) -> &dyn ToolPath {
        match self {
            Self::Line(line) => line,
            Self::Path { path, .. } => path,
            Self::Joints { trace, .. } => trace,
        }
    }

    /// The line from the start pose to the end pose (a joint move's or a path's chord, for
    /// reports).
    pub(super) fn chord(&self) -> Line {
        match self {
            Self::Line(line) => *line,
            Self::Path { path, .. } => Line {
                from: path.at(0.0),
                to: path.at(path.length_mm()),
            },
            Self::Joints { path, .. } => Line {
                from: path.pose_at(0.0),
                to: path.pose_at(1.0),
            },
        }
    }

    /// The straight line it follows: a line, or a path of one line piece (a line timed along
    /// its path, [`super::dynamics`]).
    pub(super) fn line(&self) -> Option<Line> {
        match self {
            Self::Line(line) => Some(*line),
            Self::Path { path, .. } => match path.pieces() {
                [piece] => match piece.primitive {
                    crate::geometry::Primitive::Line(line) => Some(line),
                    crate::geometry::Primitive::Arc(_) => None,
                },
                _ => None,
            },
            Self::Joints { .. } => None,
        }
    }

    /// The path, for a path section.
    pub(super) fn path(&self) -> Option<&Path> {
        match self {
            Self::Path { path, .. } => Some(path),
            Self::Line(_) | Self::Joints { .. } => None,
        }
    }

    /// Where the profile's distance falls on the path, for a path section.
    pub(super) fn pace(&self) -> Option<&Pace> {
        match self {
            Self::Path { pace, .. } => Some(pace),
            Self::Line(_) | Self::Joints { .. } => None,
        }
    }

    /// The joint-space path, for a joint move.
    pub(super) fn joint_path(&self) -> Option<&JointPath> {
        match self {
            Self::Line(_) | Self::Path { .. } => None,
            Self::Joints { path, .. } => Some(path),
        }
    }

    /// Samples the course at every point of `profile`; point 0 takes `start_counts`.
    pub(super) fn sample(
        &self,
        robot: &Robot,
        profile: &Profile,
        start_values: &Joints,
        start_counts: [i64; JOINTS],
    ) -> Result<Samples, PlanError> {
        match self {
            Self::Line(line) => {
                samples::sample(robot, &|s| line.at(s), profile, start_values, start_counts)
            }
            Self::Path { path, pace } => samples::sample(
                robot,
                &|s| path.at(pace.path_mm(s)),
                profile,
                start_values,
                start_counts,
            ),
            Self::Joints { path, .. } => {
                Ok(samples::sample_joints(robot, path, profile, start_counts))
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // the path's ends are exact by construction
mod tests {
    use super::*;
    use crate::robot::seed_robot;

    #[test]
    fn a_joint_path_ends_exactly_on_its_target() {
        let robot = seed_robot();
        let from = [0.1, 10.0, 20.0, 0.0];
        let to = [0.3f64.next_up(), 50.0, 25.0, -0.2];
        let path = JointPath::new(&robot.kinematics, from, to);
        assert_eq!(path.joints_at(1.0), to);
        assert_eq!(path.joints_at(0.0), from);
        let mid = path.joints_at(0.5);
        assert!((mid[1] - 30.0).abs() < 1e-12);
    }

    #[test]
    fn a_joint_course_is_as_long_as_the_tool_path_or_the_turn() {
        let robot = seed_robot();
        // theta1 through 90 degrees at a radius of 500 mm: a quarter circle.
        let arc = Course::joints(
            &robot,
            [0.0; 4],
            [std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0],
        );
        let quarter = 250.0 * std::f64::consts::PI;
        assert!(
            (arc.length_mm() - quarter).abs() < 1e-3,
            "{}",
            arc.length_mm()
        );
        // The tool point halfway, and the path it is measured against.
        let half = arc.position_mm(quarter / 2.0);
        let r = 500.0 / 2f64.sqrt();
        assert!((half - Vector3::new(-r, r, 0.0)).norm() < 1e-3);
        assert!(arc.tool_path().distance_mm(&(half * 1.01)) < 5.01);
        // The wrist alone: the tool point stands still, the tool turns 90 degrees.
        let wrist = Course::joints(
            &robot,
            [0.0; 4],
            [0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2],
        );
        assert!((wrist.length_mm() - 90.0).abs() < 1e-9);
        assert!(wrist.chord().length_mm() < 1e-9);
    }
}
