//! The ten-element blended zig-zag the planning bench times (`benches/plan.rs`) and the
//! profiling example plans (`examples/zigzag_profile.rs`).

use linterpd::geometry::{Corner, Element, Pose};
use linterpd::plan::{Origin, PathRequest};
use linterpd::robot::{Method, Motion, Robot};
use linterpd::table::FrequencyModel;

/// Ten lines of 200 mm (160 mm along x, 120 mm up or down) from (-800, 900, 100), every
/// waypoint but the last blended by 20 mm: 2 m on the seed robot, 240 mm/s, Ta 200 ms, path
/// acceleration 5000 mm/s^2.
pub(crate) fn zigzag_path(robot: &Robot, method: Method) -> PathRequest {
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
    PathRequest {
        from: Origin::Pose(from),
        start: None,
        elements,
        motion: path_motion(robot, method),
        path_accel_mm_s2: 5_000.0,
    }
}

/// The robot's motion as the bench's paths run it: `method`, a 50 ms period, `fpx-divider`.
pub(crate) fn path_motion(robot: &Robot, method: Method) -> Motion {
    let mut motion = robot.motion;
    motion.method = method;
    motion.period_s = 0.05;
    motion.frequency_model = FrequencyModel::FpxDivider;
    motion
}
