//! PURE (but [`load`] and [`names`], which read the programs directory). Cycle programs: what
//! a press loader does in step with its cell, as a TOML document of steps (move, path, wait,
//! set, dwell, call, loop), checked whole against the robot and its cell before anything runs,
//! and flattened into ops the daemon's cycle runner carries
//! out (`crate::daemon`'s cycle module). docs/CYCLES.md is the user's reference.
//!
//! ```text
//! program.rs    the document: ProgramDoc, StepDoc (every key known)
//! condition.rs  a wait's condition: bits, signals, DT compares, ! & | ( ); resolved and decided
//! check.rs      ProgramDoc -> Checked { ops }: names, limits, labels, calls inlined
//! load.rs       a robot's programs directory, path files read in
//! names.rs      whether a program is there at all
//! ```

pub mod check;
pub mod condition;
pub mod load;
pub mod names;
pub mod program;

pub use check::{Checked, Context, LoopExit, Op, OpKind, ProgramError, check, numbers};
pub use condition::{Condition, ConditionError, Names, Source};
pub use program::{LoopDoc, PathStep, ProgramDoc, StepDoc};

#[cfg(test)]
mod tests;
