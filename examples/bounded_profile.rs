//! Plans the seed's move a few hundred times (for profilers): bounded-error 0.05 mm (or the
//! tolerance in mm given as the second argument), or constant-period at the robot's period with
//! `cp` as the second argument.
use linterpd::geometry::Pose;
use linterpd::plan::{MoveRequest, Origin, plan_move};
use linterpd::robot::{Method, seed_robot};

fn main() {
    let robot = seed_robot();
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let mut to = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0);
    to.a_rad = from.a_rad;
    let mut motion = robot.motion;
    let second = std::env::args().nth(2);
    if second.as_deref() != Some("cp") {
        let tolerance_mm = second.and_then(|a| a.parse().ok()).unwrap_or(0.05);
        motion.method = Method::BoundedError { tolerance_mm };
    }
    let req = MoveRequest {
        from: Origin::Pose(from),
        to,
        motion,
    };
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let t = std::time::Instant::now();
    let mut rows = 0;
    for _ in 0..n {
        rows = plan_move(&robot, &req).unwrap().figures.rows;
    }
    println!(
        "{rows} rows, {:.3} ms per plan",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
