//! PURE. What the drives behind the pulse outputs can follow ([`crate::robot::Dynamics`]): the
//! time-optimal motion along a line or path section under every joint's limits ([`timing`]),
//! and every table's rows checked against them ([`rows`]); a line and a joint move under them
//! ([`moves`]); an S-curve slowed as a whole until the drives follow it ([`slowed`]), its
//! joints' jerk measured on the planned motion ([`jerk`]).

mod jerk;
mod moves;
mod rows;
mod slowed;
mod timing;

pub(super) use moves::{joint_move_motion, rest_rows_first, timed_line};
pub use rows::DriveFigures;
pub(super) use rows::judge;
pub(super) use slowed::{followed, jerk_needs_s_curve, slowed, within_limits};
pub(super) use timing::{PathLimits, RETIMING, Shape, pace};

#[cfg(test)]
mod tests;
