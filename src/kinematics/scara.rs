//! A SCARA: two revolute arms in the xy plane, a prismatic Z and a wrist, with a fixed elbow side.
//! ```text
//! x = l1 cos(t1) + l2 cos(t1 + t2)      cos(t2) = (x^2 + y^2 - l1^2 - l2^2) / (2 l1 l2)
//! y = l1 sin(t1) + l2 sin(t1 + t2)      t2 = +acos(..) elbow left, -acos(..) elbow right
//! z = d3                                t1 = atan2(y, x) - atan2(l2 sin t2, l1 + l2 cos t2)
//! a = t1 + t2 + wrist
//! ```
//! The elbow never flips: every point of a path must lie inside the open annulus
//! `|l1 - l2| + margin <= r <= l1 + l2 - margin`, whose edges are where t2 reaches 0 or pi.

use std::fmt;

use nalgebra::Vector3;

use super::{JOINTS, JointKind, Joints, Kinematics, KinematicsError, check_finite, unwrap_near};
use crate::geometry::{Line, Pose};

/// Which side the elbow stays on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Elbow {
    /// theta2 > 0 (counter-clockwise from the first arm).
    Left,
    /// theta2 < 0.
    Right,
}

impl fmt::Display for Elbow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Left => "left",
            Self::Right => "right",
        })
    }
}

/// Two arms of `l1_mm` and `l2_mm`, Z, and a wrist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scara {
    /// First arm, mm.
    pub l1_mm: f64,
    /// Second arm, mm.
    pub l2_mm: f64,
    /// The fixed elbow side.
    pub elbow: Elbow,
    /// How far from the annulus edges (full stretch and full fold) a path must stay, mm.
    pub reach_margin_mm: f64,
}

impl Scara {
    /// Inner and outer radius a path may use, mm.
    #[must_use]
    pub fn reach_mm(&self) -> (f64, f64) {
        (
            (self.l1_mm - self.l2_mm).abs() + self.reach_margin_mm,
            self.l1_mm + self.l2_mm - self.reach_margin_mm,
        )
    }

    fn check_radius(&self, radius_mm: f64) -> Result<(), KinematicsError> {
        let (min_mm, max_mm) = self.reach_mm();
        if radius_mm < min_mm || radius_mm > max_mm {
            return Err(KinematicsError::OutOfReach {
                radius_mm,
                min_mm,
                max_mm,
                elbow: self.elbow,
            });
        }
        Ok(())
    }
}

impl Kinematics for Scara {
    fn name(&self) -> &'static str {
        "scara"
    }

    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("l1_mm", self.l1_mm),
            ("l2_mm", self.l2_mm),
            ("reach_margin_mm", self.reach_margin_mm),
        ]
    }

    fn joint_kinds(&self) -> [JointKind; JOINTS] {
        [
            JointKind::Revolute,
            JointKind::Revolute,
            JointKind::Prismatic,
            JointKind::Revolute,
        ]
    }

    fn fk(&self, q: &Joints) -> Pose {
        let [t1, t2, d3, wrist] = *q;
        let x = self.l1_mm * t1.cos() + self.l2_mm * (t1 + t2).cos();
        let y = self.l1_mm * t1.sin() + self.l2_mm * (t1 + t2).sin();
        Pose {
            position_mm: Vector3::new(x, y, d3),
            a_rad: t1 + t2 + wrist,
        }
    }

    fn ik(&self, pose: &Pose, near: Option<&Joints>) -> Result<Joints, KinematicsError> {
        check_finite(pose)?;
        let p = pose.position_mm;
        let r = p.x.hypot(p.y);
        self.check_radius(r)?;
        let (l1, l2) = (self.l1_mm, self.l2_mm);
        let c2 = ((r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let t2 = match self.elbow {
            Elbow::Left => c2.acos(),
            Elbow::Right => -c2.acos(),
        };
        let mut t1 = p.y.atan2(p.x) - (l2 * t2.sin()).atan2(l1 + l2 * t2.cos());
        if let Some(near) = near {
            t1 = unwrap_near(t1, near[0]);
        }
        Ok([t1, t2, p.z, pose.a_rad - t1 - t2])
    }

    fn check_line(&self, line: &Line) -> Result<(), KinematicsError> {
        check_finite(&line.from)?;
        check_finite(&line.to)?;
        let (nearest, farthest) = line.xy_radius_range_mm();
        self.check_radius(nearest)?;
        self.check_radius(farthest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(elbow: Elbow) -> Scara {
        Scara {
            l1_mm: 400.0,
            l2_mm: 250.0,
            elbow,
            reach_margin_mm: 1.0,
        }
    }

    #[test]
    fn fk_of_ik_is_the_pose_on_both_elbow_sides() {
        for elbow in [Elbow::Left, Elbow::Right] {
            let k = arm(elbow);
            let pose = Pose::from_mm_deg(350.0, 220.0, -40.0, 10.0);
            let q = k.ik(&pose, None).unwrap();
            assert_eq!(q[1] > 0.0, elbow == Elbow::Left);
            let back = k.fk(&q);
            assert!((back.position_mm - pose.position_mm).norm() < 1e-9);
            assert!((back.a_rad - pose.a_rad).abs() < 1e-12);
        }
    }

    #[test]
    fn line_leaving_the_outer_reach_is_refused() {
        let line = Line {
            from: Pose::from_mm_deg(300.0, 0.0, 0.0, 0.0),
            to: Pose::from_mm_deg(700.0, 0.0, 0.0, 0.0),
        };
        let err = arm(Elbow::Left).check_line(&line).unwrap_err();
        assert!(matches!(err, KinematicsError::OutOfReach { .. }), "{err}");
    }

    #[test]
    fn line_crossing_the_inner_hole_is_refused_though_its_ends_are_reachable() {
        // Both ends 300 mm out, but the line passes 50 mm from the axis (inner reach 151 mm).
        let line = Line {
            from: Pose::from_mm_deg(-295.8, 50.0, 0.0, 0.0),
            to: Pose::from_mm_deg(295.8, 50.0, 0.0, 0.0),
        };
        let k = arm(Elbow::Right);
        assert!(k.ik(&line.from, None).is_ok() && k.ik(&line.to, None).is_ok());
        assert!(k.check_line(&line).is_err());
    }
}
