//! PURE. A hold-to-run jog's pieces, its speed, and how far the robot can go after the last
//! keep-alive.
//!
//! A piece is a `by` order of `speed * piece` along one axis at constant speed (`accel_time =
//! "0s"`): behind the piece before it, the daemon anchors it where that one is planned to end,
//! so pieces add up exactly, and the PLC chains it from its other bank. The speed keeps every
//! channel at or below its drive's `start_hz` where one is set (the drive follows such a step
//! from and to standstill), so a piece may start at speed and a stop (a release, the lease's
//! end) halts it within the drive's limits.
//!
//! Worst-case travel after the last keep-alive, with `v` the jog speed, `T_lease` the lease,
//! `T_exchange` the longest stop write seen, `a` the robot's braking deceleration and `T_commit`
//! the motion the PLC may hold ([`super::lease::LeaseSettings::committed`]):
//! ```text
//!   daemon alive:            v (T_lease + T_exchange) + v^2 / (2 a)
//!   daemon hung, link cut:   v (T_lease + T_commit)   + v^2 / (2 a)
//! ```
//! (With the daemon alive, the lease's end writes a stop, which reaches the PLC within one
//! exchange. A hung daemon or a cut cable writes nothing: the PLC plays what it holds, at most
//! `T_commit` beyond the moment the last piece was given, which was within the lease.)

use serde::Serialize;

use crate::geometry::Pose;
use crate::kinematics::Kinematics;
use crate::order::{MoveOrder, OrderMotion};
use crate::robot::Robot;

use super::lease::JogAxis;

/// The share of a drive's `start_hz` a jog asks for at most (the joints' rates change along a
/// piece; this keeps the whole piece under it).
const START_HZ_SHARE: f64 = 0.9;
/// The step the joints' rates are taken over, mm (or degrees for `a`).
const PROBE_MM: f64 = 0.5;

/// One piece of a jog along `axis` (`positive` or not), `length` mm (degrees for `a`), asked at
/// `speed_mm_s`.
#[must_use]
pub fn piece_order(axis: JogAxis, positive: bool, length: f64, speed_mm_s: f64) -> MoveOrder {
    let signed = if positive { length } else { -length };
    let mut by = vec![0.0; 4];
    match axis {
        JogAxis::X => by[0] = signed,
        JogAxis::Y => by[1] = signed,
        JogAxis::Z => by[2] = signed,
        JogAxis::A | JogAxis::Joint(_) => by[3] = signed,
    }
    MoveOrder {
        by: Some(by),
        motion: OrderMotion {
            speed_mm_s: Some(speed_mm_s),
            accel_time: Some("0s".into()),
            method: Some("constant-period".into()),
            ..OrderMotion::default()
        },
        ..MoveOrder::default()
    }
}

/// The pose `d` mm (degrees for `a`) along `axis` from `pose`.
fn moved(pose: &Pose, axis: JogAxis, d: f64) -> Pose {
    let mut p = *pose;
    match axis {
        JogAxis::X => p.position_mm.x += d,
        JogAxis::Y => p.position_mm.y += d,
        JogAxis::Z => p.position_mm.z += d,
        JogAxis::A | JogAxis::Joint(_) => p.a_rad += d.to_radians(),
    }
    p
}

/// The fastest a jog along `axis` from `pose` keeps every channel at or below
/// [`START_HZ_SHARE`] of its drive's `start_hz` (mm/s, or deg/s for `a`); `None` when no joint
/// has one (or the pose is out of reach: the piece's own plan refuses it then).
#[must_use]
pub fn start_hz_speed(robot: &Robot, pose: &Pose, axis: JogAxis) -> Option<f64> {
    let model = &robot.kinematics;
    let here = model.ik(pose, None).ok()?;
    let ahead = model.ik(&moved(pose, axis, PROBE_MM), Some(&here)).ok()?;
    let mut cap: Option<f64> = None;
    for (j, joint) in robot.joints.iter().enumerate() {
        let Some(start_hz) = joint.dynamics.start_hz else {
            continue;
        };
        // Pulses per mm of the jog on this joint's channel.
        let per_mm = ((ahead[j] - here[j]) / joint.step).abs() / PROBE_MM;
        if per_mm > 0.0 {
            let v = START_HZ_SHARE * start_hz / per_mm;
            cap = Some(cap.map_or(v, |c| c.min(v)));
        }
    }
    cap
}

/// How far the robot may go after the last keep-alive, mm (degrees for `a`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Travel {
    /// With the daemon alive: it writes a stop when the lease ends.
    pub alive_mm: f64,
    /// With the daemon hung or the PLC's cable cut: the PLC plays what it holds.
    pub hung_mm: f64,
}

/// The figures the worst case is computed from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TravelInputs {
    /// The jog's speed, mm/s.
    pub speed_mm_s: f64,
    /// The lease, s.
    pub lease_s: f64,
    /// The longest stop write seen (or assumed), s.
    pub exchange_s: f64,
    /// The motion the PLC may hold, s.
    pub committed_s: f64,
    /// The braking deceleration, mm/s^2.
    pub brake_mm_s2: f64,
}

impl TravelInputs {
    /// The worst-case travel after the last keep-alive.
    #[must_use]
    pub fn travel(&self) -> Travel {
        let v = self.speed_mm_s;
        let brake = if self.brake_mm_s2 > 0.0 {
            v * v / (2.0 * self.brake_mm_s2)
        } else {
            0.0
        };
        Travel {
            alive_mm: v * (self.lease_s + self.exchange_s) + brake,
            hung_mm: v * (self.lease_s + self.committed_s) + brake,
        }
    }
}

/// A robot's braking deceleration as the worst case takes it: its default motion's
/// (`speed_mm_s / accel_time`), mm/s^2; 0 with no ramp (the channels stop at once).
#[must_use]
pub fn brake_mm_s2(robot: &Robot) -> f64 {
    let m = &robot.motion;
    if m.accel_s > 0.0 {
        m.speed_mm_s / m.accel_s
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::seed_robot;

    #[test]
    fn the_console_md_example_is_about_19_mm() {
        // CONSOLE.md: 50 mm/s, a 300 ms lease, a 70 ms exchange: about 19 mm before braking.
        let t = TravelInputs {
            speed_mm_s: 50.0,
            lease_s: 0.3,
            exchange_s: 0.07,
            committed_s: 0.3,
            brake_mm_s2: 0.0,
        }
        .travel();
        assert!((t.alive_mm - 18.5).abs() < 1e-9, "{t:?}");
        assert!((t.hung_mm - 30.0).abs() < 1e-9, "{t:?}");
        let braking = TravelInputs {
            brake_mm_s2: 1250.0,
            ..TravelInputs {
                speed_mm_s: 50.0,
                lease_s: 0.3,
                exchange_s: 0.07,
                committed_s: 0.3,
                brake_mm_s2: 0.0,
            }
        }
        .travel();
        assert!((braking.alive_mm - 19.5).abs() < 1e-9, "{braking:?}");
    }

    #[test]
    fn a_piece_is_a_constant_speed_line_along_its_axis() {
        let o = piece_order(JogAxis::Y, false, 7.5, 50.0);
        assert_eq!(o.by, Some(vec![0.0, -7.5, 0.0, 0.0]));
        assert_eq!(o.motion.accel_time.as_deref(), Some("0s"));
        assert_eq!(o.motion.speed_mm_s, Some(50.0));
        let checked = o.check(seed_robot().motion).unwrap();
        assert!(checked.motion.accel_s.abs() < 1e-12);
    }

    #[test]
    fn the_start_hz_speed_keeps_every_channel_under_its_drive() {
        let mut robot = seed_robot();
        let pose = Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0);
        assert_eq!(start_hz_speed(&robot, &pose, JogAxis::X), None);
        for joint in &mut robot.joints {
            joint.dynamics.start_hz = Some(1000.0);
        }
        for axis in [JogAxis::X, JogAxis::Y, JogAxis::Z] {
            let v = start_hz_speed(&robot, &pose, axis).unwrap();
            // Every channel's rate over a short stretch at that speed.
            let model = &robot.kinematics;
            let here = model.ik(&pose, None).unwrap();
            let ahead = model.ik(&moved(&pose, axis, 0.1), Some(&here)).unwrap();
            let highest = (0..4)
                .map(|j| ((ahead[j] - here[j]) / robot.joints[j].step).abs() / 0.1 * v)
                .fold(0.0, f64::max);
            assert!(
                (highest - 900.0).abs() < 5.0,
                "{axis:?}: {highest} Hz at {v} mm/s"
            );
        }
    }
}
