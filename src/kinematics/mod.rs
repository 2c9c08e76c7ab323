//! PURE. Forward and inverse kinematics behind one trait, for the robots linterpd drives.
//!
//! Every model has four joints, in this order, each driven by one pulse channel:
//! - `cylindrical` (the seed's press loader, eqs. 8-9): theta1 (rad), d2 = z (mm), d3 = radial
//!   extension (mm), wrist (rad) = a - theta1;
//! - `cartesian`: X, Y, Z (mm), A (rad) = a;
//! - `scara`: theta1, theta2 (rad), Z (mm), wrist (rad) = a - theta1 - theta2.
//!
//! Joint values are in radians or millimetres ([`JointKind`]); degrees only at the user's edge.

mod arm;
mod cartesian;
mod cylindrical;
mod positions;
mod scara;

pub use arm::Arm;
pub use cartesian::Cartesian;
pub use cylindrical::Cylindrical;
pub use positions::Positions;
pub use scara::{Elbow, Scara};

use nalgebra::Vector3;
use thiserror::Error;

use crate::geometry::{Line, Pose};

/// Joints every model has.
pub const JOINTS: usize = 4;

/// Joint values, radians or millimetres by [`JointKind`].
pub type Joints = [f64; JOINTS];

/// What a joint's value measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// An angle, radians.
    Revolute,
    /// A length, millimetres.
    Prismatic,
}

impl JointKind {
    /// The unit of a joint value inside linterpd.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            Self::Revolute => "rad",
            Self::Prismatic => "mm",
        }
    }

    /// The unit the user writes (config, CLI, API).
    #[must_use]
    pub fn user_unit(self) -> &'static str {
        match self {
            Self::Revolute => "deg",
            Self::Prismatic => "mm",
        }
    }

    /// A user value (degrees or mm) in internal units.
    #[must_use]
    pub fn from_user(self, value: f64) -> f64 {
        match self {
            Self::Revolute => value.to_radians(),
            Self::Prismatic => value,
        }
    }

    /// An internal value in the user's units.
    #[must_use]
    pub fn to_user(self, value: f64) -> f64 {
        match self {
            Self::Revolute => value.to_degrees(),
            Self::Prismatic => value,
        }
    }
}

/// Why a pose or a path cannot be reached.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum KinematicsError {
    /// A pose coordinate is NaN or infinite.
    #[error("pose coordinate {axis} is {value}; it must be a finite number")]
    NotFinite {
        /// x, y, z or a.
        axis: &'static str,
        /// The value.
        value: f64,
    },
    /// The path passes the cylindrical robot's vertical axis closer than allowed.
    #[error(
        "the line passes {distance_mm:.3} mm from the base axis (x = y = 0); theta1 is singular \
         there and at least {min_mm} mm is required"
    )]
    NearAxis {
        /// Closest approach, mm.
        distance_mm: f64,
        /// The configured minimum, mm.
        min_mm: f64,
    },
    /// A pose outside the SCARA's reachable annulus.
    #[error(
        "the line reaches {radius_mm:.3} mm from the base axis; this scara reaches {min_mm:.3} to \
         {max_mm:.3} mm with its elbow kept {elbow}"
    )]
    OutOfReach {
        /// Offending radius, mm.
        radius_mm: f64,
        /// Inner reach, mm.
        min_mm: f64,
        /// Outer reach, mm.
        max_mm: f64,
        /// The elbow side.
        elbow: Elbow,
    },
}

/// Forward and inverse kinematics of one robot model.
pub trait Kinematics {
    /// The model's name as written in config (`cylindrical`, `cartesian`, `scara`).
    fn name(&self) -> &'static str;

    /// The dimensions that define the model, in mm, for reports.
    fn params(&self) -> Vec<(&'static str, f64)>;

    /// What each joint measures.
    fn joint_kinds(&self) -> [JointKind; JOINTS];

    /// The pose the joints put the tool in.
    fn fk(&self, q: &Joints) -> Pose;

    /// Where the joints put the tool, and where each joint moved by `steps[j]` alone puts it:
    /// [`Self::fk`] at `q` and at each moved `q`, bit for bit. A model may share the work
    /// between them (the bounded-error method's budget reads a pulse of every joint at a
    /// hundred points of every move).
    fn fk_moved(&self, q: &Joints, steps: &Joints) -> (Vector3<f64>, [Vector3<f64>; JOINTS]) {
        let at = self.fk(q).position_mm;
        let moved = std::array::from_fn(|j| {
            let mut m = *q;
            m[j] += steps[j];
            self.fk(&m).position_mm
        });
        (at, moved)
    }

    /// Joint values for a pose. Revolute joints are taken on the turn nearest `near` (the
    /// previous point of a path), so a path never jumps by a full turn; with no `near`, angles
    /// fall in (-pi, pi].
    fn ik(&self, pose: &Pose, near: Option<&Joints>) -> Result<Joints, KinematicsError>;

    /// Checks the whole straight line, not only its end points: singularities and reach.
    fn check_line(&self, line: &Line) -> Result<(), KinematicsError>;
}

/// The kinematic model of a configured robot.
#[derive(Debug, Clone, PartialEq)]
pub enum Model {
    /// The seed's R-P-P + wrist robot.
    Cylindrical(Cylindrical),
    /// X, Y, Z gantry plus a rotary A.
    Cartesian(Cartesian),
    /// Two revolute arms, Z and a wrist.
    Scara(Scara),
}

impl Model {
    fn inner(&self) -> &dyn Kinematics {
        match self {
            Self::Cylindrical(k) => k,
            Self::Cartesian(k) => k,
            Self::Scara(k) => k,
        }
    }
}

impl Kinematics for Model {
    fn name(&self) -> &'static str {
        self.inner().name()
    }
    fn params(&self) -> Vec<(&'static str, f64)> {
        self.inner().params()
    }
    fn joint_kinds(&self) -> [JointKind; JOINTS] {
        self.inner().joint_kinds()
    }
    fn fk(&self, q: &Joints) -> Pose {
        self.inner().fk(q)
    }
    fn fk_moved(&self, q: &Joints, steps: &Joints) -> (Vector3<f64>, [Vector3<f64>; JOINTS]) {
        self.inner().fk_moved(q, steps)
    }
    fn ik(&self, pose: &Pose, near: Option<&Joints>) -> Result<Joints, KinematicsError> {
        self.inner().ik(pose, near)
    }
    fn check_line(&self, line: &Line) -> Result<(), KinematicsError> {
        self.inner().check_line(line)
    }
}

/// Checks that every coordinate of a pose is finite.
pub fn check_finite(pose: &Pose) -> Result<(), KinematicsError> {
    let p = pose.position_mm;
    for (axis, value) in [("x", p.x), ("y", p.y), ("z", p.z), ("a", pose.a_rad)] {
        if !value.is_finite() {
            return Err(KinematicsError::NotFinite { axis, value });
        }
    }
    Ok(())
}

/// The angle equal to `angle` modulo a full turn that lies nearest `near`.
#[must_use]
pub fn unwrap_near(angle: f64, near: f64) -> f64 {
    let turn = std::f64::consts::TAU;
    // Planning unwraps every millisecond sample, most often less than a half turn from the
    // last: no turn, without the division (`+ 0.0` as the sum with no turns makes it).
    if (near - angle).abs() < 3.0 {
        return angle + 0.0;
    }
    // Whole turns, rounded as `round` does without its library call.
    angle + nearest_count((near - angle) / turn) as f64 * turn
}

/// `x.round() as i64` (halves away from zero), without the call `round` is on a plain x86-64
/// target: the truncation is one instruction and the fraction it leaves is exact. Planning
/// rounds every joint at every millisecond sample.
#[must_use]
pub fn nearest_count(x: f64) -> i64 {
    if x.is_nan() || x.abs() >= 4.0e15 {
        return x.round() as i64;
    }
    let whole = x as i64;
    let fraction = x - whole as f64;
    whole + i64::from(fraction >= 0.5) - i64::from(fraction <= -0.5)
}

#[cfg(test)]
mod rounding_tests {
    use super::nearest_count;
    use proptest::prelude::*;

    #[test]
    fn nearest_count_rounds_halves_away_from_zero_as_round_does() {
        let edges = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            4.0e15,
            -4.0e15,
            4.5e15,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1234.5,
            -1234.5,
        ];
        for x in edges {
            assert_eq!(nearest_count(x), x.round() as i64, "{x}");
        }
    }

    proptest! {
        #[test]
        fn nearest_count_is_round(x in prop_oneof![-1e7..1e7_f64, -1e16..1e16_f64, any::<f64>()]) {
            prop_assert_eq!(nearest_count(x), x.round() as i64);
            let half = x.trunc() + 0.5;
            prop_assert_eq!(nearest_count(half), half.round() as i64);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `unwrap_near` worked with the division at every call.
    fn unwrap_dividing(angle: f64, near: f64) -> f64 {
        let turn = std::f64::consts::TAU;
        angle + nearest_count((near - angle) / turn) as f64 * turn
    }

    proptest! {
        #[test]
        fn an_angle_unwrapped_without_the_division_is_the_angle_unwrapped_with_it(
            angle in prop_oneof![-20.0..20.0_f64, Just(-0.0), Just(0.0), Just(3.0), Just(-3.0)],
            gap in prop_oneof![-3.5..3.5_f64, -40.0..40.0_f64, Just(3.0), Just(-3.0), Just(0.0)],
        ) {
            let near = angle + gap;
            prop_assert_eq!(
                unwrap_near(angle, near).to_bits(),
                unwrap_dividing(angle, near).to_bits()
            );
        }
    }
}
