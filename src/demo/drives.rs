//! The demo's drive-limits comparison (planned, not run): one line passing 100 mm from the base
//! axis of a cylindrical robot with a 50 mm arm, its base channel at 20 kHz, under `slow-down`.
//! Without drive limits the whole line is slowed to what the base channel allows where it
//! turns fastest; with them (every joint's `max_accel`) it is timed time-optimally, slower only
//! near the axis.

use std::io::{self, Write};

use crate::geometry::Pose;
use crate::plan::{MoveRequest, Origin, PlanError, plan_line};
use crate::robot::{Dynamics, OverSpeed, Robot, short_arm};

/// The two plans of the line, side by side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveComparison {
    /// The line's duration under whole-move slow-down, s.
    pub slowed_s: f64,
    /// The speed slow-down kept, of the speed asked for.
    pub speed_factor: f64,
    /// Its duration timed under the drive limits, s.
    pub timed_s: f64,
    /// The base channel's fastest row in each, Hz.
    pub peak_hz: [f64; 2],
}

/// The short-armed robot under `slow-down`, with drive limits or without.
fn robot(limited: bool) -> Robot {
    let mut robot = short_arm(OverSpeed::SlowDown);
    if limited {
        for (joint, a) in robot
            .joints
            .iter_mut()
            .zip([2_000.0, 5_000.0, 5_000.0, 2_000.0])
        {
            joint.dynamics = Dynamics {
                max_accel: Some(joint.kind.from_user(a)),
                start_hz: None,
                max_jerk: None,
            };
        }
    }
    robot
}

/// Plans the line 400 mm long, 100 mm from the axis, ending nearest it, both ways.
pub fn compare() -> Result<DriveComparison, PlanError> {
    let plan = |limited: bool| {
        let robot = robot(limited);
        let from = robot.pose_with_wrist_at_zero(-400.0, 100.0, 100.0)?;
        let mut to = Pose::from_mm_deg(0.0, 100.0, 100.0, 0.0);
        to.a_rad = from.a_rad;
        let req = MoveRequest {
            from: Origin::Pose(from),
            to,
            motion: robot.motion,
        };
        plan_line(&robot, &req)
    };
    let (slowed, timed) = (plan(false)?, plan(true)?);
    let sum = |p: &crate::plan::MovePlan| p.starts().map(crate::plan::Plan::duration_s).sum();
    let peak =
        |p: &crate::plan::MovePlan| p.starts().map(|s| s.drive[0].peak_hz).fold(0.0, f64::max);
    Ok(DriveComparison {
        slowed_s: sum(&slowed),
        speed_factor: slowed.starts().map(|s| s.speed_factor).fold(1.0, f64::min),
        timed_s: sum(&timed),
        peak_hz: [peak(&slowed), peak(&timed)],
    })
}

/// Writes the comparison.
pub fn write(c: &DriveComparison, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out)?;
    writeln!(
        out,
        "Drive limits (planned): a 400 mm line ending 100 mm from the base axis of a robot with a \
         50 mm arm, base channel 20 kHz, 240 mm/s asked:"
    )?;
    writeln!(
        out,
        "  whole-move slow-down        {:.3} s (the whole line at {:.0} % of the speed), base \
         channel at most {:.0} Hz",
        c.slowed_s,
        c.speed_factor * 100.0,
        c.peak_hz[0]
    )?;
    writeln!(
        out,
        "  time-optimal, drive limits  {:.3} s (slower only near the axis), base channel at \
         most {:.0} Hz: {:.2}x faster",
        c.timed_s,
        c.peak_hz[1],
        c.slowed_s / c.timed_s
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_optimal_line_is_faster_than_the_slowed_one_and_both_keep_the_channel() {
        let c = compare().unwrap();
        assert!(c.speed_factor < 0.5, "{c:?}");
        assert!(c.slowed_s / c.timed_s > 1.5, "{c:?}");
        assert!(c.peak_hz.iter().all(|&hz| hz <= 20_000.0), "{c:?}");
        let mut text = Vec::new();
        write(&c, &mut text).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(text.contains("x faster"), "{text}");
    }
}
