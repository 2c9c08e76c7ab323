//! An X, Y, Z gantry plus a rotary A: every joint is its own coordinate.

use nalgebra::Vector3;

use super::{JOINTS, JointKind, Joints, Kinematics, KinematicsError, check_finite};
use crate::geometry::{Line, Pose};

/// X, Y, Z (mm) and A (rad) = the tool angle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cartesian;

impl Kinematics for Cartesian {
    fn name(&self) -> &'static str {
        "cartesian"
    }

    fn params(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }

    fn joint_kinds(&self) -> [JointKind; JOINTS] {
        [
            JointKind::Prismatic,
            JointKind::Prismatic,
            JointKind::Prismatic,
            JointKind::Revolute,
        ]
    }

    fn fk(&self, q: &Joints) -> Pose {
        Pose {
            position_mm: Vector3::new(q[0], q[1], q[2]),
            a_rad: q[3],
        }
    }

    fn ik(&self, pose: &Pose, _near: Option<&Joints>) -> Result<Joints, KinematicsError> {
        check_finite(pose)?;
        let p = pose.position_mm;
        // A is the tool angle itself, which a line already moves continuously.
        Ok([p.x, p.y, p.z, pose.a_rad])
    }

    fn check_line(&self, line: &Line) -> Result<(), KinematicsError> {
        check_finite(&line.from)?;
        check_finite(&line.to)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joints_are_the_coordinates() {
        let pose = Pose::from_mm_deg(1.0, -2.0, 3.0, 45.0);
        let q = Cartesian.ik(&pose, None).unwrap();
        assert_eq!(q[..3], [1.0, -2.0, 3.0]);
        assert_eq!(Cartesian.fk(&q), pose);
    }

    #[test]
    fn nan_coordinate_is_refused_by_name() {
        let err = Cartesian
            .ik(&Pose::from_mm_deg(f64::NAN, 0.0, 0.0, 0.0), None)
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "pose coordinate x is NaN; it must be a finite number"
        );
    }
}
