//! Cycle programs run by the daemon: one cycle at a time per robot, driven through the robot's
//! handle like any client (its moves are queued and reported as every move is), watched by a
//! status anyone can read, steered by a control value (stop, pause, resume).
//!
//! ```text
//! control.rs  Control: a stop (now, or at the step's end), a pause, the resumes asked for
//! act.rs      what the steps do: a move or path followed to its end, a wait on the inputs, a
//!             dwell
//! run.rs      the runner: a checked program's ops, one after another, in step with the control
//! slot.rs     the robot's cycle: at most one running, its status, its controller
//! handle.rs   RobotHandle's cycle methods: run (checked first), watch, stop, pause, resume
//! ```
//! A cycle never resumes by itself: after a fault it needs `clear-fault` and `resume` (or a
//! fresh `run`); a restarted daemon has no cycle.

mod act;
mod control;
mod handle;
mod run;
mod slot;

pub(crate) use run::run;
pub use slot::CycleError;
pub(crate) use slot::CycleSlot;
