//! The daemon: one task per robot owns its PLC link and runs moves through the register contract
//! (the worker), one owns its cycle and one its cell (the mode, the cell face); the rest of the
//! program talks to them through a [`RobotHandle`] per robot, which sends requests and reads
//! what they publish.
//!
//! ```text
//! API / CLI --submit/stop/home/clear--> RobotHandle --requests (stops overtake)--> worker task
//!                                         |  |  +--CycleRequest--> cycle owner --> its driver
//!                                         |  +-----CellRequest---> cell owner (mode, face)
//!                                         +<--- Shared: snapshot, reports, cycle, cell (watches)
//! ```
//! ```text
//! handle/     RobotHandle: a thin sender of requests and a reader of what the owners publish
//! robots.rs   Daemon: spawns per robot its handle, worker, cycle owner and cell owner
//! setup.rs    RobotSetup, DaemonOptions
//! shared.rs   what the owners publish (Snapshot, the cycle's status, CellView) and the reports
//! request/    what a handle asks the worker, the cycle's owner and the cell's, and their typed
//!             errors (CommandError, SubmitError, CycleError, ModeError)
//! order.rs    a move order (to, by, joints or position), its check, and planning it
//! positions.rs taught positions per robot, kept in the state directory
//! state_file.rs a state file read at start (positions, pallets): a corrupt one set aside
//! report.rs   RobotState (RobotPhase), MoveReport (Stage, SectionReport), MoveAccepted,
//!             PathAccepted: what the API writes and the CLI reads back
//! ids.rs      move ids unique across restarts
//! cell/       the robot in its cell: the cell's owner task (the mode, local/remote; the cell
//!             face's daemon side), the face mirrored in the PLC
//! cycle/      cycle programs: the cycle's owner task, the driver of its pure Runner
//! gateway.rs  register gateway requests (the cell's other registers, through the same link)
//! modbus_face/ the gateway's Modbus TCP server face, one per robot that configures it
//! worker/     the link owner: contract::machine drives it
//! service.rs  `linterpd serve`; api/ the HTTP API; notify.rs systemd
//! journal.rs  the follower: each robot's published changes journaled (faults, cycles, holds,
//!             modes, the face's commands)
//! stream.rs   the live stream: one publisher per robot of its snapshot's changes, read by the
//!             API's NDJSON feed and the console
//! console/    the operator's console's server: the seat and jog lease's control task per robot,
//!             the page, its WebSocket and logins
//! ```

pub mod api;
mod cell;
pub mod console;
mod cycle;
pub mod gate;
mod gateway;
mod handle;
mod ids;
pub mod journal;
mod live;
pub mod metrics;
pub mod modbus_face;
pub mod notify;
pub mod pallets;
pub mod positions;
mod report;
mod request;
mod robots;
pub mod service;
mod setup;
mod shared;
mod state_file;
pub mod stream;
mod worker;

pub use crate::order::permit;
pub(crate) use crate::order::plan_order;
pub use crate::order::{
    CheckedOrder, MAX_ACCEL_TIME_S, MAX_PATH_ELEMENTS, MoveOrder, OrderError, OrderLimits,
    PERIOD_RANGE_S, PathOrder, SectionOrder, SectionPart, TOLERANCE_RANGE_MM, Target,
};
pub use crate::wire::{CycleState, CycleStatus, StepAt};
pub use crate::wire::{
    FaceRefusal, FaceState, GatewayStats, LinkState, MoveAccepted, MoveId, MoveReport,
    PathAccepted, PieceKind, PieceReport, Predicted, RobotPhase, RobotState, SectionReport, Stage,
};
pub use cell::{MIRROR_EVERY, mirror_face};
pub use gateway::{GatewayError, MAX_BITS, MAX_WORDS, Values, values_from_json};
pub use handle::{PalletCommand, PalletOpError, RobotHandle, Saved};
pub use ids::{MoveIds, write_atomically};
pub use positions::{Position, PositionError, TaughtPositions};
pub use report::{KEPT, Moves};
pub use request::{
    CommandError, ConflictReason, CycleError, MAX_QUEUED_STARTS, ModeError, Owner, SubmitError,
};
pub use robots::Daemon;
pub use setup::Connector;
pub use setup::{DaemonOptions, RobotSetup, host_word};
pub use shared::{CellView, Incidents, Reads, Snapshot};
