//! PURE. What the drives behind the pulse outputs can follow ([`crate::robot::Dynamics`]): the
//! time-optimal motion along a line or path section under every joint's limits ([`timing`]),
//! and every table's rows checked against them ([`rows`]); a line and a joint move under them
//! ([`moves`]); an S-curve as the time-optimal motion averaged to its jerk
//! ([`averaged`](mod@averaged)) or slowed as a whole until the drives follow it
//! ([`slowed`](mod@slowed)), whichever is faster, its joints' jerk measured on the planned
//! motion ([`jerk`]).

mod averaged;
mod jerk;
mod moves;
mod rows;
mod slowed;
mod timing;

pub(super) use averaged::{Shares, averaged, averaged_line, faster_s_curve, probe};
use moves::timed_line_at;
pub(super) use moves::{joint_move_motion, rest_rows_first, timed_line};
pub use rows::DriveFigures;
pub(super) use rows::{judge, planned_accels};
use slowed::refused_by_a_drive;
pub(super) use slowed::{
    clearly_over_max_accel, followed, jerk_needs_s_curve, slowed, within_limits,
};
pub(super) use timing::{PathLimits, RETIMING, Shape, pace};

#[cfg(test)]
mod tests;
