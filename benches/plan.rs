//! Planning time: the seed's move (50 ms period) and a 1 m move at a 10 ms period, each planned,
//! validated and simulated (`plan_move` does all three), under the `fpx-divider` model.
//!
//! Run: `cargo bench --bench plan`

use criterion::{Criterion, criterion_group, criterion_main};
use linterpd::geometry::Pose;
use linterpd::plan::{MoveRequest, Origin, plan_move};
use linterpd::robot::{Robot, seed_robot};
use std::hint::black_box;

fn request(robot: &Robot, from: [f64; 3], to: [f64; 3], period_s: f64) -> MoveRequest {
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
        seed_exact: false,
    }
}

fn bench(c: &mut Criterion) {
    let robot = seed_robot();
    let seed = request(
        &robot,
        [-926.57, 535.03, 50.0],
        [-1144.43, 659.60, 186.60],
        0.05,
    );
    // 1 m: from (-600, 700, 10) to (-1300, 100, 397.30), 1000.0 mm long, at 240 mm/s.
    let metre = request(
        &robot,
        [-600.0, 700.0, 10.0],
        [-1300.0, 100.0, 397.30],
        0.01,
    );
    assert!((plan_move(&robot, &metre).expect("plans").line.length_mm() - 1000.0).abs() < 0.5);
    let bounded = |tolerance_mm| {
        let mut r = seed;
        r.motion.method = linterpd::robot::Method::BoundedError { tolerance_mm };
        r
    };
    let (b05, b10) = (bounded(0.05), bounded(0.10));
    let mut seed_exact = seed;
    seed_exact.seed_exact = true;
    c.bench_function("plan seed move seed-exact", |b| {
        b.iter(|| plan_move(&robot, black_box(&seed_exact)).unwrap());
    });
    c.bench_function("plan seed move bounded-error 0.05 mm", |b| {
        b.iter(|| plan_move(&robot, black_box(&b05)).unwrap());
    });
    c.bench_function("plan seed move bounded-error 0.10 mm", |b| {
        b.iter(|| plan_move(&robot, black_box(&b10)).unwrap());
    });
    c.bench_function("plan seed move (50 ms period)", |b| {
        b.iter(|| plan_move(&robot, black_box(&seed)).unwrap());
    });
    c.bench_function("plan 1 m move (10 ms period)", |b| {
        b.iter(|| plan_move(&robot, black_box(&metre)).unwrap());
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
