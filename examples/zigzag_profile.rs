//! Plans the bench's ten-element blended zig-zag (`benches/common/zigzag.rs`) a few times, for
//! profilers: bounded-error 0.05 mm, or constant-period 50 ms with `cp` as the second argument.
#[path = "../benches/common/zigzag.rs"]
mod zigzag;

use linterpd::plan::plan_path;
use linterpd::robot::{Method, seed_robot};

fn main() {
    let robot = seed_robot();
    let method = if std::env::args().nth(2).as_deref() == Some("cp") {
        Method::ConstantPeriod
    } else {
        Method::BoundedError { tolerance_mm: 0.05 }
    };
    let req = zigzag::zigzag_path(&robot, method);
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    let t = std::time::Instant::now();
    let mut rows = 0;
    for _ in 0..n {
        let p = plan_path(&robot, &req).unwrap();
        rows = p.starts().map(|s| s.figures.rows).sum::<usize>();
    }
    println!(
        "{rows} rows, {:.3} ms per plan",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
