//! PURE. A move as the cell's software asks for it (API, CLI, a cycle's step), and its check
//! into a planner request. A bad order is refused here, naming the field and the limit, before
//! anything is queued. The daemon, the cycle programs, the cell face and the CLI all speak it;
//! it imports none of them.
//!
//! An order has exactly one target: `to` (a pose: a straight line to it), `by` (a jog: a
//! straight line by an offset from where the move starts), `joints` (a joint-space move to joint
//! values) or `position` (a straight line to a taught position's pose). [`plan_order`] is the one
//! place an order becomes a plan.

use crate::contract::Permit;
use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use nalgebra::Vector3;
use serde::de::MapAccess;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::config::parse_duration_s;
use crate::config::{PathDoc, PathFileError};
use crate::geometry::{Path, Pose};
use crate::kinematics::JOINTS;
use crate::plan::{
    JointMoveRequest, MoveRequest, Origin, PathRequest, Plan, PlanError, plan_joint_move,
    plan_move, plan_section,
};
use crate::robot::{Motion, Robot};
use crate::robot::{POSITION_NAME_RULE as NAME_RULE, Position, is_position_name};

pub mod motion;
pub mod permit;

pub use motion::OrderMotion;

/// The most elements a path order may have (checked before anything is planned).
pub const MAX_PATH_ELEMENTS: usize = 500;

/// A move order: one target (`to`, `by`, `joints` or `position`) and optional motion overrides
/// (the robot's defaults otherwise). Read by hand ([`motion::read_table`]): every key known,
/// as with serde's `deny_unknown_fields`.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct MoveOrder {
    /// Target `[x, y, z]` in mm, or `[x, y, z, a]` with the tool angle in degrees (without it the
    /// tool keeps its angle).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub to: Option<Vec<f64>>,
    /// A jog: `[dx, dy, dz]` in mm, or `[dx, dy, dz, da]` with the tool's turn in degrees, from
    /// where the move starts (the daemon takes that as where the order before it is planned to
    /// end, or where the robot is when none is queued or running).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub by: Option<Vec<f64>>,
    /// A joint-space move: every joint's target in the joints' order, degrees or mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joints: Option<Vec<f64>>,
    /// A taught position's name: a straight line to its pose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position: Option<String>,
    /// The motion keys (`speed_mm_s`, ..., `jerk_mm_s3`), at the order's top level.
    #[serde(flatten)]
    pub motion: OrderMotion,
    /// An interlock the PLC enforces: input bits or signal names joined by `&`, each optionally
    /// negated (`"press_open & !press_moving"`); the move starts only while it holds and is
    /// held (stopped) in the first scan it stops holding.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub permit: Option<String>,
}

impl<'de> Deserialize<'de> for MoveOrder {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        motion::read_table(d)
    }
}

impl motion::Table for MoveOrder {
    const NAME: &'static str = "MoveOrder";
    const KEYS: &'static [&'static str] =
        &motion::keys::<12>(&["to", "by", "joints", "position"], &["permit"]);

    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<(), A::Error> {
        match key {
            "to" => self.to = map.next_value()?,
            "by" => self.by = map.next_value()?,
            "joints" => self.joints = map.next_value()?,
            "position" => self.position = map.next_value()?,
            "permit" => self.permit = map.next_value()?,
            motion => self.motion.read(motion, map)?,
        }
        Ok(())
    }
}

/// A path to run, as the API takes it (`POST /v1/robots/{name}/paths`): the path document
/// (the path file's keys, as JSON: `start`, `path_accel`, `element`) and the motion, as for a
/// move.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct PathOrder {
    /// The path document.
    pub path: serde_json::Value,
    /// The motion keys, as for a move.
    #[serde(flatten)]
    pub motion: OrderMotion,
    /// An interlock the PLC enforces on every start of the path (see [`MoveOrder::permit`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub permit: Option<String>,
}

impl<'de> Deserialize<'de> for PathOrder {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        motion::read_table(d)
    }
}

impl motion::Table for PathOrder {
    const NAME: &'static str = "PathOrder";
    const KEYS: &'static [&'static str] = &motion::keys::<9>(&["path"], &["permit"]);
    const REQUIRED: Option<&'static str> = Some("path");

    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<(), A::Error> {
        match key {
            "path" => self.path = map.next_value()?,
            "permit" => self.permit = map.next_value()?,
            motion => self.motion.read(motion, map)?,
        }
        Ok(())
    }
}

impl PathOrder {
    /// The motion the order asks for, the robot's `defaults` filling the gaps, within `limits`.
    pub fn motion(&self, defaults: Motion, limits: &OrderLimits) -> Result<Motion, OrderError> {
        self.motion.check(defaults, *limits)
    }

    /// Checks the order's motion fields against `limits` and reads its document (at most
    /// [`MAX_PATH_ELEMENTS`](MAX_PATH_ELEMENTS) elements), before anything is planned.
    ///
    /// # Errors
    /// The field at fault, its value and the limit.
    pub fn check(
        &self,
        robot: &Robot,
        limits: &OrderLimits,
    ) -> Result<(Motion, PathDoc), OrderError> {
        let motion = self.motion.check(robot.motion, *limits)?;
        let doc = PathDoc::from_json(self.path.clone())
            .map_err(|e| path_refused("(the document)", e.to_string()))?;
        let max = MAX_PATH_ELEMENTS;
        if doc.elements.len() > max {
            return Err(path_refused(
                &format!("{} elements", doc.elements.len()),
                format!("a path order takes at most {max} elements"),
            ));
        }
        Ok((motion, doc))
    }

    /// The path request this order describes for `robot` beginning at `counts` (per joint),
    /// taught positions looked up with `lookup`: the path is built from the document's stated
    /// `start` (the planner refuses counts further from it than the slack) or, without one,
    /// from the pose of `counts`; waypoints without an angle keep the one before them. The one
    /// place a path order becomes a plan's request, for the daemon and the demo's check alike.
    ///
    /// # Errors
    /// A motion field out of `limits`, a document that is wrong or has more than
    /// [`MAX_PATH_ELEMENTS`](MAX_PATH_ELEMENTS) elements, an unknown taught position.
    pub fn request(
        &self,
        robot: &Robot,
        limits: &OrderLimits,
        counts: [i64; JOINTS],
        lookup: &dyn Fn(&str) -> Option<Pose>,
    ) -> Result<PathRequest, OrderError> {
        let (motion, doc) = self.check(robot, limits)?;
        let refused = |e: PathFileError| path_refused("(the document)", e.to_string());
        let here = robot.pose_of(&counts);
        let start = doc.start_pose(here.a_rad, lookup).map_err(refused)?;
        let elements = doc
            .resolve(start.unwrap_or(here), lookup)
            .map_err(refused)?;
        Ok(PathRequest {
            from: Origin::Counts(counts),
            start,
            elements,
            motion,
            path_accel_mm_s2: doc
                .path_accel_mm_s2
                .unwrap_or(motion.speed_mm_s / motion.accel_s),
        })
    }

    /// The move order a section's report shows: a line to where the section ends, with this
    /// order's motion.
    #[must_use]
    pub fn section_report(&self, end: &Pose) -> MoveOrder {
        MoveOrder {
            to: Some(end.to_mm_deg().to_vec()),
            motion: self.motion.clone(),
            permit: self.permit.clone(),
            ..MoveOrder::default()
        }
    }
}

/// The bounds an order's motion fields are checked against before anything is planned: the
/// robot's fastest speed (`[robots.NAME.motion] max_speed_mm_s`) and the daemon's fixed
/// ranges ([`MAX_ACCEL_TIME_S`], [`PERIOD_RANGE_S`], [`TOLERANCE_RANGE_MM`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrderLimits {
    /// The fastest speed an order may ask for, mm/s.
    pub max_speed_mm_s: f64,
    /// The speed override, a share of 1 (0.01 to 1): the speed an order asks for (or the
    /// robot's default) is planned at this share of it. The console's override; 1 otherwise.
    pub speed_override: f64,
}

impl OrderLimits {
    /// The limits of `robot`, at full speed.
    #[must_use]
    pub fn of(robot: &Robot) -> Self {
        Self {
            max_speed_mm_s: robot.max_speed_mm_s,
            speed_override: 1.0,
        }
    }

    /// These limits under a speed override of `percent` (1 to 100; clamped).
    #[must_use]
    pub fn overridden(self, percent: u8) -> Self {
        Self {
            speed_override: f64::from(percent.clamp(1, 100)) / 100.0,
            ..self
        }
    }
}

impl Default for OrderLimits {
    fn default() -> Self {
        Self {
            max_speed_mm_s: crate::robot::DEFAULT_MAX_SPEED_MM_S,
            speed_override: 1.0,
        }
    }
}

/// The longest acceleration time an order may ask for, s.
pub const MAX_ACCEL_TIME_S: f64 = 10.0;
/// The interpolation periods an order may ask for, s (1 ms to 1 s).
pub const PERIOD_RANGE_S: std::ops::RangeInclusive<f64> = 0.001..=1.0;
/// The bounded-error tolerances an order may ask for, mm.
pub const TOLERANCE_RANGE_MM: std::ops::RangeInclusive<f64> = 0.001..=10.0;

/// A path document that is wrong, as an order error on its `path` field.
/// A `permit` refused: it is not one the PLC can check.
pub(crate) fn permit_refused(e: &permit::PermitError) -> OrderError {
    refuse("permit", &e.text, e.reason.clone())
}

pub(crate) fn path_refused(value: &str, reason: impl Into<String>) -> OrderError {
    refuse("path", &value, reason)
}

/// Why an order is refused: the field, the value and what it must be.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{field} = {value}: {reason}")]
pub struct OrderError {
    /// The offending field.
    pub field: &'static str,
    /// Its value as sent.
    pub value: String,
    /// What it must be.
    pub reason: String,
}

fn refuse(field: &'static str, value: &impl ToString, reason: impl Into<String>) -> OrderError {
    OrderError {
        field,
        value: value.to_string(),
        reason: reason.into(),
    }
}

/// A number as an error shows it: plainly, or in exponent form when huge or tiny.
fn number(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

fn positive(field: &'static str, value: f64) -> Result<f64, OrderError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(refuse(field, &number(value), "must be a number above 0"))
    }
}

/// `value` if it lies in `range` (`unit` names it in the error).
fn within(
    field: &'static str,
    value: f64,
    range: &std::ops::RangeInclusive<f64>,
    unit: &str,
) -> Result<f64, OrderError> {
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(refuse(
            field,
            &number(value),
            format!("must be within {} to {} {unit}", range.start(), range.end()),
        ))
    }
}

fn duration(field: &'static str, text: &str, allow_zero: bool) -> Result<f64, OrderError> {
    let s =
        parse_duration_s(text).map_err(|e| refuse(field, &format!("{text:?}"), e.to_string()))?;
    if s > 0.0 || (allow_zero && s == 0.0) {
        Ok(s)
    } else {
        Err(refuse(
            field,
            &format!("{text:?}"),
            "must be longer than 0 s",
        ))
    }
}

/// Checks that `values` has `lengths` finite numbers, naming each by `names`.
fn finite(
    field: &'static str,
    values: &[f64],
    lengths: std::ops::RangeInclusive<usize>,
    shape: &str,
    names: [&'static str; 4],
) -> Result<(), OrderError> {
    if !lengths.contains(&values.len()) {
        return Err(refuse(
            field,
            &format!("{values:?}"),
            format!("must be {shape}"),
        ));
    }
    for (v, name) in values.iter().zip(names) {
        if !v.is_finite() {
            return Err(refuse(name, v, "must be a finite number"));
        }
    }
    Ok(())
}

/// Where a checked order goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A straight line to a pose; the tool angle is filled in from the start when `a_given` is
    /// false.
    Pose {
        /// The pose.
        to: Pose,
        /// Whether the order gave a tool angle.
        a_given: bool,
    },
    /// A straight line by an offset from the start pose.
    By {
        /// dx, dy, dz, mm.
        delta_mm: Vector3<f64>,
        /// The tool's turn, rad.
        delta_a_rad: f64,
    },
    /// A joint-space move to these joint values, in the user's units (degrees or mm).
    Joints([f64; JOINTS]),
    /// One start of a path section (between two stops): the section is planned from the
    /// counts where its first start begins, which must be where the section begins.
    Section(SectionPart),
}

/// A path section to run.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionOrder {
    /// The section, measured from its start.
    pub path: Path,
    /// The path's acceleration limit across it, mm/s^2.
    pub path_accel_mm_s2: f64,
    /// Its starts as planned when the path was accepted, from the counts it was expected to
    /// begin on.
    pub accepted: Vec<Plan>,
    /// Its starts, planned once, when the first of them begins, from the counts where it
    /// really begins (the accepted ones when it begins on the counts they were planned from:
    /// planning is a function of the robot, the section, the motion and the counts); every
    /// later part takes its plan from here.
    pub planned: OnceLock<Vec<Plan>>,
}

/// One start of a path section: the section's only start, or one of its parts chained at
/// speed.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionPart {
    /// The section, shared by its parts.
    pub section: Arc<SectionOrder>,
    /// Which start, from 0.
    pub part: usize,
    /// How many starts the section was planned with when the path was accepted.
    pub parts: usize,
}

impl SectionPart {
    /// Whether it begins at speed, chained behind the part before it.
    #[must_use]
    pub fn begins_at_speed(&self) -> bool {
        self.part > 0
    }

    /// Every start of its section as its first part would plan them from `counts` (the ones
    /// planned already, the accepted ones from their counts, else planned afresh), without
    /// keeping them: what a look ahead of the first part's turn weighs and preloads, which its
    /// turn then plans for itself (the same plans when it begins on the same counts).
    ///
    /// # Errors
    /// As [`Self::plan`]'s first part: a plan error, or a section planned into another number
    /// of starts than when it was accepted.
    pub fn section_plans(
        &self,
        robot: &Robot,
        motion: Motion,
        counts: [i64; JOINTS],
    ) -> Result<Vec<Plan>, PlanError> {
        let starts = match self.section.planned.get() {
            Some(starts) => starts.clone(),
            None => match self.section.accepted.first() {
                Some(a) if a.start_counts() == counts => self.section.accepted.clone(),
                _ => plan_section(
                    robot,
                    &self.section.path,
                    motion,
                    self.section.path_accel_mm_s2,
                    counts,
                )?,
            },
        };
        if starts.len() != self.parts {
            return Err(PlanError::PartsChanged {
                accepted: self.parts,
                now: starts.len(),
            });
        }
        Ok(starts)
    }

    /// Its plan from `counts`, where it begins: the first part plans the section (it must need
    /// as many starts as when the path was accepted); every part must begin on exactly the
    /// counts it was planned from.
    fn plan(
        &self,
        robot: &Robot,
        motion: Motion,
        counts: [i64; JOINTS],
    ) -> Result<Plan, PlanError> {
        let accepted = self.section.accepted.first();
        let starts = if let Some(starts) = self.section.planned.get() {
            starts
        } else if self.part == 0 && accepted.is_some_and(|a| a.start_counts() == counts) {
            self.section
                .planned
                .get_or_init(|| self.section.accepted.clone())
        } else {
            let starts = plan_section(
                robot,
                &self.section.path,
                motion,
                self.section.path_accel_mm_s2,
                counts,
            )?;
            if starts.len() != self.parts || self.part != 0 {
                return Err(PlanError::PartsChanged {
                    accepted: self.parts,
                    now: starts.len(),
                });
            }
            self.section.planned.get_or_init(|| starts)
        };
        let plan = starts.get(self.part).ok_or(PlanError::PartsChanged {
            accepted: self.parts,
            now: starts.len(),
        })?;
        if plan.start_counts() != counts {
            return Err(PlanError::NotAtPartStart {
                part: self.part + 1,
                counts,
                planned: plan.start_counts(),
            });
        }
        Ok(plan.clone())
    }
}

/// A checked order: its target and the motion to plan with.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedOrder {
    /// The target.
    pub target: Target,
    /// The motion.
    pub motion: Motion,
    /// Its permit over the cell's inputs: written with its start, enforced by the PLC.
    pub permit: Permit,
    /// Its plan when it was accepted ([`plan_order`] takes it when asked from those counts).
    pub accepted: Option<Arc<Accepted>>,
}

/// An order's plan when it was accepted, and the counts it was planned from: planning is a
/// function of the robot, the order and the counts, so from those counts it is the plan.
#[derive(Clone, PartialEq)]
pub struct Accepted {
    /// The counts it was planned from, per joint.
    pub counts: [i64; JOINTS],
    /// The plan.
    pub plan: Plan,
}

impl std::fmt::Debug for Accepted {
    // The plan's samples and tables would fill a log line many times over.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Accepted")
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

impl CheckedOrder {
    /// Whether it is a part of a path section that begins at speed, chained behind the part
    /// before it.
    #[must_use]
    pub fn begins_at_speed(&self) -> bool {
        matches!(&self.target, Target::Section(part) if part.begins_at_speed())
    }

    /// Whether it is the first part of a path section cut into several parts. The parts behind
    /// it are written into both banks and the link's pace is checked before it starts from
    /// rest; behind a running move it begins only where the worker judged that the link can
    /// write each later part while the part before it runs (`daemon/worker/lead.rs`).
    #[must_use]
    pub fn leads_parts(&self) -> bool {
        matches!(&self.target, Target::Section(p) if p.part == 0 && p.parts > 1)
    }

    /// Every start of the section it leads, as [`SectionPart::section_plans`] from `counts`
    /// (`None`: it does not lead a section).
    ///
    /// # Errors
    /// As [`SectionPart::section_plans`].
    #[must_use]
    pub fn section_plans(
        &self,
        robot: &Robot,
        counts: [i64; JOINTS],
    ) -> Option<Result<Vec<Plan>, PlanError>> {
        match &self.target {
            Target::Section(p) if p.part == 0 => Some(p.section_plans(robot, self.motion, counts)),
            _ => None,
        }
    }

    /// How many starts its path section was cut into (1 for any other order).
    #[must_use]
    pub fn parts(&self) -> usize {
        match &self.target {
            Target::Section(p) => p.parts,
            _ => 1,
        }
    }

    /// The path section it is a part of, if it is one.
    #[must_use]
    pub fn section(&self) -> Option<&Arc<SectionOrder>> {
        match &self.target {
            Target::Section(part) => Some(&part.section),
            _ => None,
        }
    }

    /// Whether the target is relative to where the move starts.
    #[must_use]
    pub fn is_relative(&self) -> bool {
        matches!(self.target, Target::By { .. })
    }

    /// The order with a relative target made absolute from `counts` (per joint), where the move
    /// is to start; any other order as it is.
    #[must_use]
    pub fn anchored_at(self, robot: &Robot, counts: [i64; JOINTS]) -> Self {
        let from = robot.pose_of(&counts);
        match self.pose_target(&from) {
            Some(to) if self.is_relative() => Self {
                target: Target::Pose { to, a_given: true },
                accepted: None,
                ..self
            },
            _ => self,
        }
    }

    /// The pose a line order goes to from `from` (`None` for a joint-space move).
    pub(crate) fn pose_target(&self, from: &Pose) -> Option<Pose> {
        match self.target {
            Target::Pose { to, a_given: true } => Some(to),
            Target::Pose { to, a_given: false } => Some(Pose {
                a_rad: from.a_rad,
                ..to
            }),
            Target::By {
                delta_mm,
                delta_a_rad,
            } => Some(Pose {
                position_mm: from.position_mm + delta_mm,
                a_rad: from.a_rad + delta_a_rad,
            }),
            Target::Joints(_) | Target::Section(_) => None,
        }
    }
}

impl MoveOrder {
    /// The order as one start of it shows it: a line to `end`, where that start ends, with
    /// this order's motion fields (a line cut into starts at a joint's reversal).
    #[must_use]
    pub fn ending_at(&self, end: &Pose) -> Self {
        Self {
            to: Some(end.to_mm_deg().to_vec()),
            by: None,
            joints: None,
            position: None,
            ..self.clone()
        }
    }

    /// Checks every field against `defaults`, the robot's motion defaults, and the default
    /// limits, with no taught positions.
    pub fn check(&self, defaults: Motion) -> Result<CheckedOrder, OrderError> {
        self.check_with(defaults, &OrderLimits::default(), &BTreeMap::new())
    }

    /// Checks every field against `defaults`, `limits` and the robot's `taught` positions.
    pub fn check_with(
        &self,
        defaults: Motion,
        limits: &OrderLimits,
        taught: &BTreeMap<String, Position>,
    ) -> Result<CheckedOrder, OrderError> {
        Ok(CheckedOrder {
            target: self.target(taught)?,
            motion: self.motion.check(defaults, *limits)?,
            permit: Permit::NONE,
            accepted: None,
        })
    }

    fn target(&self, taught: &BTreeMap<String, Position>) -> Result<Target, OrderError> {
        self.one_target()?;
        if let Some(to) = &self.to {
            return pose_target(to);
        }
        if let Some(by) = &self.by {
            return by_target(by);
        }
        if let Some(joints) = &self.joints {
            finite(
                "joints",
                joints,
                JOINTS..=JOINTS,
                "4 joint values in the joints' order (degrees or mm)",
                ["joints[0]", "joints[1]", "joints[2]", "joints[3]"],
            )?;
            return Ok(Target::Joints(std::array::from_fn(|j| joints[j])));
        }
        taught_target(self.position.as_deref().unwrap_or_default(), taught)
    }

    /// Refuses an order that gives none, or more than one, of `to`, `by`, `joints` and
    /// `position`.
    fn one_target(&self) -> Result<(), OrderError> {
        let given: Vec<&'static str> = [
            ("to", self.to.is_some()),
            ("by", self.by.is_some()),
            ("joints", self.joints.is_some()),
            ("position", self.position.is_some()),
        ]
        .into_iter()
        .filter_map(|(field, given)| given.then_some(field))
        .collect();
        match given.as_slice() {
            [] => Err(refuse(
                "to",
                &"null",
                "an order needs one of to, by, joints or position",
            )),
            [_] => Ok(()),
            [first, second, ..] => Err(refuse(
                second,
                &"(given)",
                format!("an order takes one of to, by, joints or position; it also has {first}"),
            )),
        }
    }
}

/// Plans `order` for `robot` from `counts` (per joint): a line to a pose (without a tool angle
/// in the order the tool keeps the angle it has there; a jog is relative to the pose there), or a
/// joint-space move.
pub(crate) fn plan_order(
    robot: &Robot,
    order: &CheckedOrder,
    counts: [i64; JOINTS],
) -> Result<Plan, PlanError> {
    if let Some(accepted) = order.accepted.as_deref()
        && accepted.counts == counts
    {
        return Ok(accepted.plan.clone());
    }
    if let Target::Section(part) = &order.target {
        return part.plan(robot, order.motion, counts);
    }
    if let Target::Joints(user) = order.target {
        return plan_joint_move(
            robot,
            &JointMoveRequest {
                from: Origin::Counts(counts),
                to: std::array::from_fn(|j| robot.joints[j].kind.from_user(user[j])),
                motion: order.motion,
            },
        );
    }
    let from = robot.pose_of(&counts);
    let to = order.pose_target(&from).expect("a line order has a pose");
    plan_move(
        robot,
        &MoveRequest {
            from: Origin::Counts(counts),
            to,
            motion: order.motion,
        },
    )
}

/// A pose target `to`: `[x, y, z]` or `[x, y, z, a]`, mm and degrees.
fn pose_target(to: &[f64]) -> Result<Target, OrderError> {
    finite(
        "to",
        to,
        3..=4,
        "[x, y, z] or [x, y, z, a] (mm, degrees)",
        ["to[0] (x)", "to[1] (y)", "to[2] (z)", "to[3] (a)"],
    )?;
    let a_deg = to.get(3).copied();
    Ok(Target::Pose {
        to: Pose::from_mm_deg(to[0], to[1], to[2], a_deg.unwrap_or(0.0)),
        a_given: a_deg.is_some(),
    })
}

/// A jog `by`: `[dx, dy, dz]` or `[dx, dy, dz, da]`, mm and degrees.
fn by_target(by: &[f64]) -> Result<Target, OrderError> {
    finite(
        "by",
        by,
        3..=4,
        "[dx, dy, dz] or [dx, dy, dz, da] (mm, degrees)",
        ["by[0] (dx)", "by[1] (dy)", "by[2] (dz)", "by[3] (da)"],
    )?;
    Ok(Target::By {
        delta_mm: Vector3::new(by[0], by[1], by[2]),
        delta_a_rad: by.get(3).copied().unwrap_or(0.0).to_radians(),
    })
}

/// The pose of the taught position `name`.
fn taught_target(name: &str, taught: &BTreeMap<String, Position>) -> Result<Target, OrderError> {
    let shown = format!("{name:?}");
    if !is_position_name(name) {
        return Err(refuse("position", &shown, NAME_RULE));
    }
    let position = taught.get(name).ok_or_else(|| {
        let known: Vec<&str> = taught.keys().map(String::as_str).collect();
        let known = if known.is_empty() {
            "the robot has no taught positions".to_owned()
        } else {
            format!("taught positions: {}", known.join(", "))
        };
        refuse("position", &shown, format!("no such position; {known}"))
    })?;
    let [x, y, z, a] = position.pose;
    Ok(Target::Pose {
        to: Pose::from_mm_deg(x, y, z, a),
        a_given: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{Method, Ramp, seed_robot};

    fn order(to: Vec<f64>) -> MoveOrder {
        MoveOrder {
            to: Some(to),
            ..MoveOrder::default()
        }
    }

    /// A pick and place accepted from the seed's start on the seed robot: its one section,
    /// cut into parts chained at speed, with the starts planned at acceptance.
    fn accepted_section() -> (crate::robot::Robot, SectionOrder, Motion) {
        use crate::geometry::{Corner, Element, Pose};
        use crate::kinematics::Kinematics;
        use crate::plan::{Origin, PathRequest, plan_path};
        let robot = seed_robot();
        let start = robot
            .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
            .unwrap();
        let at = |x, y, z| {
            let mut p = Pose::from_mm_deg(x, y, z, 0.0);
            p.a_rad = start.a_rad;
            p
        };
        let motion = Motion {
            method: crate::robot::Method::BoundedError { tolerance_mm: 0.05 },
            ..robot.motion
        };
        // From counts, as the daemon plans an order.
        let counts = robot.counts_of(&robot.kinematics.ik(&start, None).unwrap());
        let req = PathRequest {
            from: Origin::Counts(counts),
            start: None,
            elements: vec![
                (
                    Element::Line {
                        to: at(-926.57, 535.03, 150.0),
                    },
                    Corner::Blend(20.0),
                ),
                (
                    Element::Line {
                        to: at(-1144.43, 659.60, 236.60),
                    },
                    Corner::Blend(20.0),
                ),
                (
                    Element::Line {
                        to: at(-1144.43, 659.60, 186.60),
                    },
                    Corner::Stop,
                ),
            ],
            motion,
            path_accel_mm_s2: 5_000.0,
        };
        let mut planned = plan_path(&robot, &req).unwrap();
        assert_eq!(planned.sections.len(), 1);
        let section = planned.sections.remove(0);
        let order = SectionOrder {
            path: section.path,
            path_accel_mm_s2: 5_000.0,
            accepted: section.starts,
            planned: OnceLock::new(),
        };
        (robot, order, motion)
    }

    /// An order begun on the counts it was accepted from takes the plan made then (planning
    /// there again gives the same plan); begun anywhere else, it is planned from there.
    #[test]
    #[allow(clippy::float_cmp)] // a marker value, copied exactly
    fn an_order_begun_where_it_was_accepted_from_takes_the_accepted_plan() {
        use crate::kinematics::Kinematics;
        let robot = seed_robot();
        let p1 = robot
            .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
            .unwrap();
        let counts = robot.counts_of(&robot.kinematics.ik(&p1, None).unwrap());
        let mut checked = order(vec![-1144.43, 659.60, 186.60])
            .check(robot.motion)
            .unwrap();
        let plan = plan_order(&robot, &checked, counts).unwrap();
        assert!(plan_order(&robot, &checked, counts).unwrap() == plan);
        let mut marked = plan;
        marked.speed_factor = 0.5;
        checked.accepted = Some(Arc::new(Accepted {
            counts,
            plan: marked,
        }));
        assert_eq!(
            plan_order(&robot, &checked, counts).unwrap().speed_factor,
            0.5
        );
        let mut off = counts;
        off[2] += 1;
        let fresh = plan_order(&robot, &checked, off).unwrap();
        assert_eq!((fresh.start_counts(), fresh.speed_factor), (off, 1.0));
        // A relative order anchored elsewhere forgets it.
        let jog = MoveOrder {
            by: Some(vec![0.0, 0.0, 10.0]),
            ..MoveOrder::default()
        }
        .check(robot.motion)
        .unwrap();
        let mut jog_accepted = jog.clone();
        jog_accepted.accepted = checked.accepted.clone();
        assert!(jog_accepted.anchored_at(&robot, off).accepted.is_none());
    }

    /// A section begun on the counts it was accepted from takes the starts planned then (they
    /// are the starts planning there again gives); begun anywhere else, it is planned again
    /// from where it begins.
    #[test]
    #[allow(clippy::float_cmp)] // a marker value, copied exactly
    fn a_section_begun_where_it_was_accepted_from_takes_the_accepted_starts() {
        let (robot, section, motion) = accepted_section();
        let counts = section.accepted[0].start_counts();
        let again =
            crate::plan::plan_section(&robot, &section.path, motion, 5_000.0, counts).unwrap();
        assert!(
            again == section.accepted,
            "planned again, not the accepted starts"
        );
        // Marked, to tell the accepted starts from starts planned again.
        let mut marked = section.clone();
        for plan in &mut marked.accepted {
            plan.speed_factor = 0.5;
        }
        let parts = marked.accepted.len();
        assert!(parts >= 2, "{parts} parts");
        let arc = Arc::new(marked);
        let part = |part| SectionPart {
            section: Arc::clone(&arc),
            part,
            parts,
        };
        let first = part(0).plan(&robot, motion, counts).unwrap();
        assert_eq!(first.speed_factor, 0.5);
        let second_from = first.end_counts();
        assert_eq!(
            part(1)
                .plan(&robot, motion, second_from)
                .unwrap()
                .speed_factor,
            0.5
        );
        // A pulse off on d3: planned again, from there.
        let mut off = counts;
        off[2] += 1;
        let fresh = Arc::new(section);
        let replanned = SectionPart {
            section: Arc::clone(&fresh),
            part: 0,
            parts,
        }
        .plan(&robot, motion, off)
        .unwrap();
        assert_eq!(replanned.start_counts(), off);
        assert_eq!(replanned.speed_factor, 1.0);
    }

    /// A look ahead of a section's first turn (`section_plans`) plans from the counts it is
    /// given and keeps nothing: the turn, begun elsewhere, still plans from where it begins.
    #[test]
    #[allow(clippy::float_cmp)] // a marker value, copied exactly
    fn a_look_ahead_at_a_sections_plans_keeps_none_of_them() {
        let (robot, mut section, motion) = accepted_section();
        let counts = section.accepted[0].start_counts();
        for plan in &mut section.accepted {
            plan.speed_factor = 0.5;
        }
        let parts = section.accepted.len();
        let first = SectionPart {
            section: Arc::new(section),
            part: 0,
            parts,
        };
        let accepted = first.section_plans(&robot, motion, counts).unwrap();
        assert!(
            accepted.iter().all(|p| p.speed_factor == 0.5),
            "the accepted starts"
        );
        let mut off = counts;
        off[2] += 1;
        let ahead = first.section_plans(&robot, motion, off).unwrap();
        assert_eq!((ahead[0].start_counts(), ahead.len()), (off, parts));
        assert!(first.section.planned.get().is_none(), "nothing kept");
        // Its turn, on the accepted counts after all, takes the accepted starts.
        let turn = first.plan(&robot, motion, counts).unwrap();
        assert_eq!(turn.speed_factor, 0.5);
    }

    #[test]
    fn target_without_angle_keeps_the_default_motion() {
        let c = order(vec![1.0, 2.0, 3.0])
            .check(seed_robot().motion)
            .unwrap();
        assert!(matches!(c.target, Target::Pose { a_given: false, .. }));
        assert_eq!(c.motion, seed_robot().motion);
    }

    #[test]
    fn bad_fields_are_named_with_value_and_limit() {
        let m = seed_robot().motion;
        assert_eq!(order(vec![1.0, 2.0]).check(m).unwrap_err().field, "to");
        assert_eq!(
            order(vec![1.0, f64::NAN, 3.0])
                .check(m)
                .unwrap_err()
                .to_string(),
            "to[1] (y) = NaN: must be a finite number"
        );
        let slow = MoveOrder {
            motion: OrderMotion {
                speed_mm_s: Some(0.0),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert_eq!(
            slow.check(m).unwrap_err().to_string(),
            "speed_mm_s = 0: must be a number above 0"
        );
        let bad = MoveOrder {
            motion: OrderMotion {
                period: Some("0ms".into()),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert_eq!(bad.check(m).unwrap_err().field, "period");
        let weird = MoveOrder {
            motion: OrderMotion {
                method: Some("spline".into()),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert!(
            weird
                .check(m)
                .unwrap_err()
                .reason
                .contains("constant-period")
        );
    }

    #[test]
    fn an_order_chooses_its_ramps_and_a_jerk_needs_an_s_curve() {
        let trapezoid = seed_robot().motion;
        let s_curve = Motion {
            ramp: Ramp::SCurve { jerk_mm_s3: 5000.0 },
            ..trapezoid
        };
        let base = order(vec![1.0, 2.0, 3.0]);
        let with = |profile: Option<&str>, jerk: Option<f64>| MoveOrder {
            motion: OrderMotion {
                profile: profile.map(str::to_owned),
                jerk_mm_s3: jerk,
                ..OrderMotion::default()
            },
            ..base.clone()
        };
        let ramp = |o: MoveOrder, m: Motion| o.check(m).map(|c| c.motion.ramp);
        let err = |o: MoveOrder, m: Motion| o.check(m).unwrap_err().to_string();
        // Nothing asked: the robot's.
        assert_eq!(ramp(with(None, None), trapezoid), Ok(Ramp::Trapezoid));
        assert_eq!(ramp(with(None, None), s_curve), Ok(s_curve.ramp));
        // Asked, with its jerk or the robot's.
        assert_eq!(
            ramp(with(Some("s-curve"), Some(20000.0)), trapezoid),
            Ok(Ramp::SCurve {
                jerk_mm_s3: 20000.0
            })
        );
        assert_eq!(ramp(with(Some("s-curve"), None), s_curve), Ok(s_curve.ramp));
        assert_eq!(
            ramp(with(None, Some(9000.0)), s_curve),
            Ok(Ramp::SCurve { jerk_mm_s3: 9000.0 })
        );
        assert_eq!(
            ramp(with(Some("trapezoid"), None), s_curve),
            Ok(Ramp::Trapezoid)
        );
        // Refused, naming the field, the value and why.
        assert_eq!(
            err(with(Some("s-curve"), None), trapezoid),
            "jerk_mm_s3 = null: profile \"s-curve\" needs the path's jerk (the robot's profile \
             is the trapezoid), e.g. 20000 mm/s^3"
        );
        assert_eq!(
            err(with(None, Some(20000.0)), trapezoid),
            "jerk_mm_s3 = 20000: only profile \"s-curve\" takes a jerk"
        );
        assert_eq!(
            err(with(Some("trapezoid"), Some(20000.0)), s_curve),
            "jerk_mm_s3 = 20000: only profile \"s-curve\" takes a jerk"
        );
        assert_eq!(
            err(with(Some("s-curve"), Some(-1.0)), trapezoid),
            "jerk_mm_s3 = -1: must be a number above 0"
        );
        assert_eq!(
            err(with(Some("spline"), None), trapezoid),
            "profile = \"spline\": must be \"trapezoid\" or \"s-curve\""
        );
    }

    /// Issue 25: `speed_mm_s: 1e308` was accepted and run (2.52 mm tracking error predicted).
    #[test]
    fn speed_1e308_is_refused_naming_the_robots_max_speed() {
        let m = seed_robot().motion;
        let fast = |v: f64| MoveOrder {
            motion: OrderMotion {
                speed_mm_s: Some(v),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0])
        };
        let limits = OrderLimits {
            max_speed_mm_s: 800.0,
            ..OrderLimits::default()
        };
        let e = fast(1e308)
            .check_with(m, &limits, &BTreeMap::new())
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "speed_mm_s = 1e308: must be at most 800 mm/s, the robot's max_speed_mm_s"
        );
        assert!(fast(800.0).check_with(m, &limits, &BTreeMap::new()).is_ok());
    }

    #[test]
    fn the_speed_override_scales_the_asked_and_the_default_speed_after_the_check() {
        let m = seed_robot().motion;
        let limits = OrderLimits {
            max_speed_mm_s: 800.0,
            ..OrderLimits::default()
        }
        .overridden(25);
        let asked = MoveOrder {
            motion: OrderMotion {
                speed_mm_s: Some(800.0),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0])
        };
        let checked = asked.check_with(m, &limits, &BTreeMap::new()).unwrap();
        assert!((checked.motion.speed_mm_s - 200.0).abs() < 1e-9);
        let default = order(vec![1.0, 2.0, 3.0])
            .check_with(m, &limits, &BTreeMap::new())
            .unwrap();
        assert!((default.motion.speed_mm_s - m.speed_mm_s / 4.0).abs() < 1e-9);
        // 0 % is taken as 1 %: an override never stops the robot by itself.
        let one = OrderLimits::default().overridden(0);
        assert!((one.speed_override - 0.01).abs() < 1e-12);
    }

    #[test]
    fn period_accel_time_and_tolerance_are_bounded_naming_the_limit() {
        let m = seed_robot().motion;
        let refused =
            |o: OrderMotion| (o.check(m, OrderLimits::default()).unwrap_err()).to_string();
        let none = OrderMotion::default;
        let period = |t: &str| OrderMotion {
            period: Some(t.into()),
            ..none()
        };
        let tolerance = |t| OrderMotion {
            tolerance_mm: Some(t),
            ..none()
        };
        let cases = [
            (period("2s"), "period = \"2s\": must be within 1 ms to 1 s"),
            (
                period("100us"),
                "period = \"100us\": must be within 1 ms to 1 s",
            ),
            (
                tolerance(50.0),
                "tolerance_mm = 50: must be within 0.001 to 10 mm",
            ),
            (
                tolerance(1e-6),
                "tolerance_mm = 1e-6: must be within 0.001 to 10 mm",
            ),
            (
                OrderMotion {
                    accel_time: Some("20s".into()),
                    ..none()
                },
                "accel_time = \"20s\": must be at most 10 s",
            ),
        ];
        for (motion, words) in cases {
            assert_eq!(refused(motion), words);
        }
    }

    #[test]
    fn tolerance_makes_a_bounded_error_move() {
        let o = MoveOrder {
            motion: OrderMotion {
                tolerance_mm: Some(0.05),
                ..OrderMotion::default()
            },
            ..order(vec![1.0, 2.0, 3.0, 10.0])
        };
        let c = o.check(seed_robot().motion).unwrap();
        assert_eq!(c.motion.method, Method::BoundedError { tolerance_mm: 0.05 });
        assert!(matches!(c.target, Target::Pose { a_given: true, .. }));
    }

    fn taught() -> BTreeMap<String, Position> {
        BTreeMap::from([(
            "pick".to_owned(),
            Position {
                pose: [10.0, 520.0, 30.0, 5.0],
                joint_counts: [0; JOINTS],
                saved_unix_s: 0,
                frame: None,
            },
        )])
    }

    #[test]
    fn an_order_takes_exactly_one_target() {
        let m = seed_robot().motion;
        let none = MoveOrder::default().check(m).unwrap_err();
        assert_eq!(
            none.to_string(),
            "to = null: an order needs one of to, by, joints or position"
        );
        let two = MoveOrder {
            by: Some(vec![1.0, 0.0, 0.0]),
            ..order(vec![1.0, 2.0, 3.0])
        };
        let e = two.check(m).unwrap_err();
        assert_eq!(e.field, "by");
        assert!(e.reason.contains("it also has to"), "{e}");
    }

    #[test]
    fn jog_joints_and_position_are_checked_naming_the_field() {
        let m = seed_robot().motion;
        let jog = |by: Vec<f64>| MoveOrder {
            by: Some(by),
            ..MoveOrder::default()
        };
        assert_eq!(jog(vec![1.0]).check(m).unwrap_err().field, "by");
        assert_eq!(
            jog(vec![1.0, 2.0, f64::INFINITY])
                .check(m)
                .unwrap_err()
                .to_string(),
            "by[2] (dz) = inf: must be a finite number"
        );
        let joints = |j: Vec<f64>| MoveOrder {
            joints: Some(j),
            ..MoveOrder::default()
        };
        let e = joints(vec![1.0, 2.0, 3.0]).check(m).unwrap_err();
        assert_eq!(
            e.to_string(),
            "joints = [1.0, 2.0, 3.0]: must be 4 joint values in the joints' order (degrees or mm)"
        );
        assert_eq!(
            joints(vec![1.0, 2.0, 3.0, f64::NAN])
                .check(m)
                .unwrap_err()
                .field,
            "joints[3]"
        );
        let at = |name: &str| MoveOrder {
            position: Some(name.into()),
            ..MoveOrder::default()
        };
        let e = at("a b")
            .check_with(m, &OrderLimits::default(), &taught())
            .unwrap_err();
        assert_eq!(e.to_string(), format!("position = \"a b\": {NAME_RULE}"));
        let e = at("place")
            .check_with(m, &OrderLimits::default(), &taught())
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "position = \"place\": no such position; taught positions: pick"
        );
        let e = at("place").check(m).unwrap_err();
        assert!(
            e.reason.ends_with("the robot has no taught positions"),
            "{e}"
        );
        let c = at("pick")
            .check_with(m, &OrderLimits::default(), &taught())
            .unwrap();
        let Target::Pose { to, a_given: true } = c.target else {
            panic!("{c:?}")
        };
        assert_eq!(to, Pose::from_mm_deg(10.0, 520.0, 30.0, 5.0));
    }

    #[test]
    fn a_jog_is_anchored_where_its_move_starts() {
        let robot = seed_robot();
        let counts = [400, 800, 1_000, 200];
        let from = robot.pose_of(&counts);
        let jog = MoveOrder {
            by: Some(vec![10.0, -5.0, 2.0]),
            ..MoveOrder::default()
        }
        .check(robot.motion)
        .unwrap();
        assert!(jog.is_relative());
        let anchored = jog.clone().anchored_at(&robot, counts);
        let Target::Pose { to, a_given: true } = anchored.target else {
            panic!("{anchored:?}")
        };
        assert!((to.position_mm - from.position_mm - Vector3::new(10.0, -5.0, 2.0)).norm() < 1e-9);
        assert!((to.a_rad - from.a_rad).abs() < 1e-12);
        // Anchored or not, the plan from those counts is the same.
        let a = plan_order(&robot, &jog, counts).unwrap();
        let b = plan_order(&robot, &anchored, counts).unwrap();
        assert_eq!(a.end_counts(), b.end_counts());
    }

    #[test]
    fn a_joints_order_plans_a_joint_move_to_those_values() {
        let robot = seed_robot();
        let c = MoveOrder {
            joints: Some(vec![10.0, 30.0, 40.0, -5.0]),
            ..MoveOrder::default()
        }
        .check(robot.motion)
        .unwrap();
        let plan = plan_order(&robot, &c, [0; JOINTS]).unwrap();
        assert!(plan.joint_path.is_some());
        assert_eq!(
            plan.end_counts(),
            [4_000, 1_200, (40.0f64 / 0.013).round() as i64, -2_000]
        );
    }
}
