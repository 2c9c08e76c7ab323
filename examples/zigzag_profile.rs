//! Plans the bench's ten-element blended zig-zag (`benches/plan.rs`) a few times, for profilers:
//! bounded-error 0.05 mm, or constant-period 50 ms with `cp` as the second argument.
use linterpd::geometry::{Corner, Element, Pose};
use linterpd::plan::{Origin, PathRequest, plan_path};
use linterpd::robot::{Method, seed_robot};
use linterpd::table::FrequencyModel;

fn main() {
    let robot = seed_robot();
    let from = Pose::from_mm_deg(-800.0, 900.0, 100.0, 0.0);
    let elements = (1..=10)
        .map(|k| {
            let z = if k % 2 == 1 { 220.0 } else { 100.0 };
            let to = Pose::from_mm_deg(-800.0 + 160.0 * f64::from(k), 900.0, z, 0.0);
            let corner = if k == 10 {
                Corner::Stop
            } else {
                Corner::Blend(20.0)
            };
            (Element::Line { to }, corner)
        })
        .collect();
    let mut motion = robot.motion;
    motion.method = if std::env::args().nth(2).as_deref() == Some("cp") {
        Method::ConstantPeriod
    } else {
        Method::BoundedError { tolerance_mm: 0.05 }
    };
    motion.period_s = 0.05;
    motion.frequency_model = FrequencyModel::FpxDivider;
    let req = PathRequest {
        from: Origin::Pose(from),
        elements,
        motion,
        path_accel_mm_s2: 5_000.0,
    };
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
