//! Plans the seed's move under d3's drive limits (`max_accel` 300 mm/s^2, `start_hz` 1000) as a
//! trapezoid and as `s-curve:20000`, under both methods, 30 times each, and prints each plan's
//! duration and the median planning time (for the S-curve: the time-optimal motion averaged,
//! and the S-curve slowed as a whole tried only as far as it could be faster).
//!
//! Then, on the seed robot without drive limits, a lift of 100 mm blended into a level traverse
//! at 240 mm/s under `slow-down`, d2's channel limited to 6 kHz (150 mm/s straight up): the
//! trapezoid slows on the lift alone, and so does `s-curve:5000`, as the time-optimal motion
//! averaged to its jerk.
//!
//! `cargo run --release --example s_curve_time`
use linterpd::geometry::{Corner, Element, Pose};
use linterpd::plan::{MoveRequest, Origin, PathRequest, plan_move, plan_path};
use linterpd::robot::{Dynamics, Method, Motion, OverSpeed, Ramp, seed_robot};
use std::time::Instant;

/// The median of 30 timings of `plan` (ms) and its last result.
fn median_of_30<T>(plan: impl Fn() -> T) -> (f64, T) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..30 {
        let t = Instant::now();
        last = Some(plan());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    (times[15], last.expect("30 plans"))
}

fn lift_and_traverse() {
    let mut robot = seed_robot();
    robot.joints[1].max_freq_hz = 6_000;
    let at = |dz: f64| Pose::from_mm_deg(-926.57, 535.03, 50.0 + dz, 0.0);
    let level = Pose::from_mm_deg(-1144.43, 659.60, 150.0, 0.0);
    for mut motion in motions(&robot.motion, 5_000.0) {
        motion.over_speed = OverSpeed::SlowDown;
        let req = PathRequest {
            from: Origin::Pose(at(0.0)),
            start: None,
            elements: vec![
                (Element::Line { to: at(100.0) }, Corner::Blend(20.0)),
                (Element::Line { to: level }, Corner::Stop),
            ],
            motion,
            path_accel_mm_s2: 5_000.0,
        };
        let (ms, plan) = median_of_30(|| plan_path(&robot, &req).unwrap());
        println!(
            "lift and traverse {:?} {:?}: {:.3} s planned in {ms:.2} ms (median of 30)",
            motion.method,
            motion.ramp,
            plan.duration_s()
        );
    }
}

/// `motion` under constant-period and bounded-error 0.05 mm, each as a trapezoid and as an
/// S-curve of `jerk_mm_s3`.
fn motions(motion: &Motion, jerk_mm_s3: f64) -> Vec<Motion> {
    let methods = [
        Method::ConstantPeriod,
        Method::BoundedError { tolerance_mm: 0.05 },
    ];
    let ramps = [Ramp::Trapezoid, Ramp::SCurve { jerk_mm_s3 }];
    methods
        .into_iter()
        .flat_map(|method| {
            ramps.map(|ramp| Motion {
                method,
                ramp,
                ..*motion
            })
        })
        .collect()
}

fn main() {
    lift_and_traverse();
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
    for motion in motions(&robot.motion, 20_000.0) {
        let req = MoveRequest {
            from: Origin::Pose(from),
            to,
            motion,
        };
        let (ms, plan) = median_of_30(|| plan_move(&robot, &req).unwrap());
        println!(
            "{:?} {:?}: {:.3} s planned in {ms:.2} ms (median of 30)",
            motion.method,
            motion.ramp,
            plan.duration_s()
        );
    }
}
