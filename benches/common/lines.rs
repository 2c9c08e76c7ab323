//! Straight-line moves the planning bench times (`benches/plan.rs`) and the length profiling
//! example plans (`examples/length_profile.rs`): a move between two points with the wrist at
//! zero, and a cartesian gantry that reaches 4 m lines.

use linterpd::geometry::Pose;
use linterpd::kinematics::{Cartesian, JointKind, Model};
use linterpd::plan::{MoveRequest, Origin};
use linterpd::robot::{Joint, Method, Robot, seed_robot};
use linterpd::table::OutputMethod;

pub(crate) fn request(robot: &Robot, from: [f64; 3], to: [f64; 3], period_s: f64) -> MoveRequest {
    let start = robot
        .pose_with_wrist_at_zero(from[0], from[1], from[2])
        .expect("reachable");
    let mut end = Pose::from_mm_deg(to[0], to[1], to[2], 0.0);
    end.a_rad = start.a_rad;
    let mut motion = robot.motion;
    motion.period_s = period_s;
    MoveRequest {
        from: Origin::Pose(start),
        to: end,
        motion,
    }
}

pub(crate) fn bounded(req: &MoveRequest, tolerance_mm: f64) -> MoveRequest {
    let mut r = *req;
    r.motion.method = Method::BoundedError { tolerance_mm };
    r
}

/// A cartesian gantry: x, y 0.01 mm, z 0.02 mm, a 0.01 deg, +-2500 mm.
pub(crate) fn gantry() -> Robot {
    let joint =
        |name: &str, channel: u8, kind: JointKind, step: f64, limit: f64, max_freq_hz: u32| Joint {
            name: String::from(name),
            channel,
            kind,
            step: kind.from_user(step),
            offset: 0.0,
            min: kind.from_user(-limit),
            max: kind.from_user(limit),
            max_freq_hz,
            output: OutputMethod::PulseSign,
            dynamics: linterpd::robot::Dynamics::default(),
        };
    let mut robot = seed_robot();
    robot.name = "gantry".into();
    robot.kinematics = Model::Cartesian(Cartesian).into();
    robot.joints = [
        joint("x", 0, JointKind::Prismatic, 0.01, 2_500.0, 100_000),
        joint("y", 1, JointKind::Prismatic, 0.01, 2_500.0, 100_000),
        joint("z", 2, JointKind::Prismatic, 0.02, 2_500.0, 20_000),
        joint("a", 3, JointKind::Revolute, 0.01, 720.0, 20_000),
    ];
    robot
}

/// A line of `length_mm` centred on `mid` along the unit vector `dir`.
pub(crate) fn line(mid: [f64; 3], dir: [f64; 3], length_mm: f64) -> ([f64; 3], [f64; 3]) {
    let h = length_mm / 2.0;
    (
        std::array::from_fn(|i| mid[i] - dir[i] * h),
        std::array::from_fn(|i| mid[i] + dir[i] * h),
    )
}
