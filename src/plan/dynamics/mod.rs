//! PURE. What the drives behind the pulse outputs can follow ([`crate::robot::Dynamics`]): the
//! time-optimal motion along a line or path section under every joint's limits ([`timing`]),
//! and every table's rows checked against them ([`rows`]); a line and a joint move under them
//! ([`moves`]); an S-curve as the time-optimal motion averaged to its jerk
//! ([`averaged`](mod@averaged)) or slowed as a whole until the drives follow it
//! ([`slowed`](mod@slowed)), its joints' jerk measured on the planned motion ([`jerk`]).
//!
//! It imports nothing of the planner above it but its vocabulary (`crate::plan::error`,
//! `crate::plan::planned`, `crate::plan::samples`): which timing is planned, and which plan
//! kept, is the planner's strategy (`crate::plan::strategy`).

mod averaged;
mod jerk;
mod moves;
mod rows;
mod slowed;
mod timing;

pub(super) use averaged::{Averaging, averaged};
pub(super) use moves::{joint_move_motion, timed_line};
pub(super) use rows::{judge, planned_accels};
pub(super) use slowed::{clearly_over_max_accel, jerk_needs_s_curve, slowed, within_limits};
pub(super) use timing::{PathLimits, RETIMING, Shape, Shares, pace};

#[cfg(test)]
mod tests;
