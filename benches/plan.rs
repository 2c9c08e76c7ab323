//! Planning time: the seed's move (50 ms period, bounded-error 0.05 and 0.10 mm) and lines of
//! 0.1, 0.5, 1, 2 and 4 m, each planned, validated and simulated (`plan_line` does all three,
//! and cuts a bounded-error line into starts where a joint's channel needs a later segment),
//! under the `fpx-divider` model. Before timing, the row count of every case is printed (over
//! every start, with how many).
//!
//! The seed's cylindrical robot cannot reach a 4 m line (its radius stays within 500..1500 mm),
//! so the lengths run on it up to 2 m and on a cartesian gantry (0.01 mm steps, +-2.5 m) at all
//! five.
//!
//! An arc: a half circle of radius 100 mm from the seed's P1 at 240 mm/s (path acceleration
//! 1000 mm/s^2), planned with `plan_path`, bounded-error 0.05 mm and constant-period 50 ms.
//!
//! A blended path: ten lines of 200 mm zig-zagging up and down across the seed robot's front
//! (2 m), every waypoint on the way blended by 20 mm, bounded-error 0.05 mm and constant-period
//! 50 ms.
//!
//! Run: `cargo bench --bench plan` (one case: `cargo bench --bench plan -- "seed move"`)

use criterion::{Criterion, criterion_group, criterion_main};
use linterpd::geometry::{ArcBy, Corner, Element, Pose};
use linterpd::plan::{MoveRequest, Origin, PathRequest, plan_line, plan_move, plan_path};
use linterpd::robot::{Method, Robot, seed_robot};
use linterpd::table::FrequencyModel;
use nalgebra::Vector3;
use std::hint::black_box;

#[path = "common/zigzag.rs"]
mod zigzag_path;
use zigzag_path::{path_motion, zigzag_path};
#[path = "common/lines.rs"]
mod lines;
use lines::{bounded, gantry, line, request};

const LENGTHS_MM: [f64; 5] = [100.0, 500.0, 1_000.0, 2_000.0, 4_000.0];

fn rows(robot: &Robot, req: &MoveRequest) -> String {
    let mut out = Vec::new();
    for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
        let mut r = *req;
        r.motion.frequency_model = model;
        let planned = plan_line(robot, &r).expect("plans");
        let starts: Vec<_> = planned.starts().collect();
        let rows: usize = starts.iter().map(|p| p.figures.rows).sum();
        let deviation = starts
            .iter()
            .map(|p| p.figures.path_deviation_mm)
            .fold(0.0, f64::max);
        out.push(format!(
            "{model:?} {rows} rows in {} start(s), path dev. {deviation:.4} mm",
            starts.len()
        ));
    }
    out.join("; ")
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
    let Origin::Pose(metre_from) = metre.from else {
        unreachable!("requests start at a pose")
    };
    assert!((metre.to.position_mm - metre_from.position_mm).norm() - 1000.0 < 0.5);
    // d3 passes range 2's top on it: two starts (`plan_line`).
    eprintln!("1 m move, 10 ms period: {}", rows(&robot, &metre));
    let (b05, b10) = (bounded(&seed, 0.05), bounded(&seed, 0.10));
    let mut seed_exact = seed;
    seed_exact.motion.method = linterpd::robot::Method::SeedExact;
    for (name, r) in [("0.05 mm", &b05), ("0.10 mm", &b10)] {
        eprintln!("seed move bounded-error {name}: {}", rows(&robot, r));
    }
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
    // The same move on a robot whose radial drive follows 1000 mm/s^2 and starts at 1 kHz
    // (every joint with a max_accel): timed time-optimally under the limits.
    let mut limited = robot.clone();
    for (joint, a) in limited
        .joints
        .iter_mut()
        .zip([200.0, 1_000.0, 1_000.0, 200.0])
    {
        joint.dynamics.max_accel = Some(joint.kind.from_user(a));
    }
    limited.joints[2].dynamics.start_hz = Some(1_000.0);
    c.bench_function("plan seed move under drive limits (50 ms period)", |b| {
        b.iter(|| plan_move(&limited, black_box(&seed)).unwrap());
    });
    c.bench_function(
        "plan seed move under drive limits bounded-error 0.05 mm",
        |b| {
            b.iter(|| plan_move(&limited, black_box(&b05)).unwrap());
        },
    );
    c.bench_function("plan 1 m move (10 ms period)", |b| {
        b.iter(|| plan_line(&robot, black_box(&metre)).unwrap());
    });
    lengths(c);
    arc(c);
    zigzag(c);
}

/// The ten-element blended path: starts, rows, path deviation and duration under both models
/// printed, then timed (`fpx-divider`).
fn zigzag(c: &mut Criterion) {
    let robot = seed_robot();
    let cases = [
        (
            "bounded-error 0.05 mm",
            Method::BoundedError { tolerance_mm: 0.05 },
        ),
        ("constant-period 50 ms", Method::ConstantPeriod),
    ];
    for (name, method) in cases {
        let req = zigzag_path(&robot, method);
        let mut out = Vec::new();
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let mut r = req.clone();
            r.motion.frequency_model = model;
            let p = plan_path(&robot, &r).expect("plans");
            let rows: usize = p.starts().map(|s| s.figures.rows).sum();
            out.push(format!(
                "{model:?} {} mm, {} starts, {rows} rows, path dev. {:.4} mm, {:.3} s",
                p.path.length_mm().round(),
                p.starts().count(),
                p.max_deviation_mm(),
                p.duration_s()
            ));
        }
        eprintln!("10 elements 2 m blended {name}: {}", out.join("; "));
        c.bench_function(&format!("plan 10 elements 2 m blended {name}"), |b| {
            b.iter(|| plan_path(&robot, black_box(&req)).unwrap());
        });
    }
}

/// A half circle of radius 100 mm from the seed's P1 (centre 100 mm towards -x, about the
/// z axis, counter-clockwise), 240 mm/s, path acceleration 1000 mm/s^2.
fn half_circle(robot: &Robot, method: Method) -> PathRequest {
    let from = Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0);
    let centre = from.position_mm - Vector3::new(100.0, 0.0, 0.0);
    let to = Pose {
        position_mm: centre - Vector3::new(100.0, 0.0, 0.0),
        a_rad: 0.0,
    };
    PathRequest {
        from: Origin::Pose(from),
        start: None,
        elements: vec![(
            Element::Arc {
                to,
                by: ArcBy::Centre {
                    centre_mm: centre,
                    axis: Vector3::z(),
                    clockwise: false,
                },
            },
            Corner::Stop,
        )],
        motion: path_motion(robot, method),
        path_accel_mm_s2: 1_000.0,
    }
}

/// The half circle, bounded-error 0.05 mm and constant-period 50 ms: rows, path deviation and
/// duration under both models printed, then timed (`fpx-divider`).
fn arc(c: &mut Criterion) {
    let robot = seed_robot();
    let cases = [
        (
            "bounded-error 0.05 mm",
            Method::BoundedError { tolerance_mm: 0.05 },
        ),
        ("constant-period 50 ms", Method::ConstantPeriod),
    ];
    for (name, method) in cases {
        let req = half_circle(&robot, method);
        let mut out = Vec::new();
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let mut r = req.clone();
            r.motion.frequency_model = model;
            let p = plan_path(&robot, &r).expect("plans");
            let rows: usize = p.starts().map(|s| s.figures.rows).sum();
            out.push(format!(
                "{model:?} {rows} rows, path dev. {:.4} mm, {:.3} s",
                p.max_deviation_mm(),
                p.duration_s()
            ));
        }
        eprintln!("arc r 100 mm 180 deg {name}: {}", out.join("; "));
        c.bench_function(&format!("plan arc r 100 mm 180 deg {name}"), |b| {
            b.iter(|| plan_path(&robot, black_box(&req)).unwrap());
        });
    }
}

/// A robot's name, the robot, a line's middle, its direction, the longest length it reaches.
type Case<'a> = (&'a str, &'a Robot, [f64; 3], [f64; 3], f64);

/// Time and rows against length: the seed robot on a line 800 mm from its axis (up to 2 m),
/// the gantry on a diagonal (up to 4 m).
fn lengths(c: &mut Criterion) {
    let seed = seed_robot();
    let gantry = gantry();
    let cases: [Case; 2] = [
        ("seed", &seed, [0.0, 800.0, 150.0], [1.0, 0.0, 0.0], 2_000.0),
        (
            "gantry",
            &gantry,
            [0.0, 0.0, 0.0],
            [2.0 / 3.0, 2.0 / 3.0, 1.0 / 3.0],
            4_000.0,
        ),
    ];
    let mut group = c.benchmark_group("plan length");
    group
        .sample_size(20)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(3));
    for (robot_name, robot, mid, dir, longest) in cases {
        for length_mm in LENGTHS_MM.into_iter().filter(|&l| l <= longest) {
            let (from, to) = line(mid, dir, length_mm);
            let cp = request(robot, from, to, 0.05);
            let b05 = bounded(&cp, 0.05);
            let m = length_mm / 1e3;
            for (method, r) in [
                ("constant-period 50 ms", &cp),
                ("bounded-error 0.05 mm", &b05),
            ] {
                eprintln!("{robot_name} {m} m {method}: {}", rows(robot, r));
                group.bench_function(format!("{robot_name} {m} m {method}"), |b| {
                    b.iter(|| plan_line(robot, black_box(r)).unwrap());
                });
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
