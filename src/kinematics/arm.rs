//! A robot's kinematics with its tool: the [`Model`] moves the flange, and the tool centre sits
//! `tool_mm` from it in the flange's frame, turning with the tool angle a (on all three models a
//! is the flange's turn about world z):
//! ```text
//! tool centre = flange + Rz(a) * tool_mm        flange = tool centre - Rz(a) * tool_mm
//! ```
//! Every pose linterpd plans, checks and reports is the tool centre's: [`Arm`]'s forward and
//! inverse kinematics are the model's with the offset applied, so the planner's lines, its
//! accuracy figures and taught positions all judge the tool centre. With no offset it is the
//! model itself, bit for bit.

use std::ops::Deref;

use nalgebra::Vector3;

use super::{JOINTS, JointKind, Joints, Kinematics, KinematicsError, Model, check_finite};
use crate::geometry::{Line, Pose};

/// The longest stretch of tool-centre travel between the flange poses [`Arm::check_line`]
/// checks a line of a turning tool at, mm.
pub(super) const CHECK_STEP_MM: f64 = 1.0;
/// The largest turn of the tool between those poses, radians.
pub(super) const CHECK_STEP_RAD: f64 = 0.01;

/// A model and the tool on its flange.
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// The model, which places the flange.
    pub model: Model,
    /// The tool centre from the flange, mm, in the flange's frame (x, y turn with the tool).
    pub tool_mm: Vector3<f64>,
}

impl From<Model> for Arm {
    fn from(model: Model) -> Self {
        Self {
            model,
            tool_mm: Vector3::zeros(),
        }
    }
}

impl Deref for Arm {
    type Target = Model;
    fn deref(&self) -> &Model {
        &self.model
    }
}

impl Arm {
    /// Whether a tool offset is set.
    #[must_use]
    pub fn has_tool(&self) -> bool {
        self.tool_mm != Vector3::zeros()
    }

    /// The offset turned by the tool angle `a_rad`, world mm.
    #[must_use]
    pub fn offset_at(&self, a_rad: f64) -> Vector3<f64> {
        let (s, c) = a_rad.sin_cos();
        let t = self.tool_mm;
        Vector3::new(c * t.x - s * t.y, s * t.x + c * t.y, t.z)
    }

    /// The flange pose that puts the tool centre at `tool`.
    #[must_use]
    pub fn flange(&self, tool: &Pose) -> Pose {
        if !self.has_tool() {
            return *tool;
        }
        Pose {
            position_mm: tool.position_mm - self.offset_at(tool.a_rad),
            a_rad: tool.a_rad,
        }
    }

    /// The tool centre of a flange pose.
    #[must_use]
    pub fn tool(&self, flange: &Pose) -> Pose {
        if !self.has_tool() {
            return *flange;
        }
        Pose {
            position_mm: flange.position_mm + self.offset_at(flange.a_rad),
            a_rad: flange.a_rad,
        }
    }
}

impl Kinematics for Arm {
    fn name(&self) -> &'static str {
        self.model.name()
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        self.model.params()
    }
    fn joint_kinds(&self) -> [JointKind; JOINTS] {
        self.model.joint_kinds()
    }
    fn fk(&self, q: &Joints) -> Pose {
        self.tool(&self.model.fk(q))
    }
    fn fk_moved(&self, q: &Joints, steps: &Joints) -> (Vector3<f64>, [Vector3<f64>; JOINTS]) {
        if !self.has_tool() {
            return self.model.fk_moved(q, steps);
        }
        let at = self.fk(q).position_mm;
        let moved = std::array::from_fn(|j| {
            let mut m = *q;
            m[j] += steps[j];
            self.fk(&m).position_mm
        });
        (at, moved)
    }
    fn ik(&self, pose: &Pose, near: Option<&Joints>) -> Result<Joints, KinematicsError> {
        check_finite(pose)?;
        self.model.ik(&self.flange(pose), near)
    }

    /// The tool centre's line: with the tool angle constant the flange runs a line too, checked
    /// as the model checks one; while the tool turns the flange runs a curve, checked as chords
    /// between its poses at most [`CHECK_STEP_MM`] of tool travel and [`CHECK_STEP_RAD`] of
    /// turn apart (a chord's sag there is far below a millimetre).
    fn check_line(&self, line: &Line) -> Result<(), KinematicsError> {
        let turn = (line.to.a_rad - line.from.a_rad).abs();
        if !self.has_tool() || turn == 0.0 {
            let flange = Line {
                from: self.flange(&line.from),
                to: self.flange(&line.to),
            };
            return self.model.check_line(&flange);
        }
        let length = line.length_mm();
        let steps = ((length / CHECK_STEP_MM).max(turn / CHECK_STEP_RAD).ceil() as usize).max(1);
        let at = |i: usize| {
            let u = i as f64 / steps as f64;
            let p = line.from.position_mm + (line.to.position_mm - line.from.position_mm) * u;
            let a = line.from.a_rad + (line.to.a_rad - line.from.a_rad) * u;
            self.flange(&Pose {
                position_mm: p,
                a_rad: a,
            })
        };
        let mut from = at(0);
        for i in 1..=steps {
            let to = at(i);
            self.model.check_line(&Line { from, to })?;
            from = to;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Cartesian, Cylindrical, Elbow, Scara};

    fn arms() -> Vec<Arm> {
        let tool_mm = Vector3::new(120.0, -30.0, -80.0);
        [
            Model::Cylindrical(Cylindrical {
                l0_mm: 500.0,
                min_axis_distance_mm: 50.0,
            }),
            Model::Cartesian(Cartesian),
            Model::Scara(Scara {
                l1_mm: 400.0,
                l2_mm: 300.0,
                elbow: Elbow::Left,
                reach_margin_mm: 1.0,
            }),
        ]
        .into_iter()
        .map(|model| Arm { model, tool_mm })
        .collect()
    }

    #[test]
    fn forward_of_inverse_is_the_tool_centre_on_every_model() {
        for arm in arms() {
            for (x, y, z, a) in [
                (350.0, 420.0, 50.0, 0.0),
                (-500.0, 300.0, -20.0, 135.0),
                (200.0, 550.0, 10.0, -60.0),
            ] {
                let pose = Pose::from_mm_deg(x, y, z, a);
                let q = arm.ik(&pose, None).unwrap();
                let back = arm.fk(&q);
                assert!(
                    (back.position_mm - pose.position_mm).norm() < 1e-9,
                    "{arm:?} {pose:?} {back:?}"
                );
                assert!((back.a_rad - pose.a_rad).abs() < 1e-12);
                // The flange sits the offset, turned by a, away from the tool centre.
                let flange = arm.model.fk(&q).position_mm;
                assert!(
                    ((pose.position_mm - flange).norm() - 120f64.hypot(30.0).hypot(80.0)).abs()
                        < 1e-9
                );
            }
        }
    }

    #[test]
    fn a_turning_tool_swings_its_flange_onto_the_axis_and_the_check_sees_it() {
        // Cylindrical: the tool centre stays at (0, 200); turning half a turn with a 150 mm
        // offset swings the flange from (-150, 200) through (0, 50), 50 mm from the axis, to
        // (150, 200): both ends are reachable, the middle is not.
        let arm = Arm {
            model: Model::Cylindrical(Cylindrical {
                l0_mm: 0.0,
                min_axis_distance_mm: 60.0,
            }),
            tool_mm: Vector3::new(150.0, 0.0, 0.0),
        };
        let from = Pose::from_mm_deg(0.0, 200.0, 0.0, 0.0);
        let to = Pose::from_mm_deg(0.0, 200.0, 0.0, 180.0);
        assert!(arm.ik(&from, None).is_ok() && arm.ik(&to, None).is_ok());
        let e = arm.check_line(&Line { from, to }).unwrap_err();
        assert!(matches!(e, KinematicsError::NearAxis { .. }), "{e}");
    }
}
