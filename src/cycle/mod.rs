//! PURE (but [`load`], which reads the programs directory). Cycle programs: what
//! a press loader does in step with its cell, as a TOML document of steps (move, path, wait,
//! set, dwell, call, loop), checked whole against the robot and its cell before anything runs,
//! and flattened into ops that [`Runner`] steps through, as the daemon's cycle driver
//! (`crate::daemon`'s cycle module) carries its actions out. docs/CYCLES.md is the user's reference.
//!
//! ```text
//! program.rs    the document: ProgramDoc, StepDoc (every key known, as TOML and JSON write it)
//! step.rs       StepDoc -> Step { label, action: Action }: the document's shape checked once
//! condition.rs  a wait's condition: bits, signals, DT compares, ! & | ( ); resolved and decided
//! check.rs      ProgramDoc -> Checked { ops }: names, limits, labels, calls inlined
//! blend.rs      consecutive move steps with blend_mm -> one path op (its corners checked)
//! reach.rs      where the ops take the robot: targets in reach and limits, motions planned
//!               from every start known before the run
//! load.rs       a robot's programs directory, path files read in
//! runner/       Runner: the program counter, loops, cycles, moves prepared ahead; events in,
//!               actions out (the daemon's cycle driver carries them out)
//! ```

mod blend;
pub mod check;
pub mod condition;
pub mod load;
mod place;
pub mod program;
mod reach;
pub mod runner;
pub mod step;

pub use check::{Checked, Context, DurationFault, LoopExit, Op, OpKind, ProgramError};

/// Checks program `name` of `ctx.programs`, and every program it calls: each step on its own,
/// then every target it can reach ([`reach`]).
///
/// # Errors
/// The first fault found, naming the program, the step and the value.
pub fn check(name: &str, ctx: &Context<'_>) -> Result<Checked, ProgramError> {
    let mut checked = check::flatten(name, ctx)?;
    checked.unchecked = reach::check(&checked.ops, &checked.blended, ctx)?;
    Ok(checked)
}
pub use condition::{
    Condition, ConditionError, ConditionFault, Names, PalletTerm, PalletView, Source,
};
pub use load::{ProgramFileError, Programs};
pub use program::{LoopDoc, PathStep, ProgramDoc, StepDoc};
pub use runner::Runner;
pub use step::{ShapeError, Step};

#[cfg(test)]
mod tests;
