//! Plans the bench's ten-element blended zig-zag (`benches/common/zigzag.rs`) a few times, for
//! profilers: bounded-error 0.05 mm, or constant-period 50 ms with `cp` as the second argument;
//! with `s-curve:J` as the third, S-curve ramps of jerk J mm/s^3.
//!
//! `cargo run --release --example zigzag_profile -- 20 cp s-curve:20000`
#[path = "../benches/common/zigzag.rs"]
mod zigzag;

use linterpd::plan::plan_path;
use linterpd::robot::{Method, Ramp, seed_robot};

fn main() {
    let robot = seed_robot();
    let method = if std::env::args().nth(2).as_deref() == Some("cp") {
        Method::ConstantPeriod
    } else {
        Method::BoundedError { tolerance_mm: 0.05 }
    };
    let mut req = zigzag::zigzag_path(&robot, method);
    if let Some(jerk) = std::env::args()
        .nth(3)
        .and_then(|a| a.strip_prefix("s-curve:")?.parse().ok())
    {
        req.motion.ramp = Ramp::SCurve { jerk_mm_s3: jerk };
    }
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    let t = std::time::Instant::now();
    let (mut rows, mut duration_s) = (0, 0.0);
    for _ in 0..n {
        let p = plan_path(&robot, &req).unwrap();
        rows = p.starts().map(|s| s.figures.rows).sum::<usize>();
        duration_s = p.duration_s();
    }
    println!(
        "{rows} rows, {duration_s:.3} s, {:.3} ms per plan",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
