//! Plans a straight line of a given length a few times, for profilers: the bench's lines
//! (`benches/common/lines.rs`), on the gantry's diagonal or, with `seed` as the fourth argument,
//! 800 mm from the seed robot's axis (up to 2 m); bounded-error 0.05 mm, or constant-period
//! 50 ms with `cp` as the third argument (anything else: bounded-error). Arguments: length in m
//! (default 4), plans (default 5). Prints the rows and a digest of the tables, to compare two
//! builds' plans:
//!
//! `cargo run --release --example length_profile 2 5 be seed`
#[path = "../benches/common/lines.rs"]
mod lines;

use linterpd::plan::plan_line;
use linterpd::robot::seed_robot;
use std::hash::{DefaultHasher, Hash, Hasher};

fn main() {
    let arg = |k: usize| std::env::args().nth(k);
    let length_m: f64 = arg(1).and_then(|a| a.parse().ok()).unwrap_or(4.0);
    let n: usize = arg(2).and_then(|a| a.parse().ok()).unwrap_or(5);
    let (robot, mid, dir) = if arg(4).as_deref() == Some("seed") {
        (seed_robot(), [0.0, 800.0, 150.0], [1.0, 0.0, 0.0])
    } else {
        (lines::gantry(), [0.0; 3], [2.0 / 3.0, 2.0 / 3.0, 1.0 / 3.0])
    };
    let (from, to) = lines::line(mid, dir, length_m * 1e3);
    let mut req = lines::request(&robot, from, to, 0.05);
    if arg(3).as_deref() != Some("cp") {
        req = lines::bounded(&req, 0.05);
    }
    let t = std::time::Instant::now();
    let (mut rows, mut digest) = (0, 0);
    for _ in 0..n {
        let planned = plan_line(&robot, &req).unwrap();
        rows = planned.starts().map(|p| p.figures.rows).sum();
        let mut h = DefaultHasher::new();
        for plan in planned.starts() {
            format!("{:?}", plan.tables).hash(&mut h);
        }
        digest = h.finish();
    }
    println!(
        "{rows} rows (tables' digest {digest:016x}), {:.3} ms per plan",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
