//! Plans the seed's move under d3's drive limits (`max_accel` 300 mm/s^2, `start_hz` 1000) as a
//! trapezoid and as `s-curve:20000`, under both methods, 30 times each, and prints each plan's
//! duration and the median planning time (for the S-curve: the time-optimal motion averaged,
//! and the S-curve slowed as a whole tried only as far as it could be faster).
//!
//! `cargo run --release --example s_curve_time`
use linterpd::geometry::Pose;
use linterpd::plan::{MoveRequest, Origin, plan_move};
use linterpd::robot::{Dynamics, Method, Ramp, seed_robot};
use std::time::Instant;
fn main() {
    let mut robot = seed_robot();
    robot.joints[2].dynamics = Dynamics {
        max_accel: Some(300.0),
        start_hz: Some(1000.0),
        max_jerk: None,
    };
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let mut to = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0);
    to.a_rad = from.a_rad;
    for method in [
        Method::ConstantPeriod,
        Method::BoundedError { tolerance_mm: 0.05 },
    ] {
        for ramp in [
            Ramp::Trapezoid,
            Ramp::SCurve {
                jerk_mm_s3: 20_000.0,
            },
        ] {
            let mut motion = robot.motion;
            motion.method = method;
            motion.ramp = ramp;
            let req = MoveRequest {
                from: Origin::Pose(from),
                to,
                motion,
            };
            let mut times = Vec::new();
            let mut d = 0.0;
            for _ in 0..30 {
                let t = Instant::now();
                d = plan_move(&robot, &req).unwrap().duration_s();
                times.push(t.elapsed().as_secs_f64() * 1e3);
            }
            times.sort_by(f64::total_cmp);
            println!(
                "{method:?} {ramp:?}: {d:.3} s planned in {:.2} ms (median of 30)",
                times[15]
            );
        }
    }
}
