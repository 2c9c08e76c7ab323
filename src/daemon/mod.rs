//! The daemon: one task per robot owns its PLC link and runs moves through the register contract
//! (the worker); the rest of the program talks to it through a [`RobotHandle`] per robot.
//!
//! ```text
//! API / CLI --submit/stop/clear/state--> RobotHandle --requests (stops overtake)--> worker task
//!                                            ^                                          |
//!                                            +---- RobotState, MoveReport feeds <-------+
//! ```
//!
//! [`notify`] tells systemd the daemon is ready, alive and stopping.

pub mod api;
mod handle;
pub mod notify;
mod order;
mod report;
pub mod service;
mod worker;

pub use handle::{CommandError, Daemon, RobotHandle, SubmitError};
pub use order::{CheckedOrder, MoveOrder, OrderError};
pub use report::{LinkState, MoveId, MoveReport, Moves, Predicted, RobotState, Stage};
pub use worker::Connector;
pub(crate) use worker::plan_order;
