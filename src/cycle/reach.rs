//! PURE. Where a checked program's motions take the robot, checked before anything moves: every
//! absolute target (a pose, a taught position, joint values) against the robot's reach and
//! joint limits wherever the move starts, and every move and path whose start is known when
//! the program is checked (the robot's pose at the run, and the ends of the motions before it
//! in every way the program can come to it: loops, a wait's `on_timeout`, the next cycle)
//! planned from there, as the daemon plans an order. A move `by` an offset or a path whose
//! start depends on the run (it differs between the ways in, or is not known) is checked when
//! it runs; the check says which.

use std::collections::HashMap;

use super::check::{Context, Op, OpKind, ProgramError};
use crate::geometry::Pose;
use crate::kinematics::JOINTS;
use crate::order::{CheckedOrder, OrderError, OrderLimits, Target, plan_order};
use crate::plan::{MoveRequest, Origin, PlanError, check_pose, check_target, line_as_path};

/// Where the robot stands when an op begins, over every way the program comes to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum At {
    /// No way comes to it (yet).
    Unset,
    /// At these counts, whichever way.
    Known([i64; JOINTS]),
    /// Not known, or not the same each way.
    Varies,
}

impl At {
    /// Where an op stands that `self` and `other` both lead to.
    fn meet(self, other: Self) -> Self {
        match (self, other) {
            (Self::Unset, x) | (x, Self::Unset) => x,
            (Self::Known(a), Self::Known(b))
                if a.iter().zip(&b).all(|(a, b)| (a - b).abs() <= 1) =>
            {
                Self::Known(a)
            }
            _ => Self::Varies,
        }
    }
}

/// Checks where `ops` take the robot ([`self`](self)).
///
/// # Errors
/// The first motion that cannot run: its step, and why (out of reach, a joint past a limit, a
/// plan refused from its known start).
///
/// Returns what is left to check when the steps run: one line per motion whose start depends
/// on the run.
pub(super) fn check(
    ops: &[Op],
    blended: &[usize],
    ctx: &Context<'_>,
) -> Result<Vec<String>, ProgramError> {
    let mut reach = Reach {
        ctx,
        planned: HashMap::new(),
    };
    let at = reach.starts(ops);
    let mut unchecked = Vec::new();
    for (i, op) in ops.iter().enumerate() {
        if at[i] == At::Unset {
            // No way comes to it: it never runs.
            continue;
        }
        let fail = |reason: String| ProgramError {
            program: op.at.program.clone(),
            step: Some(op.at.step),
            label: op.at.label.clone(),
            reason,
        };
        let shown = format!(
            "{} step {}{}",
            op.at.program,
            op.at.step,
            op.at
                .label
                .as_ref()
                .map(|l| format!(" ({l})"))
                .unwrap_or_default()
        );
        // An absolute target first, wherever the move starts: its reach and limits.
        let target = match &op.kind {
            OpKind::Move(_) => reach.target(op).map_err(|e| fail(format!("move: {e}")))?,
            _ => None,
        };
        if let (OpKind::Path(order), At::Known(from)) = (&op.kind, at[i])
            && blended.contains(&i)
        {
            super::blend::first_corner(ctx, order, from, op.at.step)
                .map_err(|e| fail(e.to_string()))?;
        }
        match (&op.kind, at[i]) {
            (OpKind::Move(_) | OpKind::Path(_), At::Known(from)) => {
                if let Err(e) = reach.end(i, op, from) {
                    let pose = ctx.robot.pose_of(&from).to_mm_deg();
                    let pose: Vec<String> = pose.iter().map(|v| format!("{v:.1}")).collect();
                    return Err(fail(format!(
                        "{} from where the steps before it end ({}): {e}",
                        kind(op),
                        pose.join(", ")
                    )));
                }
            }
            (OpKind::Move(_), _) if target.is_none() => unchecked.push(format!(
                "{shown}: {} from where the robot stands when it begins: checked when it runs",
                op.at.does
            )),
            (OpKind::Path(_), _) => unchecked.push(format!(
                "{shown}: a path from where the robot stands when it begins: checked when it runs"
            )),
            _ => {}
        }
    }
    Ok(unchecked)
}

fn kind(op: &Op) -> &'static str {
    match op.kind {
        OpKind::Path(_) => "path",
        _ => "move",
    }
}

struct Reach<'c> {
    ctx: &'c Context<'c>,
    /// Each motion planned from a start, by op and start: its end, or why it cannot run.
    planned: HashMap<(usize, [i64; JOINTS]), Result<[i64; JOINTS], Unplanned>>,
}

impl Reach<'_> {
    /// Where the robot stands as each op begins: the counts at the run, then every op's end
    /// carried to every op that can follow it, until nothing changes.
    fn starts(&mut self, ops: &[Op]) -> Vec<At> {
        let mut at = vec![At::Unset; ops.len()];
        if ops.is_empty() {
            return at;
        }
        at[0] = self.ctx.start.map_or(At::Varies, At::Known);
        let mut work: Vec<usize> = vec![0];
        while let Some(i) = work.pop() {
            let out = self.transfer(i, &ops[i], at[i]);
            for next in successors(ops, i) {
                let met = at[next].meet(out);
                if met != at[next] {
                    at[next] = met;
                    work.push(next);
                }
            }
        }
        at
    }

    /// Where op `i` leaves the robot, begun at `at`.
    fn transfer(&mut self, i: usize, op: &Op, at: At) -> At {
        match (&op.kind, at) {
            (OpKind::Move(_) | OpKind::Path(_), At::Known(from)) => match self.end(i, op, from) {
                Ok(end) => At::Known(end),
                // It cannot run from there (the check says so): the cycle would fault on it,
                // and go on from nowhere.
                Err(_) => At::Unset,
            },
            (OpKind::Move(_), _) => self.meant(op),
            (OpKind::Path(_) | OpKind::PalletPath { .. }, _) => At::Varies,
            _ => at,
        }
    }

    /// Where move `op` ends begun anywhere: its absolute target's counts, if it has one.
    fn meant(&self, op: &Op) -> At {
        match self.target(op) {
            Ok(Some(counts)) => At::Known(counts),
            _ => At::Varies,
        }
    }

    /// Where motion op `i` ends, planned from `from` as the daemon plans it (a move to where
    /// the robot is ends there; a line a joint reverses on runs as a path of that line).
    fn end(&mut self, i: usize, op: &Op, from: [i64; JOINTS]) -> Result<[i64; JOINTS], Unplanned> {
        let ctx = self.ctx;
        self.planned
            .entry((i, from))
            .or_insert_with(|| plan_end(ctx, op, from))
            .clone()
    }

    /// A move's absolute target, checked wherever it starts: its counts, `None` for a move
    /// whose target depends on where it starts (`by`; a pose without a tool angle keeps the
    /// start's angle, and only its reach is checked).
    fn target(&self, op: &Op) -> Result<Option<[i64; JOINTS]>, Unplanned> {
        let robot = self.ctx.robot;
        let checked = checked(self.ctx, op)?;
        if !self.ctx.poses_known && matches!(&op.kind, OpKind::Move(o) if o.position.is_some()) {
            return Ok(None);
        }
        match checked.target {
            Target::Pose { to, a_given: true } => Ok(Some(check_pose(robot, &to)?)),
            Target::Pose { to, a_given: false } => {
                let [x, y, z] = [to.position_mm.x, to.position_mm.y, to.position_mm.z];
                let pose = robot.pose_with_wrist_at_zero(x, y, z)?;
                check_pose(robot, &pose)?;
                Ok(None)
            }
            Target::Joints(user) => {
                let q = std::array::from_fn(|j| robot.joints[j].kind.from_user(user[j]));
                check_target(robot, &q)?;
                Ok(Some(robot.counts_of(&q)))
            }
            Target::By { .. } | Target::Section(_) => Ok(None),
        }
    }
}

/// The ops that can come after op `i`: the next (round to the first, for the next cycle), and
/// where a loop or a wait's `on_timeout` jumps.
fn successors(ops: &[Op], i: usize) -> Vec<usize> {
    let next = (i + 1) % ops.len();
    match &ops[i].kind {
        OpKind::Loop {
            to,
            exit: super::LoopExit::Stop,
        } => vec![*to],
        OpKind::Loop { to, .. }
        | OpKind::Skip { to, .. }
        | OpKind::Wait {
            on_timeout: Some(to),
            ..
        } => vec![next, *to % ops.len()],
        _ => vec![next],
    }
}

/// A move op's order, checked as the daemon checks it.
fn checked(ctx: &Context<'_>, op: &Op) -> Result<CheckedOrder, OrderError> {
    let OpKind::Move(order) = &op.kind else {
        unreachable!("only a move has a target");
    };
    let robot = ctx.robot;
    order.check_with(robot.motion, &OrderLimits::of(robot), ctx.taught)
}

/// Why a motion cannot run: its target out of reach or past a limit, or its plan refused from
/// where it starts.
#[derive(Debug, Clone, thiserror::Error)]
enum Unplanned {
    /// Its target is out of reach.
    #[error(transparent)]
    Kinematics(#[from] crate::kinematics::KinematicsError),
    /// Its order is wrong (a field, a name).
    #[error(transparent)]
    Order(#[from] OrderError),
    /// The planner refused it.
    #[error(transparent)]
    Plan(#[from] PlanError),
}

/// Plans motion op `op` from `from`: where it ends.
fn plan_end(ctx: &Context<'_>, op: &Op, from: [i64; JOINTS]) -> Result<[i64; JOINTS], Unplanned> {
    let robot = ctx.robot;
    let path_end = |req| -> Result<[i64; JOINTS], Unplanned> {
        let plan = crate::plan::plan_path(robot, &req)?;
        Ok(plan
            .sections
            .last()
            .map_or(from, crate::plan::SectionPlan::end_counts))
    };
    if let OpKind::Path(order) = &op.kind {
        let lookup = |name: &str| {
            ctx.taught.get(name).map(|p| {
                let [x, y, z, a] = p.pose;
                Pose::from_mm_deg(x, y, z, a)
            })
        };
        return path_end(order.request(robot, &OrderLimits::of(robot), from, &lookup)?);
    }
    let order = checked(ctx, op)?;
    match plan_order(robot, &order, from) {
        Ok(plan) => Ok(plan.end_counts()),
        Err(PlanError::ZeroLength { .. } | PlanError::NoTravel { .. }) => Ok(from),
        // A line one start cannot run runs in parts: it ends where their path does.
        Err(e) if matches!(e, PlanError::LaterSegment { .. }) || e.too_big() => {
            let to = order
                .pose_target(&robot.pose_of(&from))
                .expect("a line has a pose");
            path_end(line_as_path(&MoveRequest {
                from: Origin::Counts(from),
                to,
                motion: order.motion,
            }))
        }
        Err(e) => Err(e.into()),
    }
}
