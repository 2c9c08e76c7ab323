//! The seed's cylindrical robot (R-P-P + wrist), eqs. 8 and 9:
//! ```text
//! x = -(d3 + l0) sin(theta1)    theta1 = atan2(-x, y)   (continuous along a path)
//! y =  (d3 + l0) cos(theta1)    d3     = sqrt(x^2 + y^2) - l0
//! z =  d2                       d2     = z
//! a =  theta1 + wrist           wrist  = a - theta1     (the tool keeps its world angle)
//! ```

use nalgebra::Vector3;

use super::{JOINTS, JointKind, Joints, Kinematics, KinematicsError, check_finite, unwrap_near};
use crate::geometry::{Line, Pose};

/// The seed's robot: base rotation theta1, lift d2, radial extension d3 beyond `l0`, wrist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylindrical {
    /// Radius of the tool point at d3 = 0, mm.
    pub l0_mm: f64,
    /// The closest a path may pass the base axis, mm (theta1 is singular on it).
    pub min_axis_distance_mm: f64,
}

impl Kinematics for Cylindrical {
    fn name(&self) -> &'static str {
        "cylindrical"
    }

    fn params(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("l0_mm", self.l0_mm),
            ("min_axis_distance_mm", self.min_axis_distance_mm),
        ]
    }

    fn joint_kinds(&self) -> [JointKind; JOINTS] {
        [
            JointKind::Revolute,
            JointKind::Prismatic,
            JointKind::Prismatic,
            JointKind::Revolute,
        ]
    }

    fn fk(&self, q: &Joints) -> Pose {
        let [theta1, d2, d3, wrist] = *q;
        let r = d3 + self.l0_mm;
        Pose {
            position_mm: Vector3::new(-r * theta1.sin(), r * theta1.cos(), d2),
            a_rad: theta1 + wrist,
        }
    }

    fn fk_moved(&self, q: &Joints, steps: &Joints) -> (Vector3<f64>, [Vector3<f64>; JOINTS]) {
        // `fk`'s formula, the angle's sine and cosine worked once for every joint but the base.
        let [theta1, d2, d3, _] = *q;
        let (sin, cos) = theta1.sin_cos();
        let at_radius = |d3: f64, d2: f64| {
            let r = d3 + self.l0_mm;
            Vector3::new(-r * sin, r * cos, d2)
        };
        let at = at_radius(d3, d2);
        let mut base = *q;
        base[0] += steps[0];
        let moved = [
            self.fk(&base).position_mm,
            at_radius(d3, d2 + steps[1]),
            at_radius(d3 + steps[2], d2),
            at,
        ];
        (at, moved)
    }

    fn ik(&self, pose: &Pose, near: Option<&Joints>) -> Result<Joints, KinematicsError> {
        check_finite(pose)?;
        let p = pose.position_mm;
        // Not `hypot`: coordinates in millimetres neither overflow nor underflow, and the
        // library call costs more than the rest of the solution.
        let r = (p.x * p.x + p.y * p.y).sqrt();
        if r < self.min_axis_distance_mm {
            return Err(KinematicsError::NearAxis {
                distance_mm: r,
                min_mm: self.min_axis_distance_mm,
            });
        }
        let mut theta1 = (-p.x).atan2(p.y);
        if let Some(near) = near {
            theta1 = unwrap_near(theta1, near[0]);
        }
        Ok([theta1, p.z, r - self.l0_mm, pose.a_rad - theta1])
    }

    fn check_line(&self, line: &Line) -> Result<(), KinematicsError> {
        check_finite(&line.from)?;
        check_finite(&line.to)?;
        let (nearest, _) = line.xy_radius_range_mm();
        if nearest < self.min_axis_distance_mm {
            return Err(KinematicsError::NearAxis {
                distance_mm: nearest,
                min_mm: self.min_axis_distance_mm,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot() -> Cylindrical {
        Cylindrical {
            l0_mm: 500.0,
            min_axis_distance_mm: 50.0,
        }
    }

    #[test]
    fn seed_p1_has_theta1_near_sixty_degrees() {
        let q = robot()
            .ik(&Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0), None)
            .unwrap();
        assert!(
            (q[0].to_degrees() - 59.9956).abs() < 1e-3,
            "{}",
            q[0].to_degrees()
        );
        assert!((q[1] - 50.0).abs() < 1e-12);
        assert!((q[2] - (926.57f64.hypot(535.03) - 500.0)).abs() < 1e-9);
    }

    proptest::proptest! {
        #[test]
        fn the_moved_poses_shared_are_the_poses_worked_one_by_one(
            q in proptest::array::uniform4(-1e3..1e3_f64),
            steps in proptest::array::uniform4(-1.0..1.0_f64),
        ) {
            let k = robot();
            let (at, moved) = k.fk_moved(&q, &steps);
            proptest::prop_assert_eq!(at, k.fk(&q).position_mm);
            for j in 0..JOINTS {
                let mut m = q;
                m[j] += steps[j];
                proptest::prop_assert_eq!(moved[j], k.fk(&m).position_mm, "joint {}", j);
            }
        }
    }

    #[test]
    fn fk_of_ik_is_the_pose() {
        let k = robot();
        let pose = Pose::from_mm_deg(300.0, -800.0, 120.0, 33.0);
        let back = k.fk(&k.ik(&pose, None).unwrap());
        assert!((back.position_mm - pose.position_mm).norm() < 1e-9);
        assert!((back.a_rad - pose.a_rad).abs() < 1e-12);
    }

    #[test]
    fn theta1_stays_continuous_across_the_back() {
        // Crossing y < 0, x = 0 (theta1 = +-180 deg) must not jump by a turn.
        let k = robot();
        let a = k
            .ik(&Pose::from_mm_deg(-10.0, -900.0, 0.0, 0.0), None)
            .unwrap();
        let b = k
            .ik(&Pose::from_mm_deg(10.0, -900.0, 0.0, 0.0), Some(&a))
            .unwrap();
        assert!((b[0] - a[0]).abs() < 0.1, "{} -> {}", a[0], b[0]);
    }

    #[test]
    fn line_through_the_axis_is_refused() {
        let line = Line {
            from: Pose::from_mm_deg(-600.0, 10.0, 0.0, 0.0),
            to: Pose::from_mm_deg(600.0, 10.0, 0.0, 0.0),
        };
        let err = robot().check_line(&line).unwrap_err();
        assert!(
            err.to_string().contains("10.000 mm from the base axis"),
            "{err}"
        );
    }
}
