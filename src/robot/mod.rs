//! PURE. A robot as linterpd plans for it: its kinematic model, its four joints with their pulse
//! channels, and its motion defaults. `config` builds these from TOML; `plan` consumes them.

use crate::geometry::Pose;
use crate::kinematics::{
    Arm, JOINTS, JointKind, Joints, Kinematics, KinematicsError, Model, nearest_count,
};
use crate::table::{ChannelLimits, FrequencyModel, OutputMethod};

/// One joint and the pulse channel that drives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// The joint's name (reports and errors).
    pub name: String,
    /// Pulse channel 0-3.
    pub channel: u8,
    /// Revolute (rad) or prismatic (mm).
    pub kind: JointKind,
    /// Joint value of one pulse, rad or mm (never 0; negative reverses the count direction).
    pub step: f64,
    /// Joint value at count 0, rad or mm.
    pub offset: f64,
    /// Lowest allowed joint value, rad or mm.
    pub min: f64,
    /// Highest allowed joint value, rad or mm.
    pub max: f64,
    /// Highest pulse frequency the channel may output, Hz.
    pub max_freq_hz: u32,
    /// How the channel is wired to its drive.
    pub output: OutputMethod,
    /// What the drive behind the channel can follow (nothing beyond `max_freq_hz` when unset).
    pub dynamics: Dynamics,
}

/// What a joint's drive can follow, beyond its channel's top frequency: every key absent plans
/// as if the drive followed any step (the seed's tables).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dynamics {
    /// The highest acceleration of the joint, rad/s^2 or mm/s^2: the time-optimal speed along
    /// every line and path keeps the joint within it, and every pair of consecutive rows of its
    /// table steps by no more than it allows over them.
    pub max_accel: Option<f64>,
    /// The highest frequency the drive follows from and to standstill, Hz: the first row of
    /// every run from rest and the last row into rest stay at or under it.
    pub start_hz: Option<f64>,
    /// The highest jerk of the joint, rad/s^3 or mm/s^3, as its planned motion is judged: its
    /// position's third difference at steps of [`JERK_SPAN_S`]. Only an S-curve is planned for it (a
    /// trapezoid steps its acceleration at once); the S-curve is slowed until it keeps it.
    pub max_jerk: Option<f64>,
}

/// The step at which a joint's jerk is judged, s: its speed over it, that speed's change over
/// it, and that change's over it (a third difference). A drive's position loop (a servo's, some
/// 100 Hz) smooths what changes faster; a corner of a path (a line into an arc) steps the
/// acceleration at once, and that step over this span is the jerk it asks for.
pub const JERK_SPAN_S: f64 = 0.010;

impl Dynamics {
    /// Whether any limit is set.
    #[must_use]
    pub fn is_set(&self) -> bool {
        self.max_accel.is_some() || self.start_hz.is_some() || self.max_jerk.is_some()
    }
}

/// [`Robot::counts_of`] at every sample of a move: each joint's value times its step's
/// reciprocal, a product where the quotient is a division. The product is within two roundings
/// of the quotient, so it rounds to the same count but within a few roundings of a half count,
/// where the quotient is worked.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Counter {
    offset: Joints,
    step: Joints,
    per_step: Joints,
}

impl Counter {
    /// The counts nearest `q`, as [`Robot::counts_of`] rounds them.
    pub(crate) fn counts_of(&self, q: &Joints) -> [i64; JOINTS] {
        std::array::from_fn(|j| {
            let from = q[j] - self.offset[j];
            let x = from * self.per_step[j];
            if x.abs() < 4.0e15 {
                let whole = x as i64;
                let fraction = x - whole as f64;
                if (fraction.abs() - 0.5).abs() > x.abs() * 1e-15 {
                    return whole + i64::from(fraction >= 0.5) - i64::from(fraction <= -0.5);
                }
            }
            nearest_count(from / self.step[j])
        })
    }
}

impl Joint {
    /// The count nearest a joint value.
    #[must_use]
    pub fn count_of(&self, value: f64) -> i64 {
        nearest_count((value - self.offset) / self.step)
    }

    /// The joint value of a count.
    #[must_use]
    pub fn value_of(&self, count: i64) -> f64 {
        self.offset + count as f64 * self.step
    }

    /// A joint value in the user's units (degrees or mm).
    #[must_use]
    pub fn user(&self, value: f64) -> f64 {
        self.kind.to_user(value)
    }
}

/// The planning method.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Method {
    /// The seed's constant time period method.
    #[default]
    ConstantPeriod,
    /// Rows of any length, as few as keep the executed path within `tolerance_mm` of the line.
    BoundedError {
        /// The largest path deviation allowed, mm.
        tolerance_mm: f64,
    },
    /// The seed's constant time period method exactly as the paper prints it (its "+1" rows
    /// included): planned for comparison, never valid for a PLC. Not a config or order value.
    SeedExact,
}

impl Method {
    /// The name used in config, CLI and reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::ConstantPeriod => "constant-period",
            Self::BoundedError { .. } => "bounded-error",
            Self::SeedExact => "seed-exact",
        }
    }

    /// The bounded-error tolerance, mm (`None` for the constant-period methods).
    #[must_use]
    pub fn tolerance_mm(self) -> Option<f64> {
        match self {
            Self::BoundedError { tolerance_mm } => Some(tolerance_mm),
            Self::ConstantPeriod | Self::SeedExact => None,
        }
    }

    /// Whether it is the paper as printed.
    #[must_use]
    pub fn is_seed_exact(self) -> bool {
        self == Self::SeedExact
    }
}

/// What to do when a move would need a channel faster than its maximum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OverSpeed {
    /// Refuse the move, naming the joint, the frequency, the time and the limit.
    #[default]
    Reject,
    /// Lower the whole move's speed and acceleration until every channel fits.
    SlowDown,
}

impl OverSpeed {
    /// The name used in config, CLI and reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Reject => "reject",
            Self::SlowDown => "slow-down",
        }
    }
}

/// The shape of a move's start and stop ramps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Ramp {
    /// The seed's trapezoid: the acceleration steps on and off.
    #[default]
    Trapezoid,
    /// Jerk-limited: the acceleration rises and falls at `jerk_mm_s3` (seven phases over a
    /// move), for loads that must not be shaken; a little slower than the trapezoid.
    SCurve {
        /// The path's jerk, mm/s^3.
        jerk_mm_s3: f64,
    },
}

impl Ramp {
    /// The name used in config and reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Trapezoid => "trapezoid",
            Self::SCurve { .. } => "s-curve",
        }
    }
}

/// The motion settings of a move (a robot's defaults, overridden per move).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// The planning method.
    pub method: Method,
    /// Interpolation period, s.
    pub period_s: f64,
    /// Cruise speed along the line, mm/s.
    pub speed_mm_s: f64,
    /// Acceleration and deceleration time, s.
    pub accel_s: f64,
    /// What the PLC's channels really output.
    pub frequency_model: FrequencyModel,
    /// What to do when a channel would be too fast.
    pub over_speed: OverSpeed,
    /// The ramps' shape.
    pub ramp: Ramp,
}

/// A robot: kinematics, joints in the model's order, motion defaults and table area size.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// The robot's name.
    pub name: String,
    /// The kinematic model with the robot's tool (`[robots.NAME.tool]`): every pose is the
    /// tool centre's.
    pub kinematics: Arm,
    /// The four joints, in the model's order.
    pub joints: [Joint; JOINTS],
    /// Motion defaults.
    pub motion: Motion,
    /// Words in each channel's table area (CONTRACT.md default 2000).
    pub area_words: usize,
    /// The fastest an order may ask the tool to move, mm/s (`[robots.NAME.motion]
    /// max_speed_mm_s`, default [`DEFAULT_MAX_SPEED_MM_S`]): a faster order is refused.
    pub max_speed_mm_s: f64,
}

/// The fastest an order may ask a robot's tool to move when its config does not say, mm/s.
pub const DEFAULT_MAX_SPEED_MM_S: f64 = 2_000.0;

impl Robot {
    /// Joint values of counts.
    #[must_use]
    pub fn values_of(&self, counts: &[i64; JOINTS]) -> Joints {
        std::array::from_fn(|j| self.joints[j].value_of(counts[j]))
    }

    /// Counts nearest joint values.
    #[must_use]
    pub fn counts_of(&self, q: &Joints) -> [i64; JOINTS] {
        // `Joint::count_of` for every joint, the joints side by side (planning counts every
        // joint at every millisecond sample).
        let offset: Joints = std::array::from_fn(|j| self.joints[j].offset);
        let step: Joints = std::array::from_fn(|j| self.joints[j].step);
        let scaled: Joints = std::array::from_fn(|j| (q[j] - offset[j]) / step[j]);
        std::array::from_fn(|j| nearest_count(scaled[j]))
    }

    /// [`Self::counts_of`] for many samples ([`Counter`]).
    #[must_use]
    pub(crate) fn counter(&self) -> Counter {
        let step: Joints = std::array::from_fn(|j| self.joints[j].step);
        Counter {
            offset: std::array::from_fn(|j| self.joints[j].offset),
            step,
            per_step: step.map(|s| 1.0 / s),
        }
    }

    /// The pose that counts put the tool in.
    #[must_use]
    pub fn pose_of(&self, counts: &[i64; JOINTS]) -> Pose {
        self.kinematics.fk(&self.values_of(counts))
    }

    /// The pose of a point given without a tool angle: the angle the tool has when the wrist
    /// joint sits at 0 there.
    pub fn pose_with_wrist_at_zero(&self, x: f64, y: f64, z: f64) -> Result<Pose, KinematicsError> {
        let probe = Pose::from_mm_deg(x, y, z, 0.0);
        let mut q = self.kinematics.ik(&probe, None)?;
        q[JOINTS - 1] = 0.0;
        Ok(self.kinematics.fk(&q))
    }

    /// What channel `joint` allows.
    #[must_use]
    pub fn channel_limits(&self, joint: usize) -> ChannelLimits {
        ChannelLimits {
            max_freq_hz: self.joints[joint].max_freq_hz,
            area_words: self.area_words,
        }
    }

    /// Whether any joint has a drive limit beyond its channel's top frequency
    /// ([`Dynamics`]): its moves are then timed along their path under every limit at once.
    #[must_use]
    pub fn has_dynamics(&self) -> bool {
        self.joints.iter().any(|j| j.dynamics.is_set())
    }
}

/// The seed's robot as `ACCURACY.md` gives it, built in code (the same values as the shipped
/// `config/linterpd.toml`): for tests, benchmarks and examples that must not depend on a file.
#[must_use]
pub fn seed_robot() -> Robot {
    use crate::kinematics::Cylindrical;
    Robot {
        name: "press-loader".into(),
        kinematics: Model::Cylindrical(Cylindrical {
            l0_mm: 500.0,
            min_axis_distance_mm: 50.0,
        })
        .into(),
        joints: seed_joints(),
        motion: Motion {
            method: Method::ConstantPeriod,
            period_s: 0.05,
            speed_mm_s: 240.0,
            accel_s: 0.2,
            frequency_model: FrequencyModel::FpxDivider,
            over_speed: OverSpeed::Reject,
            ramp: Ramp::Trapezoid,
        },
        area_words: 2_000,
        max_speed_mm_s: DEFAULT_MAX_SPEED_MM_S,
    }
}

/// The seed robot's joints: theta1, d2, d3, wrist.
fn seed_joints() -> [Joint; JOINTS] {
    [
        seed_joint(
            "theta1",
            0,
            JointKind::Revolute,
            0.0025,
            [-170.0, 170.0],
            100_000,
        ),
        seed_joint(
            "d2",
            1,
            JointKind::Prismatic,
            0.025,
            [-50.0, 400.0],
            100_000,
        ),
        seed_joint("d3", 2, JointKind::Prismatic, 0.013, [0.0, 1_000.0], 20_000),
        seed_joint(
            "wrist",
            3,
            JointKind::Revolute,
            0.0025,
            [-360.0, 360.0],
            20_000,
        ),
    ]
}

/// A joint of the seed's robot: its step and range in the user's unit (degrees or mm), pulse
/// and sign output, no offset and no drive limits.
fn seed_joint(
    name: &str,
    channel: u8,
    kind: JointKind,
    step_user: f64,
    [min, max]: [f64; 2],
    max_freq_hz: u32,
) -> Joint {
    Joint {
        name: name.into(),
        channel,
        kind,
        step: kind.from_user(step_user),
        offset: 0.0,
        min: kind.from_user(min),
        max: kind.from_user(max),
        max_freq_hz,
        output: OutputMethod::PulseSign,
        dynamics: Dynamics::default(),
    }
}

/// The largest tool offset from the flange, mm, on any axis.
pub const MAX_TOOL_OFFSET_MM: f64 = 2_000.0;

/// The rule a taught position's name follows, as every refusal says it.
pub const POSITION_NAME_RULE: &str =
    "a position name is 1 to 32 letters, digits, '_' or '-', not starting with '-'";

/// One taught position.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Position {
    /// x, y, z in mm and the tool angle a in degrees.
    pub pose: [f64; 4],
    /// The counts it was taught at, per joint in the joints' order.
    pub joint_counts: [i64; JOINTS],
    /// When it was taught, seconds since 1970.
    pub saved_unix_s: u64,
    /// The frame `pose` is kept in (`None`: world coordinates): re-teaching the frame's points
    /// moves the position with it (`pallet::RobotPallets::world_positions`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<String>,
}

/// Whether `name` follows [`POSITION_NAME_RULE`].
#[must_use]
pub fn is_position_name(name: &str) -> bool {
    (1..=32).contains(&name.len())
        && !name.starts_with('-')
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}

/// The seed's robot with a cylindrical arm that reaches in to 50 mm from its axis, its base channel at
/// 20 kHz: a line 100 mm from the axis swings the base at 1.4 rad/s at 240 mm/s, and 20 kHz
/// allows 0.87 rad/s (the demo's drive-limits comparison, and the planner's tests of it).
#[must_use]
pub fn short_arm(over_speed: OverSpeed) -> Robot {
    let mut robot = seed_robot();
    robot.kinematics = Model::Cylindrical(crate::kinematics::Cylindrical {
        l0_mm: 50.0,
        min_axis_distance_mm: 20.0,
    })
    .into();
    robot.joints[0].max_freq_hz = 20_000;
    robot.joints[0].min = JointKind::Revolute.from_user(-360.0);
    robot.joints[0].max = JointKind::Revolute.from_user(360.0);
    robot.motion.over_speed = over_speed;
    robot
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn counts_worked_by_products_are_the_counts_worked_by_quotients(
            seed_joints in prop::array::uniform4(-1e5..1e5_f64),
            halves in prop::array::uniform4(-2_000_000_i64..2_000_000),
            nudge in prop::array::uniform4(-4_i64..=4),
            scale in prop_oneof![Just(1.0), 1e-3..1e3_f64],
        ) {
            let mut robot = super::seed_robot();
            for joint in &mut robot.joints {
                joint.step *= scale;
            }
            let counter = robot.counter();
            // Anywhere, and on a half count give or take a few roundings.
            let on_halves: crate::kinematics::Joints = std::array::from_fn(|j| {
                let joint = &robot.joints[j];
                let v = joint.offset + (halves[j] as f64 + 0.5) * joint.step;
                let mut bits = v.to_bits() as i64 + nudge[j];
                if v == 0.0 {
                    bits = 0;
                }
                f64::from_bits(bits as u64)
            });
            for q in [seed_joints, on_halves] {
                prop_assert_eq!(counter.counts_of(&q), robot.counts_of(&q), "{:?}", q);
            }
        }
    }
}
