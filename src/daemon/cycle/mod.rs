//! Cycle programs run by the daemon: one cycle at a time per robot, driven through the robot's
//! handle like any client (its moves are queued and reported as every move is), watched by a
//! status anyone can read, steered by a control value (stop, pause, hold, resume:
//! [`crate::cycle::runner::Control`]). What the cycle does next is decided by the pure
//! [`crate::cycle::Runner`]; this module carries its actions out.
//!
//! ```text
//! run.rs      the driver: the runner's actions carried out, what came of them fed back, the
//!             cycle's status written
//! act.rs      what the steps do: a move or path followed to its end, a wait on the inputs, a
//!             dwell, a loop's condition decided, moves prepared ahead unprepared; what a pause
//!             and a fault do to the robot
//! pallet.rs   the pallet steps: counters changed on disk (and journaled), the way into and
//!             out of the slot in progress queued as paths, what conditions read of a pallet
//! seen.rs     what the driver sees before each decision (the control, the PLC's incidents)
//!             and waits on: a change of the control, an incident
//! status.rs   the cycle's status as the driver writes it
//! slot.rs     the robot's cycle's owner task: at most one running, its status, its control
//! handle.rs   RobotHandle's cycle methods: run (checked first), stop, pause, resume, each a
//!             request to the owner
//! ```
//! A cycle never resumes by itself: after a fault it needs `clear-fault` and `resume` (or a
//! fresh `run`); a restarted daemon has no cycle.

mod act;
mod handle;
mod pallet;
mod run;
mod seen;
mod slot;
mod status;

pub(crate) use slot::own;
