//! PURE. Consecutive move steps blended into one path: a move step with `blend_mm` does not
//! stop at its end but rounds the corner into the next move step, so a pick-and-place cycle
//! passes its waypoints above the pick and the place without stopping.
//!
//! ```text
//!   step 3  move to @above-pick   blend_mm = 20  ┐
//!   step 4  move to @above-place  blend_mm = 20  ├─ one path op, named for step 3:
//!   step 5  move to @place                       ┘  lines to each target, 20 mm blends at
//!                                                   the ends of steps 3 and 4, a stop at 5's
//! ```
//!
//! The run begins at a move with `blend_mm` and takes the move steps after it while each one
//! before has `blend_mm`; it ends at the first move without, which ends exactly on its target.
//! Its moves are lines to a pose or a taught position (`to`, `position`), one after the other
//! in the program with nothing between: a step that is not a move, a labelled step (a loop or
//! a wait's `on_timeout` could land on it, in the middle of the path) or the program's end
//! after a blended move is refused, naming the step, never run as a stop. They share one
//! motion (speed, acceleration, method, period, tolerance, profile, jerk) and one permit, as
//! a path has. Each corner's blend is at most half of the shorter move beside it (the path's
//! own geometry would take no more than that: here it is refused rather than made smaller),
//! above 0, and the corner must not turn the path back on itself; checked where both moves
//! beside it are known when the program is checked (the first corner once the run's start is
//! known: [`first_corner`], called by `super::reach`).

use nalgebra::Vector3;
use serde_json::json;
use thiserror::Error;

use super::check::{Flattener, Here, ProgramError};
use super::program::StepDoc;
use super::step::{Action, Step};
use crate::geometry::{Corner as Pass, Element, Path, PathError, PathSpec, Pose};
use crate::kinematics::JOINTS;
use crate::order::{MoveOrder, OrderLimits, PathOrder};

/// One move of a run, as the check reads it.
struct RunMove {
    order: MoveOrder,
    blend_mm: Option<f64>,
    /// The run's path acceleration, on its first move only.
    path_accel: Option<serde_json::Value>,
    /// Where its target is, mm, when known now.
    at_mm: Option<Vector3<f64>>,
}

impl Flattener<'_, '_> {
    /// The run of move steps beginning at `steps[0]` (converted: `first`, with `blend_mm`),
    /// pushed as one path op named for `here`, its first step.
    ///
    /// Returns how many steps it took.
    ///
    /// # Errors
    /// A step of it that cannot run blended (the module's rules), naming that step.
    pub(super) fn blended(
        &mut self,
        steps: &[StepDoc],
        first: &Step,
        here: &Here<'_>,
    ) -> Result<usize, ProgramError> {
        let mut run = vec![self.run_move(first, here)?];
        while run.last().is_some_and(|m| m.blend_mm.is_some()) {
            let n = run.len();
            let before = &run[n - 1];
            let next = self.next_move(steps.get(n), before, here, n)?;
            same_motion(&run[0].order, &next.order, here.step)
                .map_err(|r| here.later(n, None).fail(r.to_string()))?;
            if next.path_accel.is_some() {
                return Err(here.later(n, None).fail(format!(
                    "path_accel goes on the first move of a blended run (step {}): the run is one \
                     path, with one acceleration",
                    here.step
                )));
            }
            run.push(next);
        }
        for k in 1..run.len() - 1 {
            let [before, at, after] = [&run[k - 1], &run[k], &run[k + 1]];
            if let (Some(b), Some(p), Some(a)) = (before.at_mm, at.at_mm, after.at_mm) {
                let blend_mm = at.blend_mm.unwrap_or_default();
                corner(b, p, a, blend_mm, here.step + k + 1)
                    .map_err(|r| here.later(k, None).fail(r.to_string()))?;
            }
        }
        let order = path_of(&run);
        let flat = self.path_step(&order, &|r| here.fail(r))?;
        let super::check::Flat::Motion(kind, _, permit) = flat else {
            unreachable!("a path step is one motion")
        };
        self.push_blended(here, kind, describe(&run, here.step), permit);
        Ok(run.len())
    }

    /// Step `n` of the run (from 0), which the move before it blends into: a move without a
    /// label, checked as a move step.
    fn next_move(
        &self,
        doc: Option<&StepDoc>,
        before: &RunMove,
        here: &Here<'_>,
        n: usize,
    ) -> Result<RunMove, ProgramError> {
        let blend = before.blend_mm.unwrap_or_default();
        let blender = here.later(n - 1, None);
        let refuse = |why: String| {
            blender.fail(format!(
                "blend_mm = {blend} rounds this move's end into the next step, but {why}; \
                 leave out blend_mm to stop there"
            ))
        };
        let Some(doc) = doc else {
            return Err(refuse("this is the program's last step".to_owned()));
        };
        let next = step_here(doc, &here.later(n, doc.label.as_ref()))?;
        if !matches!(next.action, Action::Move(_)) {
            return Err(refuse(format!(
                "step {} is not a move: only consecutive move steps blend",
                here.step + n
            )));
        }
        if let Some(label) = &next.label {
            return Err(refuse(format!(
                "step {} is labelled {label:?}: a jump could land there, in the middle of the \
                 blended path",
                here.step + n
            )));
        }
        self.run_move(&next, &here.later(n, None))
    }

    /// A move step of a run, checked as a move step, with its target's position if known.
    fn run_move(&self, step: &Step, here: &Here<'_>) -> Result<RunMove, ProgramError> {
        let Action::Move(order) = &step.action else {
            unreachable!("a blend goes with a move (the step's shape)")
        };
        self.move_step(order, &|r| here.fail(r))?;
        if let Some(b) = step.blend_mm
            && !(b.is_finite() && b > 0.0)
        {
            return Err(here.fail(format!(
                "blend_mm = {b}: must be a number of mm above 0 (leave it out to stop at the \
                 move's end)"
            )));
        }
        let at_mm = match (&order.to, &order.position) {
            (Some(to), _) => Some(Vector3::new(to[0], to[1], to[2])),
            (None, Some(name)) => self.taught_at(name),
            (None, None) => {
                let kind = if order.by.is_some() { "by" } else { "joints" };
                return Err(here.fail(format!(
                    "move {kind} cannot run in a blended run: its moves are lines to a pose or \
                     a taught position (to, position)"
                )));
            }
        };
        Ok(RunMove {
            order: order.clone(),
            blend_mm: step.blend_mm,
            path_accel: step.path_accel.clone(),
            at_mm,
        })
    }

    /// A taught position's place, when the poses are known.
    fn taught_at(&self, name: &str) -> Option<Vector3<f64>> {
        let [x, y, z, _] = self.ctx.taught.get(name)?.pose;
        self.ctx.poses_known.then(|| Vector3::new(x, y, z))
    }
}

/// `doc` converted, its shape's fault named for its step.
fn step_here(doc: &StepDoc, here: &Here<'_>) -> Result<Step, ProgramError> {
    Step::try_from(doc).map_err(|e| here.fail(e.to_string()))
}

/// The motion keys of a move and their values as written, and its permit.
fn motion_keys(o: &MoveOrder) -> impl Iterator<Item = (&'static str, Option<String>)> {
    o.motion
        .shown()
        .into_iter()
        .chain([("permit", o.permit.clone())])
}

/// Why a blended run's moves or corner cannot be one path, in the words of the refusal.
#[derive(Debug, Error)]
pub(super) enum BlendError {
    /// A move of the run moves otherwise than its first.
    #[error(
        "this move's {key} ({this}) differs from step {first_step}'s ({first}): the moves of a \
         blended run are one path with one motion and one permit; give them the same or leave \
         out blend_mm"
    )]
    OtherMotion {
        key: &'static str,
        this: String,
        first: String,
        first_step: usize,
    },
    /// The blended move does not move the tool.
    #[error(
        "the move ends where it starts: a blended move must move the tool (leave it out, or its \
         blend_mm)"
    )]
    NoMove,
    /// The move after it ends where this one does.
    #[error(
        "blend_mm = {blend_mm}: step {next_step} ends where this move ends: there is no corner \
         to round (leave out blend_mm)"
    )]
    NoCorner { blend_mm: f64, next_step: usize },
    /// The move after it turns back.
    #[error(
        "blend_mm = {blend_mm}: step {next_step} turns back by {turn_deg:.1} deg from this move: \
         no blend can round that (leave out blend_mm to stop there)"
    )]
    TurnsBack {
        blend_mm: f64,
        next_step: usize,
        turn_deg: f64,
    },
    /// The corner's path cannot be built otherwise.
    #[error("blend_mm = {blend_mm}: {source}")]
    Path {
        blend_mm: f64,
        #[source]
        source: PathError,
    },
    /// The blend is more than half the shorter move beside it.
    #[error(
        "blend_mm = {blend_mm} is more than this corner allows: at most {max_mm:.1} mm, half the \
         shorter of the moves beside it (this move {into_mm:.1} mm, step {next_step}'s \
         {out_of_mm:.1} mm)"
    )]
    TooLarge {
        blend_mm: f64,
        max_mm: f64,
        into_mm: f64,
        out_of_mm: f64,
        next_step: usize,
    },
}

/// Whether `next` moves as `first` (step `first_step`) does: one path has one motion.
fn same_motion(first: &MoveOrder, next: &MoveOrder, first_step: usize) -> Result<(), BlendError> {
    let shown = |v: Option<String>| v.unwrap_or_else(|| "not given".to_owned());
    for ((key, a), (_, b)) in motion_keys(first).zip(motion_keys(next)) {
        if a != b {
            return Err(BlendError::OtherMotion {
                key,
                this: shown(b),
                first: shown(a),
                first_step,
            });
        }
    }
    Ok(())
}

/// The corner at `at` between the moves from `before` and on to `after`, blended by
/// `blend_mm`: refused when the moves beside it cannot hold the blend. `next_step` is the
/// step of the move after it.
fn corner(
    before: Vector3<f64>,
    at: Vector3<f64>,
    after: Vector3<f64>,
    blend_mm: f64,
    next_step: usize,
) -> Result<(), BlendError> {
    let line = |p: Vector3<f64>| Element::Line {
        to: Pose {
            position_mm: p,
            a_rad: 0.0,
        },
    };
    let spec = PathSpec {
        start: Pose {
            position_mm: before,
            a_rad: 0.0,
        },
        elements: vec![(line(at), Pass::Blend(blend_mm)), (line(after), Pass::Stop)],
    };
    Path::build(&spec).map_err(|e| match e {
        PathError::NoLength { element: 1, .. } => BlendError::NoMove,
        PathError::NoLength { .. } => BlendError::NoCorner {
            blend_mm,
            next_step,
        },
        PathError::Reversal { turn_deg, .. } => BlendError::TurnsBack {
            blend_mm,
            next_step,
            turn_deg,
        },
        source => BlendError::Path { blend_mm, source },
    })?;
    let (into_mm, out_of_mm) = ((at - before).norm(), (after - at).norm());
    let max_mm = into_mm.min(out_of_mm) / 2.0;
    if blend_mm > max_mm + 1e-9 {
        return Err(BlendError::TooLarge {
            blend_mm,
            max_mm,
            into_mm,
            out_of_mm,
            next_step,
        });
    }
    Ok(())
}

/// The path a run makes: a line to each move's target, blended where asked, with the first
/// move's motion, permit and path acceleration; it starts where the robot is.
fn path_of(run: &[RunMove]) -> PathOrder {
    let elements: Vec<serde_json::Value> = run
        .iter()
        .map(|m| {
            let to = match (&m.order.to, &m.order.position) {
                (Some(to), _) => json!(to),
                (None, Some(name)) => json!(format!("@{name}")),
                (None, None) => unreachable!("a run's moves have a pose or a position"),
            };
            match m.blend_mm {
                Some(b) => json!({"line": to, "blend": b}),
                None => json!({"line": to, "stop": true}),
            }
        })
        .collect();
    let o = &run[0].order;
    let mut path = json!({ "element": elements });
    if let Some(accel) = &run[0].path_accel {
        path["path_accel"] = accel.clone();
    }
    PathOrder {
        path,
        motion: o.motion.clone(),
        permit: o.permit.clone(),
    }
}

/// What the status shows of a run beginning at step `first`.
fn describe(run: &[RunMove], first: usize) -> String {
    let moves: Vec<String> = run
        .iter()
        .map(|m| {
            let to = super::check::describe_move(&MoveOrder {
                permit: None,
                ..m.order.clone()
            });
            match m.blend_mm {
                Some(b) => format!("{to} (blend {b} mm)"),
                None => to,
            }
        })
        .collect();
    let last = first + run.len() - 1;
    let permit = run[0]
        .order
        .permit
        .as_ref()
        .map(|p| format!(" (permit {p})"))
        .unwrap_or_default();
    format!(
        "blended moves, steps {first} to {last}{permit}: {}",
        moves.join(", ")
    )
}

/// The first corner of blended run `order` (a path op made by [`Flattener::blended`] at
/// `step`), checked once the run's start `from` is known: its blend against the move into it.
///
/// # Errors
/// Why it cannot be blended.
pub(super) fn first_corner(
    ctx: &super::Context<'_>,
    order: &PathOrder,
    from: [i64; JOINTS],
    step: usize,
) -> Result<(), BlendError> {
    let robot = ctx.robot;
    let lookup = |name: &str| {
        ctx.taught.get(name).map(|p| {
            let [x, y, z, a] = p.pose;
            Pose::from_mm_deg(x, y, z, a)
        })
    };
    let Ok(req) = order.request(robot, &OrderLimits::of(robot), from, &lookup) else {
        // The plan refuses it, naming why.
        return Ok(());
    };
    let (Some((first, Pass::Blend(blend_mm))), Some((second, _))) =
        (req.elements.first(), req.elements.get(1))
    else {
        return Ok(());
    };
    let start = robot.pose_of(&from).position_mm;
    corner(
        start,
        first.to().position_mm,
        second.to().position_mm,
        *blend_mm,
        step + 1,
    )
}

#[cfg(test)]
mod tests;
