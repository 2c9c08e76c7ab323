//! How far a bounded-error line leaves its path when the PLC starts a channel's later F174
//! segment up to a scan late (ACCURACY.md), for the bench's seed-robot lines (800 mm from its
//! axis, passing the point nearest it halfway, where its radial joint reverses), bounded-error
//! 0.05 mm (or constant-period 50 ms with `cp` as the argument) under `fpx-divider`: every start
//! of the plan, played with 0, 2 and 10 ms between a channel's segments. Prints one line per
//! start:
//!
//! `cargo run --release --example scan_gap [cp]`
#[allow(dead_code)] // the gantry is not used here
#[path = "../benches/common/lines.rs"]
mod lines;

use linterpd::geometry::Line;
use linterpd::plan::{Origin, plan_line};
use linterpd::robot::seed_robot;
use linterpd::sim;

fn main() {
    let robot = seed_robot();
    for length_mm in [300.0, 500.0, 1_000.0, 2_000.0] {
        let (from, to) = lines::line([0.0, 800.0, 150.0], [1.0, 0.0, 0.0], length_mm);
        let mut req = lines::request(&robot, from, to, 0.05);
        if std::env::args().nth(1).as_deref() != Some("cp") {
            req = lines::bounded(&req, 0.05);
        }
        let Origin::Pose(from) = req.from else {
            unreachable!("the bench's lines start at a pose")
        };
        let line = Line { from, to: req.to };
        let planned = plan_line(&robot, &req).expect("the bench's lines plan");
        let starts: Vec<_> = planned.starts().collect();
        for (k, plan) in starts.iter().enumerate() {
            let segments: Vec<usize> = plan.tables.iter().map(|t| t.segments.len()).collect();
            let deviation = |gap_s: f64| {
                let run = plan.execution_with_scan(gap_s);
                sim::path_deviation_mm(
                    &robot,
                    &plan.start_counts(),
                    run.events.iter().copied(),
                    &line,
                )
            };
            println!(
                "{:.1} m, start {}/{}: {} rows, segments {segments:?}; path deviation \
                 {:.4} / {:.4} / {:.4} mm with 0 / 2 / 10 ms between segments",
                length_mm / 1e3,
                k + 1,
                starts.len(),
                plan.figures.rows,
                deviation(0.0),
                deviation(0.002),
                deviation(0.010)
            );
        }
    }
}
