//! Plans the seed's move a few hundred times (for profilers): bounded-error 0.05 mm (or the
//! tolerance in mm given as the second argument), or constant-period at the robot's period with
//! `cp` as the second argument. With `ratio` as the second argument, plans it bounded-error
//! 0.05 mm and constant-period in turn, timing every plan, and prints both medians and their
//! ratio: interleaved, the two see the same load on a noisy machine (issue 28's goal: at most
//! 1.5x).
use linterpd::geometry::Pose;
use linterpd::plan::{MoveRequest, Origin, plan_move};
use linterpd::robot::{Method, seed_robot};
use std::time::Instant;

fn median_ms(times: &mut [f64]) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2] * 1e3
}

fn main() {
    let robot = seed_robot();
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let mut to = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0);
    to.a_rad = from.a_rad;
    let request = |method: Option<Method>| {
        let mut motion = robot.motion;
        if let Some(method) = method {
            motion.method = method;
        }
        MoveRequest {
            from: Origin::Pose(from),
            to,
            motion,
        }
    };
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let second = std::env::args().nth(2);
    if second.as_deref() == Some("ratio") {
        let bounded = request(Some(Method::BoundedError { tolerance_mm: 0.05 }));
        let constant = request(None);
        let (mut b, mut c) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            for (req, times) in [(&bounded, &mut b), (&constant, &mut c)] {
                let t = Instant::now();
                std::hint::black_box(plan_move(&robot, req).unwrap());
                times.push(t.elapsed().as_secs_f64());
            }
        }
        let (b, c) = (median_ms(&mut b), median_ms(&mut c));
        println!(
            "medians of {n} interleaved plans: bounded-error 0.05 mm {b:.3} ms, \
             constant-period {c:.3} ms, x{:.2}",
            b / c
        );
        return;
    }
    let req = request(
        (second.as_deref() != Some("cp")).then(|| Method::BoundedError {
            tolerance_mm: second.and_then(|a| a.parse().ok()).unwrap_or(0.05),
        }),
    );
    let t = Instant::now();
    let mut rows = 0;
    for _ in 0..n {
        rows = plan_move(&robot, &req).unwrap().figures.rows;
    }
    println!(
        "{rows} rows, {:.3} ms per plan",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
