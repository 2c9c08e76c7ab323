//! PURE. What the drives behind the pulse outputs can follow ([`crate::robot::Dynamics`]): the
//! time-optimal motion along a line or path section under every joint's limits ([`timing`]),
//! and every table's rows checked against them ([`rows`]).

mod rows;
mod timing;

pub use rows::DriveFigures;
pub(super) use rows::judge;
pub(super) use timing::{ACCEL_MARGIN, PathLimits, START_MARGIN, Shape, pace};

#[cfg(test)]
mod tests;
