//! A tool offset: the planned line of the tool centre, on every kinematics, as the planner's own
//! figures judge it.

use nalgebra::Vector3;

use super::{MoveRequest, Origin, plan_move};
use crate::geometry::{Line, Pose};
use crate::kinematics::{Arm, Cartesian, Elbow, JointKind, Kinematics, Model, Scara};
use crate::robot::{Dynamics, Joint, Method, Robot, seed_robot};
use crate::table::OutputMethod;

fn joint(name: &str, channel: u8, kind: JointKind, step: f64, limit: f64) -> Joint {
    Joint {
        name: name.into(),
        channel,
        kind,
        step: kind.from_user(step),
        offset: 0.0,
        min: kind.from_user(-limit),
        max: kind.from_user(limit),
        max_freq_hz: 100_000,
        output: OutputMethod::PulseSign,
        dynamics: Dynamics::default(),
    }
}

const TOOL_MM: [f64; 3] = [100.0, 40.0, -60.0];

/// The three kinematics with a tool, and a line of each with the tool turning 30 degrees.
fn robots() -> Vec<(Robot, Pose, Pose)> {
    let tool_mm = Vector3::from(TOOL_MM);
    let mut cylindrical = seed_robot();
    cylindrical.kinematics.tool_mm = tool_mm;
    let mut cartesian = seed_robot();
    cartesian.kinematics = Arm {
        model: Model::Cartesian(Cartesian),
        tool_mm,
    };
    cartesian.joints = [
        joint("x", 0, JointKind::Prismatic, 0.01, 2_000.0),
        joint("y", 1, JointKind::Prismatic, 0.01, 2_000.0),
        joint("z", 2, JointKind::Prismatic, 0.01, 2_000.0),
        joint("a", 3, JointKind::Revolute, 0.005, 720.0),
    ];
    let mut scara = seed_robot();
    let model = Model::Scara(Scara {
        l1_mm: 400.0,
        l2_mm: 300.0,
        elbow: Elbow::Left,
        reach_margin_mm: 1.0,
    });
    scara.kinematics = Arm { model, tool_mm };
    scara.joints = [
        joint("t1", 0, JointKind::Revolute, 0.001, 360.0),
        joint("t2", 1, JointKind::Revolute, 0.001, 360.0),
        joint("z", 2, JointKind::Prismatic, 0.01, 1_000.0),
        joint("wrist", 3, JointKind::Revolute, 0.005, 720.0),
    ];
    let line = |a: [f64; 4], b: [f64; 4]| {
        (
            Pose::from_mm_deg(a[0], a[1], a[2], a[3]),
            Pose::from_mm_deg(b[0], b[1], b[2], b[3]),
        )
    };
    let (c0, c1) = line([100.0, 700.0, 100.0, 0.0], [400.0, 1100.0, 150.0, 30.0]);
    let (s0, s1) = line([300.0, 300.0, 100.0, 0.0], [450.0, 300.0, 150.0, 30.0]);
    vec![(cylindrical, c0, c1), (cartesian, c0, c1), (scara, s0, s1)]
}

#[test]
fn the_tool_centres_line_is_straight_within_the_plans_tolerance_on_every_kinematics() {
    let tolerance_mm = 0.05;
    for (robot, from, to) in robots() {
        let mut motion = robot.motion;
        motion.method = Method::BoundedError { tolerance_mm };
        motion.speed_mm_s = 100.0;
        let plan = plan_move(
            &robot,
            &MoveRequest {
                from: Origin::Pose(from),
                to,
                motion,
            },
        )
        .unwrap();
        let name = robot.kinematics.name();
        assert!(plan.valid(), "{name}: {:?}", plan.problems);
        assert!(
            plan.figures.path_deviation_mm <= tolerance_mm,
            "{name}: {:?}",
            plan.figures
        );
        // The end counts put the tool centre on P2 within the pulse grid.
        let end = robot.pose_of(&plan.end_counts());
        assert!(
            (end.position_mm - to.position_mm).norm() < 0.05,
            "{name}: {end:?}"
        );
        // The flange does not run a line while the tool turns: it strays from its chord by many
        // times the tolerance, so the figure above judged the tool centre, not the flange.
        let arm = &robot.kinematics;
        let mid = Line { from, to }.at(Line { from, to }.length_mm() / 2.0);
        let flange = |p: &Pose| arm.model.fk(&arm.ik(p, None).unwrap()).position_mm;
        let chord = Line {
            from: arm.flange(&from),
            to: arm.flange(&to),
        };
        let sag = chord.distance_mm(&flange(&mid));
        assert!(
            sag > 6.0 * tolerance_mm,
            "{name}: the flange runs {sag} mm off its chord"
        );
    }
}

#[test]
fn forward_of_inverse_is_the_pose_with_a_tool_on_every_robot() {
    for (robot, from, to) in robots() {
        for pose in [from, to] {
            let q = robot.kinematics.ik(&pose, None).unwrap();
            let back = robot.kinematics.fk(&q);
            assert!((back.position_mm - pose.position_mm).norm() < 1e-9);
            assert!((back.a_rad - pose.a_rad).abs() < 1e-12);
        }
    }
}
