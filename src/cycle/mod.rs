//! PURE (but [`load`], which reads the programs directory). Cycle programs: what
//! a press loader does in step with its cell, as a TOML document of steps (move, path, wait,
//! set, dwell, call, loop), checked whole against the robot and its cell before anything runs,
//! and flattened into ops the daemon's cycle runner carries
//! out (`crate::daemon`'s cycle module). docs/CYCLES.md is the user's reference.
//!
//! ```text
//! program.rs    the document: ProgramDoc, StepDoc (every key known)
//! condition.rs  a wait's condition: bits, signals, DT compares, ! & | ( ); resolved and decided
//! check.rs      ProgramDoc -> Checked { ops }: names, limits, labels, calls inlined
//! reach.rs      where the ops take the robot: targets in reach and limits, motions planned
//!               from every start known before the run
//! load.rs       a robot's programs directory, path files read in
//! ```

pub mod check;
pub mod condition;
pub mod load;
pub mod program;
mod reach;

pub use check::{Checked, Context, LoopExit, Op, OpKind, ProgramError, check};
pub use condition::{Condition, ConditionError, Names, Source};
pub use load::Programs;
pub use program::{LoopDoc, PathStep, ProgramDoc, StepDoc};

#[cfg(test)]
mod tests;
